"""The table run's progress line: an extractor's training shows on it without skewing the ETA."""

from __future__ import annotations

import pytest

from momu.data.synth import SynthConfig, SynthDance
from momu.encoders.dstformer import DSTformerConfig
from momu.engine.progress import JobProgress, SideWorkClock
from momu.metrics.extractors import MotionClassifierConfig, TrainConfig, train_extractor


def test_side_work_gives_the_job_an_eta_from_its_first_steps() -> None:
    progress = JobProgress("t", units=2, enabled=False)
    progress.start_unit("row #1 seed 0", planned=100)
    assert progress.eta() is None
    progress.side_step("motion extractor", 10, 100)  # the extractor trains before the stages
    unit = progress._running["row #1 seed 0"]
    assert unit.planned == 200 and unit.fraction() == 0.05
    assert progress.eta() is not None  # an ETA before any stage step
    progress.side_step("motion extractor", 100, 100)  # it ends: its steps are done
    assert unit.finished_steps == 100 and unit.current == 0
    progress.stage_step("diffusion", 50, 100)
    assert unit.fraction() == 0.75
    assert progress._stage_text() == "diffusion 50/100"
    progress.side_step("motion extractor", 100, 100)  # counted once per unit
    assert unit.planned == 200 and unit.finished_steps == 100 and unit.fraction() == 0.75
    progress.finish_unit()
    assert progress.done == 1
    progress.close()


def test_extractor_training_reports_every_optimizer_step() -> None:
    cfg = SynthConfig(num_clips=12, min_seconds=3.0, max_seconds=3.0, skeleton="openpose14", fps=15.0,
                      styles=["ballet", "hiphop"])  # fmt: skip
    clips = [SynthDance(cfg, split="train")[i] for i in range(len(SynthDance(cfg, split="train")))]
    tiny = MotionClassifierConfig(
        fps=15.0, window=30, hidden=16, dstformer=DSTformerConfig(dim_feat=8, dim_rep=8, depth=1, num_heads=2)
    )
    seen: list[tuple[int, int]] = []
    train_extractor(
        "motion", clips, model_config=tiny, train=TrainConfig(epochs=2, val_fraction=0.0, batch_size=4),
        on_step=lambda step, steps: seen.append((step, steps)),
    )  # fmt: skip
    steps = seen[-1][1]
    assert [s for s, _ in seen] == list(range(1, steps + 1))
    assert steps >= 2 and all(total == steps for _, total in seen)


def test_side_work_time_left_follows_its_own_rate(monkeypatch: pytest.MonkeyPatch) -> None:
    import momu.engine.progress as progress

    now = [100.0]
    monkeypatch.setattr(progress.time, "monotonic", lambda: now[0])
    clock = SideWorkClock()
    assert clock.text("audio extractor", 10, 110) == "audio extractor 10/110"
    now[0] = 120.0  # 20 s for 10 steps: the 90 steps left take 180 s
    assert clock.text("audio extractor", 20, 110) == "audio extractor 20/110, 3 min 00 s left"


def test_a_jobs_worker_reports_side_work_as_planned_steps_once() -> None:
    import io

    from momu.engine.table_units import Unit
    from momu.engine.table_workers import UnitReporter

    report = io.StringIO()
    reporter = UnitReporter(report, Unit("#7", 0), planned=100)
    reporter.side_step("audio extractor", 1, 40)  # the first report goes out at once
    reporter.side_step("audio extractor", 40, 40)  # the end always goes out
    reporter.side_step("audio extractor", 40, 40)  # and only once
    reporter.stage_done("diffusion", 100, "trained")
    lines = [line.split("\t") for line in report.getvalue().splitlines()]
    assert [(done, planned) for _, _, done, planned, _ in lines] == [
        ("1", "140"),
        ("40", "140"),
        ("140", "140"),
    ]
    assert lines[0][4].startswith("audio extractor 1/40")
