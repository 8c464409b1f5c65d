"""Shared loader helpers: audio/JSON/npy readers, keypoint cleaning, cropping, splits, errors."""

from __future__ import annotations

import pickle
from pathlib import Path

import numpy as np
import pytest
import soundfile as sf
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra import numpy as hnp

from momu.data.common import (
    DataFileError,
    MissingDataFileError,
    check_length_match,
    clean_keypoints,
    crop_clip,
    hash_split,
    load_audio,
    load_npy,
    read_json_file,
    read_lines,
    require_root,
    resample_motion,
)
from momu.data.types import Clip


# ------------------------------------------------------------------------------------------ audio
def _write(path: Path, data: np.ndarray, sr: int) -> Path:
    sf.write(str(path), data.astype(np.float32), sr, subtype="FLOAT")
    return path


def test_load_audio_averages_channels_and_reads_the_requested_span(tmp_path: Path) -> None:
    left = np.linspace(-0.5, 0.5, 1000)
    right = np.full(1000, 0.25)
    path = _write(tmp_path / "a.wav", np.stack([left, right], axis=1), 100)
    audio, sr = load_audio(path)
    assert sr == 100 and audio.dtype == np.float32 and audio.shape == (1000,)
    np.testing.assert_allclose(audio, (left + right) / 2, atol=1e-6)
    part, _ = load_audio(path, offset=2.0, duration=3.0)  # samples 200..499
    np.testing.assert_allclose(part, ((left + right) / 2)[200:500], atol=1e-6)
    tail, _ = load_audio(path, offset=9.0, duration=5.0)  # only 1 s left: returns what exists
    assert tail.shape == (100,)


def test_load_audio_resamples_to_the_requested_rate(tmp_path: Path) -> None:
    t = np.arange(8000) / 8000
    path = _write(tmp_path / "tone.wav", 0.5 * np.sin(2 * np.pi * 100 * t), 8000)
    audio, sr = load_audio(path, sample_rate=16000)
    assert sr == 16000 and abs(len(audio) - 16000) <= 1
    spectrum = np.abs(np.fft.rfft(audio))
    assert abs(np.argmax(spectrum) * 16000 / len(audio) - 100) < 2  # the tone stays at 100 Hz


def test_load_audio_errors_name_the_file_and_the_problem(tmp_path: Path) -> None:
    with pytest.raises(MissingDataFileError, match="missing.wav: audio file not found") as info:
        load_audio(tmp_path / "missing.wav")
    assert isinstance(info.value, FileNotFoundError) and isinstance(info.value, ValueError)
    (tmp_path / "zero.mp3").write_bytes(b"")
    with pytest.raises(DataFileError, match=r"zero.mp3: empty audio file \(0 bytes\)"):
        load_audio(tmp_path / "zero.mp3")
    _write(tmp_path / "silent.wav", np.zeros(0), 8000)
    with pytest.raises(DataFileError, match=r"silent.wav: empty audio \(0 samples\)"):
        load_audio(tmp_path / "silent.wav")
    (tmp_path / "junk.wav").write_bytes(b"RIFF1234WAVEjunkjunkjunk")
    with pytest.raises(DataFileError, match="junk.wav: cannot decode audio"):
        load_audio(tmp_path / "junk.wav")
    path = _write(tmp_path / "short.wav", np.zeros(100), 100)
    with pytest.raises(
        DataFileError, match=r"short.wav: audio is 1.00 s long; cannot start reading at 5.00 s"
    ):
        load_audio(path, offset=5.0)
    bad = np.zeros(100)
    bad[10] = np.nan
    with pytest.raises(DataFileError, match="1 non-finite audio samples"):
        load_audio(_write(tmp_path / "nan.wav", bad, 100))


# -------------------------------------------------------------------------------- text, json, npy
def test_read_lines_strips_whitespace_and_blank_lines(tmp_path: Path) -> None:
    (tmp_path / "list.txt").write_text("  a \n\n\tb#c\r\n   \n")
    assert read_lines(tmp_path / "list.txt") == ["a", "b#c"]
    with pytest.raises(MissingDataFileError, match="nope.txt: file not found"):
        read_lines(tmp_path / "nope.txt")


