"""Where two presets of a recipe differ: every dotted key whose resolved values are not equal.

Used to document (and test) every departure of a recipe's ``cpu`` preset from its ``paper`` preset
(``docs/presets.md``), so a reader sees exactly what the small CPU runs change.
"""

from __future__ import annotations

import json
from collections.abc import Iterator, Mapping, Sequence
from typing import Any

from momu.config import to_container

__all__ = ["flatten", "departures", "departures_table"]


def flatten(node: Any, prefix: str = "") -> Iterator[tuple[str, Any]]:
    """``(dotted key, leaf value)`` of a nested mapping; lists are leaves."""
    if isinstance(node, Mapping):
        for key in node:
            yield from flatten(node[key], f"{prefix}.{key}" if prefix else str(key))
    else:
        yield prefix, node


def departures(reference: Any, other: Any) -> list[tuple[str, Any, Any]]:
    """``(key, reference value, other value)`` for every key where the two resolved configs differ.

    A key present on one side only is reported with ``"—"`` on the other (a node replaced by a part
    with other parameters, or ``null``).
    """
    a = dict(flatten(reference if isinstance(reference, dict) else to_container(reference)))
    b = dict(flatten(other if isinstance(other, dict) else to_container(other)))
    keys = sorted(set(a) | set(b))
    return [(k, a.get(k, "—"), b.get(k, "—")) for k in keys if a.get(k, "—") != b.get(k, "—")]


def _cell(value: Any) -> str:
    text = value if isinstance(value, str) else json.dumps(value)
    return text.replace("|", "\\|")


def departures_table(rows: Sequence[tuple[str, Any, Any]], names: tuple[str, str] = ("paper", "cpu")) -> str:
    """A Markdown table of :func:`departures` rows."""
    lines = [f"| key | {names[0]} | {names[1]} |", "|---|---|---|"]
    lines += [f"| `{k}` | {_cell(a)} | {_cell(b)} |" for k, a, b in rows]
    return "\n".join(lines) + "\n"
