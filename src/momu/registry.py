"""Registries of momu's parts and the entry-point path for third-party plugins.

One :class:`Registry` class, one instance per kind of part (``ENCODERS``, ``BACKBONES``, ...).
A part is a *factory* (a function or class) registered with a config dataclass::

    @BACKBONES.register("dit", config=DiTConfig)
    def build_dit(cfg: DiTConfig) -> nn.Module: ...

Built-in parts live in the subpackage named after their kind (``momu.backbones`` ...); that
subpackage is imported the first time the registry is asked for names or an entry.

Third-party parts come through the entry-point group ``momu.<kind>`` of their own
distribution. Discovery is lazy: :meth:`Registry.names` and :meth:`Registry.sources` read
package metadata only and import nothing; :meth:`Registry.get` imports only the plugin asked
for. A plugin that fails to import raises :class:`PluginError` naming its distribution and
entry point; it never breaks ``import momu`` or other parts. A plugin's import is stopped after
``MOMU_PLUGIN_TIMEOUT`` seconds (:mod:`momu.plugin_import`), so one that hangs cannot hang momu.
Two plugins that declare the same name make :meth:`Registry.get` of that name raise
:class:`RegistryError` naming both distributions and entry points (neither is picked silently).
"""

from __future__ import annotations

import dataclasses
import importlib
import inspect
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from importlib.metadata import EntryPoint, entry_points, packages_distributions, version
from typing import Any, Generic, TypeVar

from momu.plugin_import import PluginImportTimeout, import_within, plugin_timeout

__all__ = [
    "BUILTIN_SOURCE",
    "Entry",
    "PluginError",
    "Registry",
    "RegistryError",
    "KINDS",
    "REGISTRIES",
    "ENCODERS",
    "BACKBONES",
    "LOSSES",
    "SAMPLERS",
    "SCHEDULERS",
    "VOCODERS",
    "METRICS",
    "DATASETS",
    "METHODS",
    "registry_for",
    "singular",
]

F = TypeVar("F", bound=Callable[..., Any])
T = TypeVar("T")

BUILTIN_SOURCE = "momu"


def singular(kind: str) -> str:
    """``"backbones" -> "backbone"``, ``"losses" -> "loss"``: how one part of a kind is called."""
    if kind.endswith("sses"):
        return kind[:-2]
    return kind[:-1] if kind.endswith("s") else kind


class RegistryError(LookupError):
    """An unknown name, a duplicate name, or a malformed registration."""


class PluginError(ImportError):
    """A third-party plugin could not be imported or did not register what it declared."""


@dataclass(frozen=True)
class Entry:
    """One registered part.

    Attributes:
        kind: the registry kind (``"backbones"`` ...).
        name: the name used in configs.
        factory: the callable that builds the part from a config instance.
        config: the dataclass that validates the part's parameters (``None``: no parameters).
        source: ``"momu"`` for built-ins, ``"dist==version"`` for plugins.
        origin: where the factory is defined (``module:qualname (file:line)``).
    """

    kind: str
    name: str
    factory: Callable[..., Any]
    config: type | None
    source: str
    origin: str

    def default_config(self) -> Any:
        """A config instance with every default filled in (``None`` for a parameterless part)."""
        return self.config() if self.config is not None else None


def _origin(obj: Any) -> str:
    module = getattr(obj, "__module__", "?")
    qualname = getattr(obj, "__qualname__", repr(obj))
    try:
        file = inspect.getsourcefile(obj)
        line = inspect.getsourcelines(obj)[1]
        return f"{module}:{qualname} ({file}:{line})"
    except (TypeError, OSError):
        return f"{module}:{qualname}"


def _describe(ep: EntryPoint) -> str:
    return f"entry point '{ep.name} = {ep.value}' in group '{ep.group}'"


def _source_of_module(module: str) -> str:
    """``"momu"`` for momu's own modules, ``"dist==version"`` for an installed package, else ``"local"``."""
    top = module.split(".")[0]
    if top == "momu":
        return BUILTIN_SOURCE
    dists = packages_distributions().get(top)  # scanned only for non-momu parts: plugins, user code
    if not dists:
        return f"local ({module})" if module else "local"
    return f"{dists[0]}=={version(dists[0])}"


def _dist_source(ep: EntryPoint) -> str:
    dist = ep.dist
    if dist is None:
        return "unknown-distribution"
    return f"{dist.metadata['Name']}=={dist.version}"