def test_read_json_file_reports_position_of_the_syntax_error(tmp_path: Path) -> None:
    (tmp_path / "c.json").write_text('{"a": 1,\n "b": }')
    with pytest.raises(DataFileError, match=r"c.json: invalid JSON at line 2 column 7") as info:
        read_json_file(tmp_path / "c.json")
    assert info.value.path == tmp_path / "c.json"
    assert read_json_file(_json(tmp_path / "ok.json", {"x": [1, 2]})) == {"x": [1, 2]}


def _json(path: Path, obj: object) -> Path:
    import json

    path.write_text(json.dumps(obj))
    return path


def test_load_npy_refuses_pickled_objects_and_non_numeric_arrays(tmp_path: Path) -> None:
    np.save(tmp_path / "ok.npy", np.arange(6).reshape(2, 3))
    np.testing.assert_array_equal(load_npy(tmp_path / "ok.npy"), np.arange(6).reshape(2, 3))
    np.save(tmp_path / "obj.npy", np.array([{"a": 1}], dtype=object), allow_pickle=True)
    with pytest.raises(DataFileError, match="obj.npy: holds pickled Python objects"):
        load_npy(tmp_path / "obj.npy")
    np.save(tmp_path / "str.npy", np.array(["a", "b"]))
    with pytest.raises(DataFileError, match="str.npy: expected a numeric array"):
        load_npy(tmp_path / "str.npy")
    (tmp_path / "junk.npy").write_bytes(b"junk")
    with pytest.raises(DataFileError, match=r"junk.npy: not a .npy file \(no NUMPY header\)"):
        load_npy(tmp_path / "junk.npy")
    (tmp_path / "cut.npy").write_bytes((tmp_path / "ok.npy").read_bytes()[:-8])
    with pytest.raises(DataFileError, match="cut.npy: not a valid .npy file"):
        load_npy(tmp_path / "cut.npy")


# ------------------------------------------------------------------------------------- keypoints
def test_clean_keypoints_interpolates_short_gaps_linearly() -> None:
    x = np.zeros((6, 2, 3), np.float32)
    x[:, 1, 0] = np.arange(6)  # joint 1 moves 1 unit per frame along x
    x[1:4, 1] = np.nan
    out, filled = clean_keypoints(x, "clip.npy", joints=2, dims=3, max_gap=3)
    assert filled == 3 and out.dtype == np.float32
    np.testing.assert_allclose(out[:, 1, 0], np.arange(6))
    np.testing.assert_array_equal(out[:, 0], 0.0)


def test_clean_keypoints_honours_a_missing_mask() -> None:
    x = np.tile(np.arange(5, dtype=np.float32)[:, None, None], (1, 1, 2))
    x[2] = 100.0  # a detector outlier flagged by zero confidence
    missing = np.zeros((5, 1), bool)
    missing[2] = True
    out, filled = clean_keypoints(x, "p.npy", joints=1, dims=2, max_gap=2, missing=missing)
    assert filled == 1
    np.testing.assert_allclose(out[:, 0, 0], np.arange(5))


def test_clean_keypoints_errors_name_file_joint_and_frame() -> None:
    x = np.zeros((10, 3, 2), np.float32)
    with pytest.raises(
        DataFileError, match=r"a.npy: expected keypoints of shape \(T, 4, 2\), got \(10, 3, 2\)"
    ):
        clean_keypoints(x, "a.npy", joints=4, dims=2, max_gap=None)
    with pytest.raises(DataFileError, match="no frames"):
        clean_keypoints(np.zeros((0, 3, 2)), "a.npy", joints=3, dims=2, max_gap=None)
    y = x.copy()
    y[:, 2] = np.nan
    with pytest.raises(DataFileError, match=r"joint\(s\) \[2\] missing in every frame"):
        clean_keypoints(y, "a.npy", joints=3, dims=2, max_gap=None)
    z = x.copy()
    z[3:8, 1] = np.nan
    with pytest.raises(
        DataFileError, match=r"5 keypoint\(s\) in runs of more than max_gap=4 .*joint 1, frame 3"
    ):
        clean_keypoints(z, "a.npy", joints=3, dims=2, max_gap=4)
    out, filled = clean_keypoints(z, "a.npy", joints=3, dims=2, max_gap=5)
    assert filled == 5 and np.isfinite(out).all()


