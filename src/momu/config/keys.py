"""Naming a bad key: the innermost schema node a dotted key falls in, and that node's valid keys.

A part's config dataclass may nest others (``MoMuConfig.train_diffusion`` is a ``TrainConfig``,
``RecipeConfig.subsets`` a ``dict`` of ``SubsetConfig``). A misspelled key deep inside should list
the keys of the dataclass it was meant for, not the top-level ones.
"""

from __future__ import annotations

import dataclasses
import re
import types
import typing
from collections.abc import Mapping
from typing import Any

__all__ = ["innermost_node", "field_names", "ENV_INTERPOLATION", "find_env_interpolation"]

ENV_INTERPOLATION = re.compile(r"\$\{\s*oc\.env\s*:")
"""``${oc.env:VAR}``: refused in momu configs (it would copy environment values — tokens,
passwords — into printed configs, error messages, ``config.yaml`` and ``results.json``)."""


def field_names(cls: type) -> list[str]:
    """The field names of dataclass ``cls`` in declaration order."""
    return [f.name for f in dataclasses.fields(cls)]


def _hints(cls: type) -> dict[str, Any]:
    try:
        return typing.get_type_hints(cls)
    except Exception:  # an annotation that does not resolve: fall back to the raw ones
        return {f.name: f.type for f in dataclasses.fields(cls)}


def _unwrap_optional(tp: Any) -> Any:
    origin = typing.get_origin(tp)
    if origin in (typing.Union, types.UnionType):
        args = [a for a in typing.get_args(tp) if a is not type(None)]
        return args[0] if len(args) == 1 else tp
    return tp


def _step(cls: type, key: str) -> tuple[type | None, bool]:
    """``(dataclass under field key of cls, is it a mapping of them)``, or ``(None, False)``."""
    tp = _hints(cls).get(key)
    if tp is None:
        return None, False
    tp = _unwrap_optional(tp)
    if dataclasses.is_dataclass(tp) and isinstance(tp, type):
        return tp, False
    if typing.get_origin(tp) in (dict, Mapping, typing.Dict):  # noqa: UP006 - typing.Dict spellings too
        args = typing.get_args(tp)
        value = _unwrap_optional(args[1]) if len(args) == 2 else None
        if dataclasses.is_dataclass(value) and isinstance(value, type):
            return value, True
    return None, False


def innermost_node(schema: type, dotted: str) -> tuple[str, type]:
    """The deepest dataclass node on the way to ``dotted``: ``(its dotted prefix, its class)``.

    >>> from dataclasses import dataclass, field
    >>> @dataclass
    ... class Inner:
    ...     steps: int = 1
    >>> @dataclass
    ... class Outer:
    ...     train: Inner = field(default_factory=Inner)
    >>> innermost_node(Outer, "train.stpes")
    ('train', <class 'momu.config.keys.Inner'>)
    """
    parts = [p for p in dotted.split(".") if p]
    prefix: list[str] = []
    cls = schema
    i = 0
    while i < len(parts) - 1:
        inner, mapping = _step(cls, parts[i])
        if inner is None:
            break
        if mapping:
            if i + 1 >= len(parts) - 1:
                break
            prefix += parts[i : i + 2]
            i += 2
        else:
            prefix.append(parts[i])
            i += 1
        cls = inner
    return ".".join(prefix), cls


def find_env_interpolation(tree: Any, path: str = "") -> str | None:
    """The dotted key of the first string holding ``${oc.env:...}`` in ``tree``, else ``None``."""
    if isinstance(tree, str):
        return (path or "<root>") if ENV_INTERPOLATION.search(tree) else None
    if isinstance(tree, Mapping):
        for key, value in tree.items():
            found = find_env_interpolation(value, f"{path}.{key}" if path else str(key))
            if found is not None:
                return found
    elif isinstance(tree, (list, tuple)):
        for i, value in enumerate(tree):
            found = find_env_interpolation(value, f"{path}[{i}]")
            if found is not None:
                return found
    return None
