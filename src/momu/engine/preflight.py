"""What a table run checks before it creates any folder, tracker or model.

* each row's config resolves and validates against :class:`~momu.config.schema.RecipeConfig`; a
  bad key is blamed on what introduced it — the user's ``override 'k=v'`` when the error does not
  depend on the row, the row otherwise;
* every output path can be written (``--out`` is not a file, its parent is a writable folder);
* the dataset each row trains on opens (options valid, root present), and the spec's own check
  (Tables 2–6: every subset's data) passes.

Anything that fails raises :class:`~momu.config.ConfigError` with a one-line reason, so the runner
exits with status 2 and nothing is written (no ``wandb/`` folder, no half-made output folder).
"""

from __future__ import annotations

import json
from collections.abc import Callable, Mapping, Sequence
from pathlib import Path
from typing import Any

from omegaconf import DictConfig

from momu.config import ConfigError, build_component, load_config, to_container
from momu.config.schema import RecipeConfig
from momu.io import check_output_dir
from momu.registry import PluginError, RegistryError

__all__ = ["row_config", "check_outputs", "check_datasets", "open_dataset", "override_for"]

CONFIG_SCHEMA = RecipeConfig
"""The schema every recipe config is validated against."""


def _key_of(exc: ConfigError) -> str:
    return exc.key or str(exc).split(":", 1)[0].strip()


def override_for(exc: ConfigError, overrides: Sequence[str]) -> str | None:
    """The (last) override in ``overrides`` that set the key ``exc`` is about, if any."""
    key = _key_of(exc)
    found = None
    for text in overrides:
        name = text.split("=", 1)[0].strip().lstrip("+")
        if key == name or key.startswith((name + ".", name + "[")) or name.startswith(key + "."):
            found = text
    return found


def _load(base: Any, overrides: Sequence[str]) -> DictConfig:
    return load_config(base, overrides, schema=CONFIG_SCHEMA, fill_defaults=False)


def row_config(
    base: str | Path | Mapping[str, Any],
    row_label: str,
    row_overrides: Sequence[str],
    preset: Sequence[str],
    user: Sequence[str],
    data: Sequence[str],
) -> DictConfig:
    """One row's validated config: ``base`` + preset + row + the user's overrides + ``--data``.

    Raises:
        ConfigError: ``override 'k=v': ...`` when the user's override fails whatever the row,
            ``<row_label> with override 'k=v': ...`` when it fails only with this row's overrides,
            ``<row_label>: ...`` otherwise.
    """
    try:
        return _load(base, [*preset, *row_overrides, *user, *data])
    except ConfigError as exc:
        culprit = override_for(exc, user)
        if culprit is None:
            raise ConfigError(f"{row_label}: {exc}", key=exc.key) from None
        try:
            _load(base, [*preset, *user, *data])
        except ConfigError as without_row:
            if str(without_row) == str(exc):
                raise ConfigError(f"override {culprit!r}: {exc}", key=exc.key) from None
        raise ConfigError(f"{row_label} with override {culprit!r}: {exc}", key=exc.key) from None


def check_outputs(out: Path, table: str) -> None:
    """``--out`` and ``--out/<table>`` can be made and written."""
    try:
        check_output_dir(out, "--out")
        check_output_dir(out / table, "--out")
    except ValueError as exc:
        raise ConfigError(str(exc)) from None


def check_datasets(
    configs: Mapping[str, DictConfig], check: Callable[[DictConfig], None] | None = None
) -> None:
    """Open each distinct ``dataset`` node of ``configs`` and run the spec's ``check`` on each config.

    Building a dataset reads only its index (split files, folder listings, a manifest), so this
    is cheap; it catches bad options (``dataset.num_clips=-3``) and missing roots before training.
    """
    seen: set[str] = set()
    for cfg in configs.values():
        node = cfg.get("dataset")
        if node is not None:
            plain = to_container(node)
            text = json.dumps(plain, sort_keys=True, default=str)
            if text not in seen:
                seen.add(text)
                open_dataset(plain)
        if check is not None:
            try:
                check(cfg)
            except ConfigError:
                raise
            except (ValueError, OSError, RegistryError, PluginError) as exc:
                raise ConfigError(str(exc)) from None


def open_dataset(node: Any) -> Any:
    """Build the dataset ``node`` names; a bad option or a missing root is a ``ConfigError`` naming
    ``dataset`` (one line, exit status 2 from a CLI) instead of the loader's own exception."""
    name = node.get("name") if isinstance(node, Mapping) else node
    try:
        return build_component(node, "datasets")
    except ConfigError as exc:
        raise ConfigError(f"dataset: {exc}") from None
    except (ValueError, OSError, RegistryError, PluginError) as exc:
        message = str(exc)
        prefix = f"{name}: "
        reason = message[len(prefix) :] if message.startswith(prefix) else message
        raise ConfigError(f"dataset ({name}): {reason}", key="dataset") from None
