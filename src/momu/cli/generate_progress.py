"""``momu generate``'s progress: a bar on a terminal, a few INFO log lines otherwise.

:func:`progress` is used for the diffusion windows and for the mp4's frames (the longest phase of a
long song). On a terminal (stderr is a TTY) it draws a ``tqdm`` bar; without one (a log file, a job
scheduler) it logs a line when the phase starts and at each quarter. :func:`info_logging` makes those
INFO lines (and the other ``momu.cli`` INFO lines) visible by default, without ``-v``.
"""

from __future__ import annotations

import contextlib
import logging
import sys
import time
from collections.abc import Callable, Iterator

__all__ = ["progress", "info_logging"]

log = logging.getLogger(__name__)

_QUARTERS = (25, 50, 75, 100)


def _is_terminal() -> bool:
    try:
        return sys.stderr.isatty()
    except (AttributeError, ValueError):
        return False


@contextlib.contextmanager
def progress(total: int, desc: str, unit: str, quiet: bool = False) -> Iterator[Callable[[int], None]]:
    """``update(n)`` for ``total`` steps of ``desc``: a bar on a terminal, else a log line per quarter."""
    if quiet or total <= 0:
        yield lambda n: None
        return
    if _is_terminal():
        from tqdm.auto import tqdm

        with tqdm(total=total, desc=desc, unit=unit, dynamic_ncols=True, leave=False) as bar:

            def advance(n: int) -> None:
                bar.update(n)

            yield advance
        return
    units = unit if total == 1 else f"{unit}s"
    log.info("%s: %d %s", desc, total, units)
    done, quarter, start = 0, 0, time.perf_counter()

    def update(n: int) -> None:
        nonlocal done, quarter
        done += n
        reached = quarter
        while reached < len(_QUARTERS) and done * 100 >= _QUARTERS[reached] * total:
            reached += 1
        if reached > quarter:  # one line when a quarter is passed, with the share actually done
            quarter = reached
            log.info(
                "%s: %d%% (%d of %d %s, %.1f s)",
                desc,
                100 * min(done, total) // total,
                min(done, total),
                total,
                units,
                time.perf_counter() - start,
            )

    yield update


@contextlib.contextmanager
def info_logging(quiet: bool) -> Iterator[None]:
    """Show ``momu.cli``'s INFO lines in the block (unless ``quiet`` or already shown)."""
    logger = logging.getLogger("momu.cli")
    if quiet or logger.getEffectiveLevel() <= logging.INFO:
        yield
        return
    old = logger.level
    logger.setLevel(logging.INFO)
    try:
        yield
    finally:
        logger.setLevel(old)
