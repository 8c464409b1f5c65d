"""``momu data check DATASET --root DIR [--set key=value ...]``: load every item, summarise, list bad files.

Every item of the dataset is read (and validated by its loader); the command prints a summary —
items, durations, frame rates, skeletons / joints, audio sample rates, splits, styles — and one
line per bad file with the reason::

    BAD /data/aist/keypoints3d/gBR_sBM_cAll_d04_mBR0_ch01.pkl: NaN keypoints beyond what ...

It exits with status 1 when any file is bad (or the dataset cannot be opened at all), 0 when all
items load, and 2 for a usage error (unknown dataset, misspelled option).

Unless ``split=...`` is given, datasets with a ``split`` option are checked with ``split=all``.
"""

from __future__ import annotations

import argparse
import dataclasses
import logging
import sys
from collections import Counter
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from omegaconf import OmegaConf
from omegaconf.errors import OmegaConfBaseException

from momu.config import ConfigError
from momu.data.common import DataFileError, printable
from momu.data.types import Clip, ClipDataset
from momu.registry import DATASETS

__all__ = ["CheckReport", "check_dataset", "open_dataset", "add_action", "run"]

logger = logging.getLogger(__name__)


@dataclass
class CheckReport:
    """What :func:`check_dataset` found.

    Attributes:
        items: number of items in the dataset.
        bad: ``(file or item, reason)`` for every item that failed to load.
        durations: seconds of each good item.
        fps / skeletons / sample_rates / splits / styles: counts over the good items.
        dims: ``(joints, dims)`` per skeleton name.
        with_text: good items carrying text descriptions.
    """

    items: int = 0
    bad: list[tuple[str, str]] = field(default_factory=list)
    durations: list[float] = field(default_factory=list)
    fps: Counter[float] = field(default_factory=Counter)
    skeletons: Counter[str] = field(default_factory=Counter)
    dims: dict[str, tuple[int, int]] = field(default_factory=dict)
    sample_rates: Counter[int] = field(default_factory=Counter)
    splits: Counter[str] = field(default_factory=Counter)
    styles: Counter[str] = field(default_factory=Counter)
    with_text: int = 0

    @property
    def ok(self) -> bool:
        return not self.bad

    def add(self, clip: Clip) -> None:
        self.durations.append(float(clip.duration))
        if clip.motion is not None:
            self.fps[round(float(clip.fps), 3)] += 1
            name = clip.skeleton or "?"
            self.skeletons[name] += 1
            self.dims[name] = (int(clip.motion.shape[1]), int(clip.motion.shape[2]))
        if clip.audio is not None and clip.sample_rate:
            self.sample_rates[int(clip.sample_rate)] += 1
        self.splits[str(clip.meta.get("split", "-"))] += 1
        if clip.style is not None:
            self.styles[str(clip.style)] += 1
        if clip.text:
            self.with_text += 1

    def summary(self, title: str) -> str:
        """The human-readable report (summary lines, then one ``BAD`` line per bad file)."""
        good = self.items - len(self.bad)
        lines = [title, f"items: {self.items} ({good} ok, {len(self.bad)} bad)"]
        if self.durations:
            d = np.asarray(self.durations)
            lines.append(
                f"duration: total {d.sum():.1f} s ({d.sum() / 3600:.2f} h); per item min {d.min():.2f} s, "
                f"mean {d.mean():.2f} s, max {d.max():.2f} s"
            )
        if self.fps:
            lines.append("fps: " + _counts({f"{k:g}": v for k, v in self.fps.items()}))
        if self.skeletons:
            parts = [
                f"{n} ({self.dims[n][0]} joints x {self.dims[n][1]}D): {c}"
                for n, c in sorted(self.skeletons.items())
            ]
            lines.append("skeleton: " + ", ".join(parts))
        lines.append("audio: " + (_counts({f"{k} Hz": v for k, v in self.sample_rates.items()}) or "none"))
        if self.splits:
            lines.append("splits: " + _counts(self.splits))
        if self.styles:
            lines.append("styles: " + _counts(self.styles))
        if self.with_text:
            lines.append(f"text: {self.with_text} items with descriptions")
        lines.extend(f"BAD {where}: {reason}" for where, reason in self.bad)
        lines.append("result: " + ("OK" if self.ok else f"{len(self.bad)} bad file(s)"))
        return "\n".join(lines)