# ------------------------------------------------------------------------------ lengths and crops
def test_check_length_match_tolerance() -> None:
    check_length_match("x.wav", 10.0, 10.9, 1.0)
    with pytest.raises(DataFileError, match=r"x.wav: motion lasts 10.00 s but its audio 12.50 s.*2.50 s"):
        check_length_match("x.wav", 10.0, 12.5, 1.0)


def test_crop_clip_cuts_motion_audio_confidence_and_beats_consistently() -> None:
    motion = np.arange(50, dtype=np.float32)[:, None, None] * np.ones((1, 2, 2), np.float32)
    clip = Clip(
        id="c",
        motion=motion,
        fps=10.0,
        audio=np.arange(500, dtype=np.float32),
        sample_rate=100,
        trajectory=np.zeros((50, 3), np.float32),
        meta={"beat_times": np.array([0.5, 1.5, 2.5, 3.5]), "confidence": np.arange(50.0)[:, None]},
    )
    out = crop_clip(clip, 1.0, 2.0)
    np.testing.assert_array_equal(out.motion[:, 0, 0], np.arange(10, 30))
    np.testing.assert_array_equal(out.audio, np.arange(100, 300))
    np.testing.assert_allclose(out.meta["beat_times"], [0.5, 1.5])
    np.testing.assert_array_equal(out.meta["confidence"][:, 0], np.arange(10, 30))
    assert out.trajectory is not None and out.trajectory.shape == (20, 3)
    assert out.duration == pytest.approx(2.0) and out.meta["window"] == (1.0, 3.0)
    assert clip.motion.shape[0] == 50  # the original is untouched
    with pytest.raises(
        ValueError, match=r"clip 'c' is 5.00 s long, shorter than the requested window \[4.00, 6.00\)"
    ):
        crop_clip(clip, 4.0, 2.0)


def test_resample_motion_subsamples_integer_ratios_exactly() -> None:
    motion = np.arange(11, dtype=np.float32)[:, None, None] * np.ones((1, 2, 3), np.float32)
    meta = {"confidence": np.arange(11.0)[:, None], "smpl_poses": np.arange(11.0)[:, None] * np.ones((1, 72))}
    clip = Clip(id="r", motion=motion, fps=60.0, meta=meta)
    out = resample_motion(clip, 30.0)
    assert out.fps == 30.0 and out.num_frames == 5 and out.meta["source_fps"] == 60.0
    np.testing.assert_array_equal(out.motion[:, 0, 0], [0, 2, 4, 6, 8])
    np.testing.assert_array_equal(out.meta["confidence"][:, 0], [0, 2, 4, 6, 8])
    np.testing.assert_array_equal(out.meta["smpl_poses"][:, 0], [0, 2, 4, 6, 8])
    assert resample_motion(clip, 60.0) is clip


def test_resample_motion_interpolates_positions_and_takes_nearest_smpl() -> None:
    frames = 26  # 25 fps, 1.04 s
    motion = np.arange(frames, dtype=np.float32)[:, None, None] * np.ones((1, 1, 3), np.float32)
    clip = Clip(
        id="r",
        motion=motion,
        fps=25.0,
        trajectory=np.arange(frames, dtype=np.float32)[:, None] * np.ones((1, 3), np.float32),
        meta={"smpl_trans": np.arange(frames, dtype=np.float32)[:, None] * np.ones((1, 3), np.float32)},
    )
    out = resample_motion(clip, 20.0)  # frame k sits at original frame 1.25 k
    assert out.num_frames == 20 and out.duration <= clip.duration
    np.testing.assert_allclose(out.motion[:, 0, 0], 1.25 * np.arange(20), atol=1e-5)
    np.testing.assert_allclose(out.trajectory[:, 0], 1.25 * np.arange(20), atol=1e-5)
    np.testing.assert_array_equal(out.meta["smpl_trans"][:, 0], np.round(1.25 * np.arange(20)))


