"""``momu eval``: folders paired by stem, metrics by name, table + JSON, clear errors."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
import soundfile as sf
from tests.unit.test_metrics_beats_audio import SR, clicks, swing

from momu.cli import main

FPS = 30.0


def make_pair_dirs(tmp_path: Path, n: int = 2, gen_audio: bool = False) -> tuple[Path, Path]:
    gen, gt = tmp_path / "gen", tmp_path / "gt"
    gen.mkdir()
    gt.mkdir()
    for i in range(n):
        motion = swing(FPS, 5.0).astype(np.float32)
        np.save(gen / f"clip{i}.npy", motion)
        np.save(gt / f"clip{i}.npy", motion)
        sf.write(gt / f"clip{i}.wav", clicks([1.0, 2.0, 3.0, 4.0], 5.0), SR)
        if gen_audio:
            sf.write(gen / f"clip{i}.wav", clicks([1.5, 2.5, 3.5, 4.5], 5.0), SR)
    return gen, gt


def run_eval(gen: Path, gt: Path, metrics: str, *options: str) -> int:
    """``momu eval --gen GEN --gt GT --metrics METRICS [options]``; returns its exit status."""
    return main(["eval", "--gen", str(gen), "--gt", str(gt), "--metrics", metrics, *options])


def test_eval_prints_table_and_writes_json(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    gen, gt = make_pair_dirs(tmp_path)
    out = tmp_path / "res" / "scores.json"
    rc = run_eval(gen, gt, "hit_rate,bas", "--fps", "30", "--set", "bas.variant=mint", "--out", str(out))
    assert rc == 0
    table = capsys.readouterr().out
    assert "hit_rate" in table and "bas" in table and "(2 pairs)" in table
    data = json.loads(out.read_text())
    # generated dances have no audio: they are scored against the reference music (the conditioning input)
    assert data["scores"]["hit_rate"] == 1.0
    assert 0.0 <= data["scores"]["bas"] <= 1.0
    assert data["metrics"]["bas"]["source"] == "momu"
    assert data["metrics"]["bas"]["provenance"]["config"]["variant"] == "mint"
    assert data["inputs"]["pairs"] == ["clip0", "clip1"] and data["inputs"]["fps"] == 30.0
    assert data["inputs"]["generated_modalities"]["clip0"]["audio"].endswith("gt/clip0.wav")


def test_generated_audio_is_used_when_present(tmp_path: Path) -> None:
    gen, gt = make_pair_dirs(tmp_path, gen_audio=True)
    out = tmp_path / "s.json"
    assert run_eval(gen, gt, "hit_rate", "--fps", "30", "--out", str(out)) == 0
    assert json.loads(out.read_text())["scores"]["hit_rate"] == 0.0  # off-beat generated music


def test_missing_dir_unpaired_and_unknown_metric(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    gen, gt = make_pair_dirs(tmp_path)
    assert run_eval(tmp_path / "nope", gt, "bas") == 2
    assert "folder not found" in capsys.readouterr().err
    np.save(gen / "extra.npy", swing(FPS, 2.0))
    assert run_eval(gen, gt, "bas") == 2
    err = capsys.readouterr().err
    assert "unpaired" in err and "extra" in err
    assert run_eval(gen, gt, "bas,not_a_metric") == 2
    err = capsys.readouterr().err
    assert "not_a_metric" in err and "valid names" in err
    assert run_eval(gen, gt, "bas", "--set", "pfc.x=1") == 2
    assert run_eval(gen, gt, "bas", "--set", "bas.variant=x") == 2
    assert "variant" in capsys.readouterr().err
    assert run_eval(gen, gt, "bas", "--set", "bas.nope=1") == 2
    assert "valid keys" in capsys.readouterr().err


def test_bad_motion_file_and_failing_metric(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    gen, gt = make_pair_dirs(tmp_path, n=1)
    np.save(gen / "clip0.npy", np.zeros((10, 24)))
    assert run_eval(gen, gt, "bas") == 2
    assert "(T, J, D)" in capsys.readouterr().err
    np.save(gen / "clip0.npy", np.zeros((30, 24, 3), dtype=np.float32))  # static: PFC is undefined
    np.save(gt / "clip0.npy", np.zeros((30, 24, 3), dtype=np.float32))  # the same skeleton
    out = tmp_path / "s.json"
    assert run_eval(gen, gt, "pfc", "--out", str(out)) == 1
    data = json.loads(out.read_text())
    assert "never accelerates" in data["errors"]["pfc"] and data["scores"] == {}


def test_any_registered_metric_runs_by_name(tmp_path: Path) -> None:
    from dataclasses import dataclass

    from momu.registry import METRICS

    @dataclass
    class FramesConfig:
        scale: float = 1.0

    class Frames:
        name, needs_reference = "test_total_frames", True

        def __init__(self, cfg: FramesConfig) -> None:
            self.cfg = cfg

        def __call__(self, generated, reference=None):  # type: ignore[no-untyped-def]
            return {self.name: self.cfg.scale * sum(c.num_frames for c in generated) / len(reference)}

        def provenance(self) -> dict[str, object]:
            return {"scale": self.cfg.scale}

    METRICS.register("test_total_frames", config=FramesConfig)(Frames)
    try:
        gen, gt = make_pair_dirs(tmp_path)
        out = tmp_path / "s.json"
        options = ["--fps", "30", "--set", "test_total_frames.scale=2", "--out", str(out)]
        assert run_eval(gen, gt, "test_total_frames", *options) == 0
        data = json.loads(out.read_text())
        assert data["scores"]["test_total_frames"] == 2 * 150 * 2 / 2  # two 150-frame clips, two references
        assert data["metrics"]["test_total_frames"]["provenance"] == {"scale": 2.0}
    finally:
        METRICS.unregister("test_total_frames")
