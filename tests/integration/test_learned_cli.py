"""``momu extractor train|info`` end to end on synth_dance, and the trained file used by a metric config."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from momu.cli import main
from momu.config import build_component
from momu.data.synth import SynthConfig, SynthDance
from momu.metrics.extractors import file_sha256


def test_extractor_train_info_and_metric(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "motion.safetensors"
    args = ["extractor", "train", "--kind", "motion", "--data", "synth", "--clips", "9", "--seconds", "2"]
    args += [
        "--fps",
        "15",
        "--epochs",
        "2",
        "--depth",
        "1",
        "--dim-feat",
        "8",
        "--dim-rep",
        "4",
        "--out",
        str(out),
    ]
    assert main(args) == 0
    printed = capsys.readouterr().out
    assert "trained motion_classifier" in printed and file_sha256(out) in printed
    assert out.is_file() and out.with_suffix(".json").is_file()

    assert main(["extractor", "info", str(out)]) == 0
    info = json.loads(capsys.readouterr().out)
    assert info["kind"] == "motion_classifier" and info["sha256_matches_json"] is True
    assert info["classes"] == sorted(info["classes"]) and len(info["classes"]) >= 2

    metric = build_component({"name": "fid_learned", "extractor": str(out)}, "metrics")
    ds = SynthDance(SynthConfig(num_clips=6, min_seconds=2, max_seconds=2, skeleton="openpose14", fps=15))
    clips = [ds[i] for i in range(len(ds))]
    assert abs(metric(clips, clips)["fid_learned"]) < 1e-6
    assert metric.provenance()["extractor"]["sha256"] == file_sha256(out)


def test_extractor_train_reports_bad_arguments(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    base = ["extractor", "train", "--kind", "motion"]
    assert main([*base, "--data", "synth", "--out", str(tmp_path / "m.pt")]) == 2
    assert "safetensors" in capsys.readouterr().err
    assert main([*base, "--data", str(tmp_path / "missing"), "--out", str(tmp_path / "m.safetensors")]) == 2
    assert "not 'synth' and not a folder" in capsys.readouterr().err
    assert main(["extractor", "info", str(tmp_path / "nope.safetensors")]) == 2
    assert not (tmp_path / "m.safetensors").exists()