# ------------------------------------------------------------------------------------ splits, misc
def test_hash_split_is_deterministic_per_id_and_close_to_the_ratios() -> None:
    ids = [f"item{i}" for i in range(3000)]
    first = [hash_split(i) for i in ids]
    # pinned: a change of the hash would silently reshuffle every user's train/val/test splits
    assert [first[i] for i in (0, 1, 7, 69, 19)] == ["train", "val", "test", "val", "test"]
    assert first == [hash_split(i) for i in reversed(ids)][::-1]  # independent of order / other ids
    share = {s: first.count(s) / len(ids) for s in ("train", "val", "test")}
    assert abs(share["train"] - 0.9) < 0.03 and abs(share["val"] - 0.05) < 0.02
    assert [hash_split(i, seed=1) for i in ids] != first
    assert {hash_split(i, (0.0, 0.0, 1.0)) for i in ids[:50]} == {"test"}
    with pytest.raises(ValueError, match="sum"):
        hash_split("x", (0.5, 0.6, 0.1))


def test_require_root_messages(tmp_path: Path) -> None:
    with pytest.raises(ValueError, match="'root' is required"):
        require_root("", "aistpp", "annotations")
    with pytest.raises(
        FileNotFoundError, match=r"aistpp: root folder .*nowhere does not exist \(expected annotations\)"
    ):
        require_root(tmp_path / "nowhere", "aistpp", "annotations")
    assert require_root(tmp_path, "aistpp", "annotations") == tmp_path


def test_data_file_error_carries_path_and_reason_through_pickling() -> None:
    err = pickle.loads(pickle.dumps(DataFileError("/x/y.npy", "bad shape")))
    assert err.path == Path("/x/y.npy") and err.reason == "bad shape" and str(err) == "/x/y.npy: bad shape"


# ------------------------------------------------------------------------------------ properties
@settings(deadline=None)
@given(
    fps=st.sampled_from([15.0, 20.0, 25.0, 60.0]),
    frames=st.integers(10, 300),
    start_frac=st.floats(0.0, 0.9),
    len_frac=st.floats(0.05, 1.0),
    beats=st.lists(st.floats(0.0, 20.0), max_size=20),
)
def test_crop_clip_keeps_modalities_aligned(
    fps: float, frames: int, start_frac: float, len_frac: float, beats: list[float]
) -> None:
    sr = 100
    duration = frames / fps
    start = start_frac * duration
    seconds = max(len_frac * (duration - start), 1.0 / fps)
    if start + seconds > duration:
        return
    clip = Clip(
        id="p",
        motion=np.zeros((frames, 1, 2), np.float32),
        fps=fps,
        audio=np.zeros(int(round(duration * sr)), np.float32),
        sample_rate=sr,
        meta={"beat_times": np.sort(np.asarray(beats))},
    )
    out = crop_clip(clip, start, seconds)
    assert abs(out.num_frames - seconds * fps) <= 1
    assert abs(len(out.audio) / sr - out.num_frames / fps) <= 1.0 / fps + 1.0 / sr
    kept = out.meta["beat_times"]
    assert np.all((kept >= 0) & (kept < seconds))
    assert len(kept) == int(np.sum((np.asarray(beats) >= start) & (np.asarray(beats) < start + seconds)))


@settings(deadline=None)
@given(
    data=hnp.arrays(np.float32, (12, 3, 2), elements=st.floats(-100, 100, width=32)),
    holes=hnp.arrays(np.bool_, (12, 3)),
)
def test_clean_keypoints_fills_every_hole_keeps_observed(data: np.ndarray, holes: np.ndarray) -> None:
    holes[0] = False  # every joint observed at least once
    x = data.copy()
    x[holes] = np.nan
    out, filled = clean_keypoints(x, "p.npy", joints=3, dims=2, max_gap=None)
    assert filled == int(holes.sum()) and np.isfinite(out).all()
    np.testing.assert_array_equal(out[~holes], data[~holes])
