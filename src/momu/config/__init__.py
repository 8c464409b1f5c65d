"""Configs: OmegaConf trees whose component nodes are validated against their part's dataclass.

A *component node* is a mapping ``{name: <registry name>, **params}`` (or just the bare name)
stored under a key that names a registry kind:

* a key equal to a kind's singular (``backbone``, ``encoder``, ``loss``, ``sampler``,
  ``scheduler``, ``vocoder``, ``metric``, ``dataset``, ``method``) or ending in ``_<singular>``
  (``music_encoder``, ``motion_encoder``) holds one component of that kind;
* a key equal to a kind's plural or ending in ``_<plural>`` (``metrics``, ``aux_losses``) holds
  a list of components.

Validation merges each node's params into its part's config dataclass, so a misspelled key is
an error naming the valid keys, missing params take their defaults, and values are type-checked.
Components nest: a part's dataclass may hold component nodes of its own (a method's backbone).
A bare-name override (``backbone=unet1d``) replaces the whole node, dropping the old params.
"""

from __future__ import annotations

import json
from collections.abc import Iterable, Mapping, Sequence
from pathlib import Path
from typing import Any

from omegaconf import DictConfig, ListConfig, OmegaConf
from omegaconf.errors import ConfigAttributeError, ConfigKeyError, OmegaConfBaseException

from momu.config.keys import (
    ALLOWED_RESOLVERS,
    field_names,
    find_built_interpolation,
    find_refused_resolver,
    innermost_node,
)
from momu.io import atomic_write_text
from momu.registry import KINDS, Entry, PluginError, RegistryError, registry_for, singular

__all__ = [
    "ConfigError",
    "component_kind",
    "load_config",
    "apply_overrides",
    "validate",
    "instantiate_config",
    "build_component",
    "save_config",
    "to_container",
]


class ConfigError(ValueError):
    """A config that cannot be loaded or does not validate; the message names the key.

    Attributes:
        key: the dotted key at fault, when one is (``method.train_diffusion.stpes``).
    """

    def __init__(self, message: str, key: str | None = None) -> None:
        super().__init__(message)
        self.key = key


def _unknown_key(schema: type, key: str, path: str, label: str = "") -> ConfigError:
    """``<path.key>: unknown key for <innermost node>; valid keys: <that node's fields>``."""
    prefix, cls = innermost_node(schema, key)
    full = _join(path, key)
    valid = ", ".join(field_names(cls))
    if prefix:
        owner = f" of {label}" if label else ""
        where = f" for {_join(path, prefix)} ({cls.__name__}){owner}"
    else:
        where = f" for {label}" if label else ""
    return ConfigError(f"{full}: unknown key{where}; valid keys: {valid}", key=full)


def component_kind(key: str) -> tuple[str, bool] | None:
    """``(kind, is_list)`` when ``key`` names a component node, else ``None``.

    >>> component_kind("music_encoder")
    ('encoders', False)
    >>> component_kind("metrics")
    ('metrics', True)
    """
    for kind in KINDS:
        one = singular(kind)
        if key == one or key.endswith("_" + one):
            return kind, False
        if key == kind or key.endswith("_" + kind):
            return kind, True
    return None


def _join(path: str, key: Any) -> str:
    return f"{path}.{key}" if path else str(key)


def _plain(node: Any, resolve: bool = True) -> Any:
    if isinstance(node, (DictConfig, ListConfig)):
        try:
            return OmegaConf.to_container(node, resolve=resolve)
        except OmegaConfBaseException as exc:
            raise ConfigError(f"cannot resolve the config: {str(exc).splitlines()[0]}") from None
    return node


def _entry(kind: str, name: Any, path: str) -> Entry:
    if not isinstance(name, str):
        raise ConfigError(f"{path}: a {singular(kind)} node needs a 'name' (a registered {kind} name)")
    try:
        return registry_for(kind).get(name)
    except (RegistryError, PluginError) as exc:
        raise ConfigError(f"{path}: {exc}") from exc


def _merge_params(entry: Entry, params: Mapping[str, Any], path: str) -> Any:
    """Merge ``params`` into the entry's structured config; errors name the key and valid keys."""
    label = f"{singular(entry.kind)} '{entry.name}'"
    if entry.config is None:
        if params:
            raise ConfigError(f"{path}: {label} takes no parameters, got {', '.join(map(str, params))}")
        return OmegaConf.create({})
    schema = OmegaConf.structured(entry.config)
    try:
        return OmegaConf.merge(schema, dict(params))
    except (ConfigKeyError, ConfigAttributeError) as exc:
        key = getattr(exc, "full_key", None) or getattr(exc, "key", None) or "?"
        raise _unknown_key(entry.config, str(key), path, label) from None
    except OmegaConfBaseException as exc:
        key = getattr(exc, "full_key", None) or "?"
        msg = str(exc).splitlines()[0]
        raise ConfigError(
            f"{_join(path, key)}: invalid value for {label}: {msg}", key=_join(path, key)
        ) from None