class Registry(Generic[T]):
    """Named parts of one kind, built-in and from plugins.

    Args:
        kind: the kind's name; also the entry-point group suffix (``momu.<kind>``).
        builtin_module: the module that registers momu's built-in parts of this kind when
            imported (``None``: no built-ins).
    """

    def __init__(self, kind: str, builtin_module: str | None = None) -> None:
        self.kind = kind
        self.group = f"momu.{kind}"
        self._builtin_module = builtin_module
        self._entries: dict[str, Entry] = {}
        self._builtins_loaded = builtin_module is None

    # ------------------------------------------------------------------ registration
    def register(self, name: str, *, config: type | None = None) -> Callable[[F], F]:
        """Decorator registering ``factory`` under ``name``, validated by ``config``.

        Raises:
            RegistryError: ``name`` is taken (the message names both definitions) or ``config``
                is not a dataclass.
        """
        if not name or not name.replace("_", "").replace("-", "").isalnum():
            raise RegistryError(f"{self.kind}: invalid part name {name!r} (use letters, digits, _ and -)")
        if config is not None and not dataclasses.is_dataclass(config):
            raise RegistryError(f"{self.kind} '{name}': config must be a dataclass, got {config!r}")

        def decorator(factory: F) -> F:
            source = _source_of_module(getattr(factory, "__module__", "") or "")
            self.add(Entry(self.kind, name, factory, config, source, _origin(factory)))
            return factory

        return decorator

    def add(self, entry: Entry) -> None:
        """Add a ready-made entry (what :meth:`register` does); duplicates are an error."""
        existing = self._entries.get(entry.name)
        if existing is not None and existing.factory is not entry.factory:
            raise RegistryError(
                f"{self.kind} '{entry.name}' is registered twice: by {existing.origin} "
                f"[{existing.source}] and by {entry.origin}"
            )
        self._entries[entry.name] = entry

    def unregister(self, name: str) -> None:
        """Remove ``name`` (for tests and interactive sessions)."""
        self._entries.pop(name, None)

    # ------------------------------------------------------------------ discovery
    def _load_builtins(self) -> None:
        if not self._builtins_loaded and self._builtin_module is not None:
            self._builtins_loaded = True
            importlib.import_module(self._builtin_module)

    def _declarations(self) -> dict[str, list[EntryPoint]]:
        """``name -> entry points declaring it`` (by distribution): more than one when two
        distributions claim a name."""
        found: dict[str, list[EntryPoint]] = {}
        for ep in entry_points(group=self.group):
            same = found.setdefault(ep.name, [])
            if not any(e.value == ep.value and _dist_source(e) == _dist_source(ep) for e in same):
                same.append(ep)
        for eps in found.values():
            if len(eps) > 1:  # reads the distributions' metadata only for a clash
                eps.sort(key=lambda e: (_dist_source(e), e.value))
        return found

    def _entry_points(self) -> dict[str, EntryPoint]:
        return {name: eps[0] for name, eps in self._declarations().items()}

    def _clash(self, name: str, declared: list[EntryPoint]) -> RegistryError:
        who = " and ".join(f"{_describe(ep)} of {_dist_source(ep)}" for ep in declared)
        return RegistryError(
            f"{self.kind} '{name}' is declared by {len(declared)} plugins: {who}; "
            "uninstall one or rename its part"
        )

    def names(self) -> list[str]:
        """Every name of this kind, built-in and plugin, sorted. Imports no plugin."""
        self._load_builtins()
        return sorted(set(self._entries) | set(self._entry_points()))

    def sources(self) -> dict[str, str]:
        """``name -> source`` for every part, without importing any plugin."""
        self._load_builtins()
        out = {name: entry.source for name, entry in self._entries.items()}
        for name, eps in self._declarations().items():
            ep = eps[0]
            if out.get(name) == BUILTIN_SOURCE:  # get() refuses the name until one is renamed
                out[name] = f"{BUILTIN_SOURCE} (CONFLICT: also {_dist_source(ep)})"
            elif len(eps) > 1:  # so does it for two plugins
                out[name] = f"CONFLICT: {', '.join(_dist_source(e) for e in eps)}"
            out.setdefault(name, _dist_source(ep))
        return dict(sorted(out.items()))

    def __contains__(self, name: object) -> bool:
        return isinstance(name, str) and name in self.names()

    def __iter__(self) -> Iterator[str]:
        return iter(self.names())

    def get(self, name: str) -> Entry:
        """The entry for ``name``, importing its plugin if it comes from one.

        Raises:
            RegistryError: no part has that name (the message lists the valid names), or two
                plugins declare it (the message names both).
            PluginError: the plugin declaring ``name`` failed to import, did not finish importing
                within ``MOMU_PLUGIN_TIMEOUT`` seconds, or did not register it.
        """
        self._load_builtins()
        declared = self._declarations().get(name, [])
        if len(declared) > 1:
            raise self._clash(name, declared)
        ep = declared[0] if declared else None
        if name in self._entries:
            entry = self._entries[name]
            if ep is not None and entry.source == BUILTIN_SOURCE:
                raise RegistryError(
                    f"{self.kind} '{name}' is registered twice: built in ({entry.origin}) and by "
                    f"{_describe(ep)} of {_dist_source(ep)}; rename the plugin's part"
                )
            return entry
        if ep is None:
            raise RegistryError(
                f"unknown {singular(self.kind)} '{name}'; valid names: {', '.join(self.names()) or '(none)'}"
            )
        return self._load_plugin(name, ep)

    def _load_plugin(self, name: str, ep: EntryPoint) -> Entry:
        source = _dist_source(ep)
        what = f"{self.kind} '{name}' from distribution {source} ({_describe(ep)})"
        try:
            seconds = plugin_timeout()
        except ValueError as exc:
            raise PluginError(str(exc)) from None
        try:
            loaded = import_within(ep.load, seconds, what)
        except PluginImportTimeout as exc:
            raise PluginError(str(exc)) from None
        except (Exception, SystemExit) as exc:  # a broken plugin (even one calling sys.exit) is isolated
            reason = (
                f"called sys.exit({exc.code!r})"
                if isinstance(exc, SystemExit)
                else f"{type(exc).__name__}: {exc}"
            )
            raise PluginError(f"{what} failed to import: {reason}") from exc
        entry = self._entries.get(name)
        if entry is None:
            # The entry point may name the factory itself, registered under another name.
            for candidate in self._entries.values():
                if candidate.factory is loaded:
                    raise PluginError(
                        f"{_describe(ep)} of {source} registers its part as '{candidate.name}', "
                        f"not '{name}': the entry-point name must equal the registered name"
                    )
            raise PluginError(
                f"{_describe(ep)} of {source} imported but registered no {self.kind} part named "
                f"'{name}' (decorate its factory with momu.registry.{self.kind.upper()}.register('{name}'))"
            )
        if entry.source != source:  # the entry point's distribution is the authoritative source
            entry = dataclasses.replace(entry, source=source)
            self._entries[name] = entry
        return entry

    # ------------------------------------------------------------------ building
    def build(self, name: str, config: Any = None, /, **deps: Any) -> Any:
        """Build part ``name`` from ``config`` (a config instance, a mapping of params, or None).

        ``deps`` are passed to the factory as keyword arguments (other built parts, shapes...).
        """
        entry = self.get(name)
        if entry.config is None:
            if config:
                raise RegistryError(f"{self.kind} '{name}' takes no parameters, got {dict(config)!r}")
            return entry.factory(**deps)
        if config is None:
            cfg = entry.config()
        elif isinstance(config, entry.config):
            cfg = config
        else:
            from momu.config import instantiate_config

            cfg = instantiate_config(entry, dict(config))
        return entry.factory(cfg, **deps)

    def __repr__(self) -> str:
        return f"Registry({self.kind!r}, {len(self._entries)} loaded)"


