"""Issue 13, ``momu eval``: no scoring of filled-in modalities, skeleton and fps checks, one audio list,
short-clip warnings, Fréchet round-off flags, failing metrics reported, lazy clips, warnings once."""

from __future__ import annotations

import json
import logging
from pathlib import Path

import numpy as np
import pytest
import soundfile as sf
from tests.unit.test_eval_cli import FPS, make_pair_dirs, run_eval
from tests.unit.test_metrics_beats_audio import SR, clicks, swing

from momu.cli import eval_inputs, generate_cmd
from momu.data import ballroom, common
from momu.export.npz import write_motion_npz
from momu.io import write_json
from momu.registry import METRICS


def test_beat_scores_of_motion_only_folders_is_an_error_not_f1_1(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    gen, gt = make_pair_dirs(tmp_path)  # generated dances only: the music would be the reference's
    out = tmp_path / "s.json"
    assert run_eval(gen, gt, "beat_scores", "--fps", "30", "--out", str(out)) == 2
    err = capsys.readouterr().err
    assert "metric 'beat_scores' scores generated music" in err and not out.exists()
    (tmp_path / "b").mkdir()
    gen2, gt2 = make_pair_dirs(tmp_path / "b", gen_audio=True)
    fine = ("--set", "beat_scores.bin_seconds=0.25")
    assert run_eval(gen2, gt2, "beat_scores", "--fps", "30", *fine, "--out", str(out)) == 0
    assert json.loads(out.read_text())["scores"]["beat_scores.f1"] < 1.0  # off-beat music is not perfect


def test_a_17_joint_motion_against_24_joint_references_is_refused(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    gen, gt = make_pair_dirs(tmp_path)
    for p in gt.glob("*.npy"):
        np.save(p, np.zeros((150, 24, 3), np.float32) + np.load(p)[:, :1])
    for p in gen.glob("*.npy"):
        np.save(p, np.zeros((150, 17, 3), np.float32) + np.load(p)[:, :1])
    for metric in ("bas", "harmony", "kinematic_beat_scores"):
        assert run_eval(gen, gt, metric, "--fps", "30") == 2
        err = capsys.readouterr().err
        assert "17 joints x 3D) does not match its reference" in err and "clip0.npy" in err


def test_a_frame_rate_mismatch_from_a_sidecar_is_refused(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    gen, gt = make_pair_dirs(tmp_path)
    (gen / "clip1.json").write_text(json.dumps({"fps": 60.0, "skeleton": ""}))
    assert run_eval(gen, gt, "bas", "--fps", "30") == 2
    assert "clip1.npy: 60 fps but its reference" in capsys.readouterr().err


def test_one_list_of_audio_formats_for_the_whole_cli(tmp_path: Path) -> None:
    assert generate_cmd.AUDIO_SUFFIXES is common.AUDIO_SUFFIXES is eval_inputs.AUDIO_SUFFIXES
    assert ballroom.AUDIO_SUFFIXES is common.AUDIO_SUFFIXES and ".opus" in common.AUDIO_SUFFIXES
    gen, gt = make_pair_dirs(tmp_path)
    for i in range(2):
        audio = clicks([1.0, 2.0, 3.0, 4.0], 5.0, sr=48000)
        sf.write(gen / f"clip{i}.opus", audio, 48000, format="OGG", subtype="OPUS")
    out = tmp_path / "s.json"
    assert run_eval(gen, gt, "beat_scores", "--fps", "30", "--out", str(out)) == 0  # .opus is read
    assert json.loads(out.read_text())["inputs"]["generated_modalities"]["clip0"]["audio"].endswith(".opus")


def test_clips_too_short_for_the_bins_are_flagged(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    gen, gt = tmp_path / "gen", tmp_path / "gt"
    gen.mkdir()
    gt.mkdir()
    for i in range(2):
        motion = swing(FPS, 1.0).astype(np.float32)
        np.save(gen / f"c{i}.npy", motion)
        np.save(gt / f"c{i}.npy", motion)
        sf.write(gt / f"c{i}.wav", clicks([0.25, 0.75], 1.0), SR)
    out = tmp_path / "s.json"
    assert run_eval(gen, gt, "kinematic_beat_scores,hit_rate", "--fps", "30", "--out", str(out)) == 0
    table = capsys.readouterr().out
    assert "warning: kinematic_beat_scores: 2 of 2 clips are shorter than 4 s" in table
    warnings = json.loads(out.read_text())["warnings"]
    assert set(warnings) == {"kinematic_beat_scores", "hit_rate"} and "saturates" in warnings["hit_rate"]


def test_a_frechet_distance_within_round_off_is_flagged(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    gen, gt = tmp_path / "gen", tmp_path / "gt"
    gen.mkdir()
    gt.mkdir()
    rng = np.random.default_rng(0)
    for i in range(40):
        motion = (rng.normal(size=(1, 24, 3)) + 0.05 * np.cumsum(rng.normal(size=(90, 24, 3)), 0)).astype(
            np.float32
        )
        np.save(gen / f"c{i:02d}.npy", motion)
        np.save(gt / f"c{i:02d}.npy", motion)  # identical sets: FID is 0 up to round-off
    out = tmp_path / "s.json"
    assert run_eval(gen, gt, "fid_g", "--fps", "30", "--out", str(out)) == 0
    result = json.loads(out.read_text())
    assert abs(result["scores"]["fid_g"]) <= 1e-4  # printed as the reference computes it ...
    assert "round-off" in result["flags"]["fid_g"]  # ... and flagged
    assert "≈ 0 within round-off" in capsys.readouterr().out


class _Broken:
    needs_reference = False

    def __init__(self, cfg: object, result: object) -> None:
        self.cfg, self.result, self.name = cfg, result, "broken"

    def __call__(self, generated, reference=None):  # type: ignore[no-untyped-def]
        if isinstance(self.result, Exception):
            raise self.result
        return self.result

    def provenance(self) -> dict[str, object]:
        return {}


@pytest.mark.parametrize("result", [TypeError("bad operand"), [1.0, 2.0], {"x": "text"}, MemoryError()])
def test_a_failing_metric_is_reported_and_the_others_kept(
    result: object, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    METRICS.register("h13_broken")(lambda: _Broken(None, result))
    try:
        gen, gt = make_pair_dirs(tmp_path)
        out = tmp_path / "s.json"
        assert run_eval(gen, gt, "h13_broken,bas", "--fps", "30", "--out", str(out)) == 1
        data = json.loads(out.read_text())
        assert "bas" in data["scores"] and "h13_broken" in data["errors"]
        assert "FAILED" in capsys.readouterr().out
    finally:
        METRICS.unregister("h13_broken")


def test_pairs_are_checked_once_and_read_lazily(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    gen, gt = make_pair_dirs(tmp_path, n=3)
    for i in range(3):
        write_json(gen / f"clip{i}.json", {"fps": FPS})
    reads: list[Path] = []
    real_read_json = eval_inputs.read_json
    monkeypatch.setattr(eval_inputs, "read_json", lambda p: reads.append(Path(p)) or real_read_json(p))
    generated, reference = eval_inputs.load_pairs(gen, gt, FPS)
    assert sorted(p.name for p in reads) == ["clip0.json", "clip1.json", "clip2.json"]  # each sidecar once
    for clip in (*generated, *reference):
        assert isinstance(clip, eval_inputs.LazyClip)
        assert not any(isinstance(v, np.ndarray) for v in vars(clip).values())  # no arrays held
    assert generated[0].motion.shape == (150, 3, 3) and generated[0].audio is not None
    assert generated[0].generated_modalities == ("motion",)
    changed = np.load(gen / "clip0.npy") + 1.0
    np.save(gen / "clip0.npy", changed)  # the motion is read from its file on every access
    np.testing.assert_array_equal(generated[0].motion, changed)
    assert len(reads) == 3  # and the sidecar is not read again


def test_a_repeated_warning_is_printed_once(tmp_path: Path, caplog: pytest.LogCaptureFixture) -> None:
    log = logging.getLogger("h13.metric")

    class Chatty(_Broken):
        def __call__(self, generated, reference=None):  # type: ignore[no-untyped-def]
            for _ in generated:
                log.warning("clip is odd")
            return {"chatty": 1.0}

    METRICS.register("h13_chatty")(lambda: Chatty(None, None))
    try:
        gen, gt = make_pair_dirs(tmp_path, n=4)
        caplog.set_level(logging.WARNING)
        assert run_eval(gen, gt, "h13_chatty", "--fps", "30") == 0
        assert caplog.text.count("clip is odd") == 1
    finally:
        METRICS.unregister("h13_chatty")


def test_eval_out_is_checked_before_any_work(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    gen, gt = make_pair_dirs(tmp_path)
    (tmp_path / "afile").write_text("x")
    assert run_eval(gen, gt, "bas", "--fps", "30", "--out", str(tmp_path / "afile" / "s.json")) == 2
    assert "afile is a file" in capsys.readouterr().err


def _npz_pair_dirs(tmp_path: Path, gen_fps: float) -> tuple[Path, Path]:
    """A generated ``clip0.npz`` as ``momu generate`` writes it, beside a reference ``.npy`` + music."""
    gen, gt = tmp_path / "gen", tmp_path / "gt"
    gen.mkdir()
    gt.mkdir()
    motion = np.tile(swing(30.0, 5.0), (1, 7, 1)).astype(np.float32)  # (T, 21, 3): the dwm21 layout
    write_motion_npz(gen / "clip0.npz", motion, gen_fps, "dwm21")
    np.save(gt / "clip0.npy", motion)
    sf.write(gt / "clip0.wav", clicks([1.0, 2.0, 3.0, 4.0], 5.0), SR)
    return gen, gt


def test_momu_generate_npz_files_are_evaluated_with_their_own_fps(tmp_path: Path) -> None:
    gen, gt = _npz_pair_dirs(tmp_path, 30.0)
    out = tmp_path / "s.json"
    assert run_eval(gen, gt, "hit_rate", "--fps", "30", "--out", str(out)) == 0
    assert json.loads(out.read_text())["scores"]["hit_rate"] == 1.0  # the same motion as the reference


def test_an_npz_frame_rate_mismatch_is_refused(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    gen, gt = _npz_pair_dirs(tmp_path, 60.0)  # the npz's own fps wins over --fps
    assert run_eval(gen, gt, "hit_rate", "--fps", "30") == 2
    assert "clip0.npz: 60 fps but its reference" in capsys.readouterr().err