def _validate_component(node: Any, kind: str, path: str) -> dict[str, Any]:
    node = _plain(node)
    if isinstance(node, str):
        node = {"name": node}
    if not isinstance(node, Mapping):
        raise ConfigError(f"{path}: expected a {singular(kind)} name or {{name: ..., params}}, got {node!r}")
    params = {k: v for k, v in node.items() if k != "name"}
    entry = _entry(kind, node.get("name"), path)
    merged: Any = OmegaConf.to_container(_merge_params(entry, params, path), resolve=True)
    return {"name": entry.name, **_validate_tree(merged, path)}


def _validate_tree(tree: Mapping[str, Any], path: str) -> dict[str, Any]:
    out: dict[str, Any] = {}
    for key, value in tree.items():
        sub = _join(path, key)
        found = component_kind(str(key))
        if found is None or value is None:
            out[key] = _validate_tree(value, sub) if isinstance(value, Mapping) else value
        elif found[1]:
            if not isinstance(value, Sequence) or isinstance(value, str):
                raise ConfigError(f"{sub}: expected a list of {found[0]}, got {value!r}")
            out[key] = [_validate_component(v, found[0], f"{sub}[{i}]") for i, v in enumerate(value)]
        else:
            out[key] = _validate_component(value, found[0], sub)
    return out


def _refuse_resolvers(cfg: Any) -> None:
    """Refuse ``${oc.env:...}`` and every resolver not in the allow-list, before anything is resolved."""
    found = find_refused_resolver(_plain(cfg, resolve=False))
    if found is None:
        return
    key, name = found
    if name == "oc.env":
        raise ConfigError(
            f"{key}: ${{oc.env:...}} interpolation is disabled in momu configs (it would copy "
            "environment values such as tokens into printed and saved configs); write the value, or "
            "let the shell expand it in an override (key=$VAR)",
            key=key,
        )
    allowed = ", ".join(f"${{{r}:...}}" for r in ALLOWED_RESOLVERS)
    raise ConfigError(
        f"{key}: resolver {name!r} is disabled in momu configs (only ${{other.key}} references and "
        f"{allowed} are resolved: a resolver can build ${{oc.env:...}} and copy environment values "
        "into printed and saved configs); write the value",
        key=key,
    )


def _refuse_built_interpolations(resolved: Any) -> None:
    """Refuse a resolved value that holds ``${`` (an interpolation assembled while resolving)."""
    key = find_built_interpolation(resolved)
    if key is not None:
        raise ConfigError(
            f"{key}: resolves to text holding '${{' (an interpolation assembled from escaped text or "
            "pieces, which would be resolved again); write the value",
            key=key,
        )


def _check_schema(resolved: dict[str, Any], schema: type, fill_defaults: bool) -> dict[str, Any]:
    """Merge ``resolved`` into ``schema``; top-level component nodes it does not declare pass through.

    Component nodes were validated against their parts already; every other key must be a field.
    """
    declared = set(field_names(schema))
    passthrough = {k: v for k, v in resolved.items() if k not in declared and component_kind(str(k))}
    rest = {k: v for k, v in resolved.items() if k not in passthrough}
    try:
        checked = OmegaConf.merge(OmegaConf.structured(schema), rest)
    except (ConfigKeyError, ConfigAttributeError) as exc:
        key = getattr(exc, "full_key", None) or getattr(exc, "key", None) or "?"
        raise _unknown_key(schema, str(key), "") from None
    except OmegaConfBaseException as exc:
        key = getattr(exc, "full_key", None) or "?"
        raise ConfigError(f"{key}: invalid value: {str(exc).splitlines()[0]}", key=str(key)) from None
    if not fill_defaults:
        return resolved
    merged: Any = OmegaConf.to_container(checked, resolve=True)
    return {**merged, **passthrough}


def validate(cfg: Any, schema: type | None = None, *, fill_defaults: bool = True) -> DictConfig:
    """Validate every component node of ``cfg`` (and every other key against ``schema``); freeze it.

    ``${oc.env:...}`` interpolations are refused (they would copy secrets into saved configs), and so
    is every resolver but :data:`~momu.config.keys.ALLOWED_RESOLVERS` and any resolved value that
    still holds ``${`` (``oc.decode`` and pieces can assemble an ``oc.env`` call while resolving).
    With ``fill_defaults=False`` the schema checks keys and types but adds no missing keys.

    Raises:
        ConfigError: the first bad key, named by its dotted path, with the valid keys of the
            innermost node it falls in.
    """
    _refuse_resolvers(cfg)
    tree = _plain(cfg)
    _refuse_built_interpolations(tree)
    if not isinstance(tree, Mapping):
        raise ConfigError(f"a config must be a mapping at the top level, got {type(tree).__name__}")
    resolved = _validate_tree(tree, "")
    if schema is not None:
        resolved = _check_schema(resolved, schema, fill_defaults)
    out = OmegaConf.create(resolved)
    OmegaConf.set_readonly(out, True)
    return out