ENCODERS: Registry[Any] = Registry("encoders", "momu.encoders")
BACKBONES: Registry[Any] = Registry("backbones", "momu.backbones")
LOSSES: Registry[Any] = Registry("losses", "momu.losses")
SAMPLERS: Registry[Any] = Registry("samplers", "momu.samplers")
SCHEDULERS: Registry[Any] = Registry("schedulers", "momu.schedulers")
VOCODERS: Registry[Any] = Registry("vocoders", "momu.vocoders")
METRICS: Registry[Any] = Registry("metrics", "momu.metrics")
DATASETS: Registry[Any] = Registry("datasets", "momu.data")
METHODS: Registry[Any] = Registry("methods", "momu.methods")

REGISTRIES: dict[str, Registry[Any]] = {
    r.kind: r
    for r in (ENCODERS, BACKBONES, LOSSES, SAMPLERS, SCHEDULERS, VOCODERS, METRICS, DATASETS, METHODS)
}
KINDS: tuple[str, ...] = tuple(REGISTRIES)


def registry_for(kind: str) -> Registry[Any]:
    """The registry of ``kind`` (plural, e.g. ``"backbones"``)."""
    try:
        return REGISTRIES[kind]
    except KeyError:
        raise RegistryError(f"unknown kind '{kind}'; valid kinds: {', '.join(KINDS)}") from None