def _counts(counter: Any) -> str:
    return ", ".join(f"{k} {v}" for k, v in sorted(counter.items(), key=lambda kv: str(kv[0])))


def _where(dataset: ClipDataset, index: int, exc: BaseException) -> tuple[str, str]:
    if isinstance(exc, DataFileError):
        return printable(exc.path), exc.reason
    items = getattr(dataset, "items", None)
    where = str(items[index].path) if isinstance(items, list) and index < len(items) else f"item {index}"
    message = str(exc)
    if message.startswith(where + ": "):
        message = message[len(where) + 2 :]
    if isinstance(exc, MemoryError):
        message = "out of memory reading it (does a header declare a huge size?)" + (
            f": {message}" if message else ""
        )
    elif not message:
        message = "no message"
    plain = isinstance(exc, (OSError, ValueError, MemoryError))
    return printable(where), printable(message if plain else f"{type(exc).__name__}: {message}")


def check_dataset(dataset: ClipDataset, *, progress: bool = False) -> CheckReport:
    """Load every item of ``dataset``; collect statistics and every failure with its file.

    Args:
        dataset: any :class:`~momu.data.types.ClipDataset`.
        progress: show a progress bar on stderr (only when stderr is a terminal).
    """
    from tqdm import tqdm

    report = CheckReport(items=len(dataset))
    bar = tqdm(range(len(dataset)), desc="checking", unit="item", disable=None if progress else True)
    for index in bar:
        try:
            clip = dataset[index]
        except Exception as exc:  # report and go on: one bad file must not hide the others
            report.bad.append(_where(dataset, index, exc))
            logger.debug("item %d failed", index, exc_info=True)
            continue
        report.add(clip)
    return report


def open_dataset(name: str, root: str, overrides: Sequence[str] = ()) -> ClipDataset:
    """Build registered dataset ``name`` at ``root`` with ``key=value`` overrides.

    ``split`` defaults to ``all`` for datasets that have one.

    Raises:
        ConfigError: an override that does not parse or names no option of the dataset.
    """
    try:
        params = OmegaConf.to_container(OmegaConf.from_dotlist(list(overrides))) if overrides else {}
    except OmegaConfBaseException as exc:
        raise ConfigError(f"overrides {list(overrides)}: {exc}") from None
    assert isinstance(params, dict)
    entry = DATASETS.get(name)
    fields = {f.name for f in dataclasses.fields(entry.config)} if entry.config is not None else set()
    if "root" not in fields:
        raise ConfigError(f"dataset '{name}' has no 'root' option: it does not read from a folder")
    params["root"] = root
    if "split" in fields:
        params.setdefault("split", "all")
    return DATASETS.build(name, params)


def add_action(actions: Any) -> None:
    p = actions.add_parser(
        "check",
        help="load every item of a dataset, print a summary and each bad file",
        description=__doc__.split("\n\n")[1] if __doc__ else None,
    )
    p.add_argument("dataset", help="registered dataset name (momu list datasets)")
    p.add_argument("--root", required=True, help="the dataset folder in its published layout")
    p.add_argument(
        "overrides",
        nargs="*",
        metavar="key=value",
        help="dataset options before --root, e.g. load_audio=false",
    )
    p.add_argument(
        "--set",
        dest="options",
        nargs="+",
        action="extend",
        default=[],
        metavar="key=value",
        help="dataset options anywhere on the line, e.g. --set split=val load_audio=false",
    )
    p.add_argument("--no-progress", action="store_true", help="no progress bar")
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    title = f"dataset: {args.dataset}  root: {args.root}"
    try:
        dataset = open_dataset(args.dataset, args.root, [*args.overrides, *args.options])
    except (DataFileError, FileNotFoundError, ValueError) as exc:
        if isinstance(exc, ConfigError):
            raise
        where, reason = (
            (str(exc.path), exc.reason) if isinstance(exc, DataFileError) else (args.root, str(exc))
        )
        text = f"{title}\nBAD {where}: {reason}\nresult: cannot open the dataset\n"
        sys.stdout.write(printable(text))
        return 1
    report = check_dataset(dataset, progress=not args.no_progress)
    sys.stdout.write(printable(report.summary(title)) + "\n")
    return 0 if report.ok else 1
