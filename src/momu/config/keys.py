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
from collections.abc import Iterator, Mapping
from typing import Any

from omegaconf import grammar_parser
from omegaconf.errors import GrammarParseError
from omegaconf.grammar.gen.OmegaConfGrammarParser import OmegaConfGrammarParser

__all__ = [
    "innermost_node",
    "field_names",
    "ENV_INTERPOLATION",
    "ALLOWED_RESOLVERS",
    "find_refused_resolver",
    "find_built_interpolation",
]

ENV_INTERPOLATION = re.compile(r"\$\{\s*oc\.env\s*:")
"""``${oc.env:VAR}``: refused in momu configs (it would copy environment values — tokens,
passwords — into printed configs, error messages, ``config.yaml`` and ``results.json``)."""

ALLOWED_RESOLVERS = ("oc.select",)
"""The only resolvers a momu config may call, besides references to other keys (``${a.b}``).

Any other — ``oc.env``, and every resolver that builds an interpolation while the config is
resolved (``oc.decode``, ``oc.create``), which could spell ``${oc.env:...}`` out of pieces — is
refused wherever it appears (:func:`find_refused_resolver`), and a resolved value may not hold
``${`` (:func:`find_built_interpolation`): it would be resolved again the next time the config is.
"""


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


def _strings(tree: Any, path: str = "") -> Iterator[tuple[str, str]]:
    """``(dotted key, string)`` for every string of a plain config tree, in order."""
    if isinstance(tree, str):
        yield path or "<root>", tree
    elif isinstance(tree, Mapping):
        for key, value in tree.items():
            yield from _strings(value, f"{path}.{key}" if path else str(key))
    elif isinstance(tree, (list, tuple)):
        for i, value in enumerate(tree):
            yield from _strings(value, f"{path}[{i}]")


def resolver_names(text: str) -> list[str]:
    """The resolvers the interpolations of ``text`` call, as written (``["oc.env"]``); escaped
    ``\\${...}`` is text, not an interpolation. A name built by an interpolation (``${${x}:y}``)
    comes back as written, so it is in no allow-list. Text OmegaConf cannot parse calls nothing
    (resolving it fails on its own)."""
    if "${" not in text:
        return []
    try:
        tree = grammar_parser.parse(text)
    except GrammarParseError:
        return []
    names: list[str] = []
    stack: list[Any] = [tree]
    while stack:
        node = stack.pop()
        if isinstance(node, OmegaConfGrammarParser.InterpolationResolverContext):
            names.append(node.getChild(1).getText())
        stack.extend(node.getChild(i) for i in reversed(range(node.getChildCount())))
    return names


def find_refused_resolver(tree: Any) -> tuple[str, str] | None:
    """``(dotted key, resolver)`` of the first call of a resolver not in :data:`ALLOWED_RESOLVERS`."""
    for key, text in _strings(tree):
        if ENV_INTERPOLATION.search(text):  # escaped or not: never an environment value
            return key, "oc.env"
        for name in resolver_names(text):
            if name not in ALLOWED_RESOLVERS:
                return key, name
    return None


def find_built_interpolation(resolved: Any) -> str | None:
    """The dotted key of the first *resolved* string still holding ``${`` (an interpolation built
    while resolving, from escaped text or pieces: it would be resolved the next time), else ``None``."""
    return next((key for key, text in _strings(resolved) if "${" in text), None)