def _parse_override(text: str) -> tuple[str, Any]:
    if "=" not in text or text.startswith("="):
        raise ConfigError(f"override {text!r}: expected key=value")
    key, raw = text.split("=", 1)
    key = key.strip().lstrip("+")
    try:  # interpolations (${...}) stay unresolved until the whole config is validated
        parsed: Any = OmegaConf.to_container(OmegaConf.from_dotlist([f"v={raw}"]), resolve=False)
        value = parsed["v"]
    except Exception as exc:  # YAML and OmegaConf grammar errors alike
        raise ConfigError(f"override {text!r}: cannot parse value: {str(exc).splitlines()[0]}") from None
    return key, value


def _is_bare_name(value: Any) -> bool:
    return isinstance(value, str) and "${" not in value  # an interpolation is resolved later


def _expand_bare_names(tree: Any) -> Any:
    """Turn bare-name component nodes (``backbone: dit``) into ``{name: dit}`` so params can be set."""
    if isinstance(tree, Mapping):
        out: dict[Any, Any] = {}
        for key, value in tree.items():
            found = component_kind(str(key))
            if found is not None and not found[1] and _is_bare_name(value):
                out[key] = {"name": value}
            elif found is not None and found[1] and isinstance(value, list):
                out[key] = [{"name": v} if _is_bare_name(v) else _expand_bare_names(v) for v in value]
            else:
                out[key] = _expand_bare_names(value)
        return out
    return tree


def apply_overrides(cfg: Any, overrides: Iterable[str]) -> DictConfig:
    """Apply ``key=value`` dotlist overrides to an unvalidated config.

    A value given to a component key replaces that whole node when it names a part
    (``backbone=unet1d`` or ``backbone={name: unet1d, depth: 2}`` drop the old node's params);
    a mapping without a name (``backbone={depth: 2}``) or a dotted key (``backbone.depth=4``)
    sets params of the existing node. Interpolations (``${...}``) are resolved after all
    overrides, so an override reaches every node that refers to the overridden one.
    """
    # bare names are expanded once here and in each inserted value (not the whole tree per override)
    tree = OmegaConf.create(_expand_bare_names(_plain(cfg, resolve=False)) if cfg is not None else {})
    for text in overrides:
        key, value = _parse_override(text)
        leaf = key.rsplit(".", 1)[-1]
        names_part = not isinstance(value, dict) or "name" in value
        replace = component_kind(leaf) is not None and names_part
        if leaf.isdigit():  # an item of a component list: expand the list around it afterwards
            tree = _update(tree, key, value, replace, text)
            tree = OmegaConf.create(_expand_bare_names(_plain(tree, resolve=False)))
            continue
        value = _expand_bare_names({leaf: value})[leaf]
        tree = _update(tree, key, value, replace, text)
    return tree


def _update(tree: DictConfig, key: str, value: Any, replace: bool, text: str) -> DictConfig:
    try:
        OmegaConf.update(tree, key, value, merge=not replace, force_add=True)
    except OmegaConfBaseException as exc:
        raise ConfigError(f"override {text!r}: {str(exc).splitlines()[0]}") from None
    return tree


def load_config(
    source: str | Path | Mapping[str, Any] | DictConfig | None = None,
    overrides: Iterable[str] = (),
    schema: type | None = None,
    *,
    fill_defaults: bool = True,
) -> DictConfig:
    """Load a YAML file (or mapping), apply overrides, validate (see :func:`validate`) and freeze.

    Raises:
        ConfigError: unreadable file, bad YAML, bad override, or a key that does not validate.
    """
    if isinstance(source, (str, Path)):
        path = Path(source)
        if not path.is_file():
            raise ConfigError(f"{path}: config file not found")
        try:
            base: Any = OmegaConf.load(path)
        except Exception as exc:
            raise ConfigError(f"{path}: cannot parse YAML: {str(exc).splitlines()[0]}") from None
    else:
        base = source or {}
    return validate(apply_overrides(base, overrides), schema, fill_defaults=fill_defaults)


def instantiate_config(entry: Entry, params: Mapping[str, Any]) -> Any:
    """The entry's config dataclass instance built from ``params`` (validated)."""
    if entry.config is None:
        if params:
            raise ConfigError(f"{entry.kind} '{entry.name}' takes no parameters")
        return None
    merged = _merge_params(entry, _validate_tree(dict(params), entry.name), entry.name)
    return OmegaConf.to_object(merged)


def build_component(node: Any, kind: str, /, **deps: Any) -> Any:
    """Build the part described by a component node (``{name, **params}`` or a bare name)."""
    node = _plain(node)
    if isinstance(node, str):
        node = {"name": node}
    params = {k: v for k, v in node.items() if k != "name"}
    entry = _entry(kind, node.get("name"), singular(kind))
    return registry_for(kind).build(entry.name, params, **deps)


def to_container(cfg: Any) -> Any:
    """A plain (JSON-serialisable) copy of a config."""
    return _plain(cfg)


def save_config(cfg: Any, path: str | Path) -> Path:
    """Write ``cfg`` as YAML (``.yaml``/``.yml``) or JSON (any other suffix), atomically."""
    path = Path(path)
    plain = _plain(cfg)
    text = OmegaConf.to_yaml(plain) if path.suffix in {".yaml", ".yml"} else json.dumps(plain, indent=2)
    return atomic_write_text(path, text)
