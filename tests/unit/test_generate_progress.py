"""``momu generate``'s progress without a terminal: an INFO line per quarter passed, with how much is done."""

from __future__ import annotations

import logging
import re

import pytest

from momu.cli import generate_progress
from momu.cli.generate_progress import progress


@pytest.fixture(autouse=True)
def _no_terminal(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(generate_progress, "_is_terminal", lambda: False)


def test_a_batch_that_jumps_past_a_quarter_logs_the_share_actually_done(
    caplog: pytest.LogCaptureFixture,
) -> None:
    """The two-pass schedule finishes windows in batches: 33 of 73 windows at once is 45 %, not 25 %."""
    caplog.set_level(logging.INFO, logger="momu.cli")
    with progress(73, "generating the dance", "window") as update:
        for n in (33, 4, 33, 3):
            update(n)
    lines = [r.getMessage() for r in caplog.records]
    assert lines[0] == "generating the dance: 73 windows"
    shown = [re.match(r"generating the dance: (\d+)% \((\d+) of 73 windows, ", line) for line in lines[1:]]
    assert [(int(m[1]), int(m[2])) for m in shown if m] == [(45, 33), (50, 37), (95, 70), (100, 73)]


def test_nothing_is_logged_when_quiet(caplog: pytest.LogCaptureFixture) -> None:
    caplog.set_level(logging.INFO, logger="momu.cli")
    with progress(10, "writing dance.mp4", "frame", quiet=True) as update:
        update(10)
    assert caplog.records == []
