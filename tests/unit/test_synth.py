"""synth_dance: configuration, determinism, shapes, rigidity, splits, writing/reading, CLI."""

from __future__ import annotations

import hashlib
import json
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from momu.cli import main as momu_main
from momu.data.synth import (
    STYLE_NAMES,
    SynthConfig,
    SynthDance,
    generate_clip,
    load_written,
    split_of,
    write_dataset,
)
from momu.data.types import Clip, ClipDataset
from momu.features.skeletons import get_skeleton
from momu.registry import DATASETS

SMALL = SynthConfig(num_clips=6, min_seconds=2.0, max_seconds=3.0, styles=list(STYLE_NAMES))


def _bone_lengths(motion: np.ndarray, skeleton: str) -> np.ndarray:
    sk = get_skeleton(skeleton)
    return np.stack([np.linalg.norm(motion[:, c] - motion[:, p], axis=-1) for p, c in sk.bones], axis=1)


def test_clip_contents_and_units() -> None:
    clip = generate_clip(SMALL, 0)
    assert isinstance(clip, Clip)
    assert clip.id == "synth_00000" and clip.style == "ballet" and clip.skeleton == "smpl24"
    assert clip.fps == 60.0 and clip.sample_rate == 16000
    assert clip.motion is not None and clip.audio is not None
    assert clip.motion.dtype == np.float32 and clip.motion.shape[1:] == (24, 3)
    assert clip.audio.dtype == np.float32 and np.abs(clip.audio).max() <= 1.0
    assert 2.0 <= clip.duration <= 3.0 + 1 / 60
    # audio and motion cover the same time span
    assert clip.audio.shape[0] == round(clip.num_frames / clip.fps * clip.sample_rate)
    beats = np.asarray(clip.meta["beat_times"])
    assert np.all(np.diff(beats) > 0) and beats[0] >= 0 and beats[-1] < clip.duration
    lo, hi = (60.0, 76.0)  # ballet's tempo range
    assert lo <= clip.meta["bpm"] <= hi
    np.testing.assert_allclose(np.diff(beats), 60.0 / clip.meta["bpm"])
    # feet on the floor (Y up, metres), dancer about SMPL height
    feet = clip.motion[:, [7, 8, 10, 11], 1].min(axis=1)  # ankles and feet: soft floor contact
    assert np.all(feet >= -1e-6) and np.all(feet <= 0.01 * np.log(4) + 1e-6)
    assert 1.3 < np.median(clip.motion[:, 15, 1]) < 1.8  # head joint


def test_styles_cycle_and_have_distinct_tempo_ranges() -> None:
    styles = [generate_clip(SMALL, i).style for i in range(6)]
    assert styles == ["ballet", "hiphop", "zumba", "techno", "waltz", "rumba"]
    from momu.data.synth import STYLES
    from momu.data.synth.styles_ballroom import BALLROOM_STYLES

    ballroom = {s.name for s in BALLROOM_STYLES}
    for family in (ballroom, set(STYLES) - ballroom):  # in place, and travelling: each disjoint
        ranges = sorted(s.bpm for s in STYLES.values() if s.name in family)
        assert all(a[1] < b[0] for a, b in zip(ranges[:-1], ranges[1:], strict=True))


def test_bpm_range_decouples_tempo_from_style() -> None:
    """With ``bpm_range`` every style draws its tempo from the one range (a tempo augmentation), and
    everything but the tempo is drawn as without it: the beat grid follows the drawn tempo."""
    cfg = replace(SMALL, styles=["waltz", "quickstep"], num_clips=40, bpm_range=[60.0, 160.0])
    by_style: dict[str, list[float]] = {"waltz": [], "quickstep": []}
    for i in range(40):
        clip = generate_clip(cfg, i)
        by_style[str(clip.style)].append(clip.meta["bpm"])
        np.testing.assert_allclose(np.diff(clip.meta["beat_times"]), 60.0 / clip.meta["bpm"])
    waltz, quick = np.asarray(by_style["waltz"]), np.asarray(by_style["quickstep"])
    assert waltz.min() >= 60.0 and quick.max() <= 160.0
    assert waltz.max() > 136.0 and quick.min() < 84.0  # each style meets the other's range
    plain = generate_clip(replace(cfg, bpm_range=None), 0)
    assert plain.style == "waltz" and 60.0 <= plain.meta["bpm"] <= 84.0


def test_ballroom_styles_travel_and_step_like_real_dancers() -> None:
    """Dance with Melody dancers travel 15-55 m/min with ankles near 0.7 m/s (issue 32); the in-place
    styles travel a few metres a minute at most."""
    cfg = replace(
        SMALL, skeleton="dwm21", fps=25.0, min_seconds=20.0, max_seconds=20.0, trajectory_radius=4.0
    )

    def travel_and_ankle(style: str) -> tuple[float, float]:
        clip = generate_clip(replace(cfg, styles=[style]), 0)
        root, ankles = clip.motion[:, 2, [0, 2]], clip.motion[:, [9, 18]]
        minute = clip.duration / 60.0
        travel = float(np.linalg.norm(np.diff(root, axis=0), axis=-1).sum()) / minute
        return travel, float(np.linalg.norm(np.diff(ankles, axis=0), axis=-1).mean() * clip.fps)

    for style in ("waltz", "rumba", "cha_cha", "quickstep"):
        travel, ankle = travel_and_ankle(style)
        assert 12.0 < travel < 60.0 and 0.4 < ankle < 1.3, (style, travel, ankle)
    travel, _ = travel_and_ankle("ballet")
    assert travel < 10.0


def test_deterministic_and_independent_of_num_clips() -> None:
    a = generate_clip(SMALL, 3)
    b = SynthDance(replace(SMALL, num_clips=50))[3]
    assert a.motion is not None and b.motion is not None and a.audio is not None and b.audio is not None
    assert np.array_equal(a.motion, b.motion) and np.array_equal(a.audio, b.audio)
    assert a.meta == b.meta
    c = generate_clip(replace(SMALL, seed=1), 3)
    assert c.motion is not None and not np.array_equal(a.motion[:10], c.motion[:10])


@pytest.mark.parametrize("skeleton", ["smpl24", "dwm21", "humanml22", "coco17"])
def test_generated_3d_motion_is_rigid(skeleton: str) -> None:
    clip = generate_clip(replace(SMALL, skeleton=skeleton), 1)
    assert clip.motion is not None
    lengths = _bone_lengths(clip.motion.astype(np.float64), skeleton)
    np.testing.assert_allclose(
        lengths, np.broadcast_to(get_skeleton(skeleton).bone_lengths, lengths.shape), atol=2e-6
    )


def test_fps_defaults_to_the_skeleton_and_can_be_overridden() -> None:
    assert generate_clip(replace(SMALL, skeleton="dwm21"), 0).fps == 25.0
    clip = generate_clip(replace(SMALL, skeleton="dwm21", fps=30.0, min_seconds=2.0, max_seconds=2.0), 0)
    assert clip.fps == 30.0 and clip.num_frames == 60


def test_openpose14_is_2d_pixels_inside_the_image() -> None:
    clip = generate_clip(replace(SMALL, skeleton="openpose14"), 2)
    assert clip.motion is not None and clip.motion.shape[1:] == (14, 2)
    u, v = clip.motion[..., 0], clip.motion[..., 1]
    assert 0 < u.min() and u.max() < 1280 and 0 < v.min() and v.max() < 720
    # image v grows downwards: the nose is above (smaller v than) the ankles
    assert np.all(clip.motion[:, 0, 1] < clip.motion[:, 10, 1])
    # the projected skeleton is several hundred pixels tall
    assert 250 < np.median(clip.motion[:, 10, 1] - clip.motion[:, 0, 1]) < 500


def test_root_centred_stores_trajectory() -> None:
    glob = generate_clip(SMALL, 1)
    cent = generate_clip(replace(SMALL, root_centred=True), 1)
    assert glob.motion is not None and cent.motion is not None and cent.trajectory is not None
    assert np.allclose(cent.motion[:, 0], 0.0)
    np.testing.assert_allclose(cent.motion + cent.trajectory[:, None], glob.motion, atol=1e-6)


def test_dancer_travels_within_radius() -> None:
    clip = generate_clip(replace(SMALL, min_seconds=10, max_seconds=10, trajectory_radius=0.5), 2)
    assert clip.motion is not None
    root = clip.motion[:, 0]
    assert np.hypot(root[:, 0], root[:, 2]).max() <= 0.5 + 1e-6
    assert np.ptp(root[:, 0]) > 0.05  # zumba steps
    still = generate_clip(replace(SMALL, trajectory_radius=0.0), 2)
    assert still.motion is not None and np.abs(still.motion[:, 0, [0, 2]]).max() < 1e-9


def test_splits_are_fixed_per_index_and_balanced_over_styles() -> None:
    assert [split_of(i, 3) for i in range(9)] == ["train"] * 3 + ["val"] * 3 + ["test"] * 3
    full = SynthDance(replace(SMALL, num_clips=120, styles=["ballet", "hiphop", "zumba"]))
    splits = [split_of(i, 3) for i in full.indices]
    assert splits.count("train") == 96 and splits.count("val") == 12 and splits.count("test") == 12
    val = SynthDance(replace(SMALL, num_clips=120, styles=["ballet", "hiphop", "zumba"]), split="val")
    assert len(val) == 12 and {val[i].style for i in range(3)} == {"ballet", "hiphop", "zumba"}
    assert all(val[i].meta["split"] == "val" for i in range(3))
    assert len(SynthDance(SMALL, split="all")) == 6


@pytest.mark.parametrize(
    ("change", "message"),
    [
        ({"num_clips": -1}, "num_clips"),
        ({"min_seconds": 3.0, "max_seconds": 2.0}, "min_seconds"),
        ({"fps": 0.0}, "fps"),
        ({"skeleton": "smpl99"}, "smpl99"),
        ({"styles": ["disco"]}, "disco"),
        ({"styles": []}, "styles"),
        ({"phase_jitter": -0.1}, "phase_jitter"),
        ({"amplitude_range": [1.0]}, "amplitude_range"),
        ({"root_centred": True, "skeleton": "openpose14"}, "root_centred"),
        ({"bpm_range": [120.0, 90.0]}, "bpm_range"),
        ({"bpm_range": [0.0, 90.0]}, "bpm_range"),
        ({"bpm_range": [90.0]}, "bpm_range"),
    ],
)
def test_bad_config_names_the_field(change: dict, message: str) -> None:
    with pytest.raises(ValueError, match=message):
        SynthDance(replace(SMALL, **change))


def test_bad_split_and_index() -> None:
    with pytest.raises(ValueError, match="split"):
        SynthDance(SMALL, split="training")
    with pytest.raises(IndexError):
        SynthDance(SMALL)[6]


def test_registered_dataset_builds_from_config(tmp_path: Path) -> None:
    ds = DATASETS.build(
        "synth_dance", {"num_clips": 4, "min_seconds": 1.0, "max_seconds": 1.0, "split": "train"}
    )
    assert isinstance(ds, ClipDataset) and len(ds) == 3
    write_dataset(tmp_path, replace(SMALL, num_clips=4, min_seconds=1.0, max_seconds=1.0, styles=["hiphop"]))
    read = DATASETS.build("synth_dance", {"root": str(tmp_path), "split": "val"})
    assert len(read) == 1 and read[0].id == "synth_00001"


def _digest(folder: Path) -> dict[str, str]:
    return {
        str(p.relative_to(folder)): hashlib.sha256(p.read_bytes()).hexdigest()
        for p in sorted(folder.rglob("*"))
        if p.is_file()
    }


def test_write_is_byte_identical_and_reads_back(tmp_path: Path) -> None:
    cfg = replace(SMALL, num_clips=4, min_seconds=1.5, max_seconds=2.5)
    a, b = write_dataset(tmp_path / "a", cfg), write_dataset(tmp_path / "b", cfg)
    digests = _digest(a)
    assert set(digests) == {"manifest.json"} | {
        f"{k}/synth_0000{i}.{e}" for i in range(4) for k, e in (("audio", "wav"), ("motion", "npy"))
    }
    assert digests == _digest(b)

    manifest = json.loads((a / "manifest.json").read_text())
    assert manifest["skeleton"] == "smpl24" and manifest["fps"] == 60.0 and manifest["sample_rate"] == 16000
    assert manifest["splits"] == {"train": 4, "val": 0, "test": 0}
    entry = manifest["clips"][2]
    assert entry["style"] == "zumba" and entry["split"] == "train" and entry["beat_times"]

    ds = load_written(a)
    assert len(ds) == 4
    for i in range(4):
        disk, mem = ds[i], generate_clip(cfg, i)
        assert disk.id == mem.id and disk.style == mem.style and disk.fps == mem.fps
        assert (
            disk.motion is not None
            and mem.motion is not None
            and disk.audio is not None
            and mem.audio is not None
        )
        assert np.array_equal(disk.motion, mem.motion)
        np.testing.assert_allclose(disk.audio, mem.audio, atol=1.0 / 2**15)  # PCM_16 quantisation
        assert disk.meta["beat_times"] == mem.meta["beat_times"]


def test_float_wavs_round_trip_exactly(tmp_path: Path) -> None:
    cfg = replace(SMALL, num_clips=1, min_seconds=1.0, max_seconds=1.0)
    write_dataset(tmp_path, cfg, subtype="FLOAT")
    disk, mem = load_written(tmp_path)[0], generate_clip(cfg, 0)
    assert disk.audio is not None and mem.audio is not None and np.array_equal(disk.audio, mem.audio)


def test_root_centred_copy_keeps_trajectory(tmp_path: Path) -> None:
    cfg = replace(SMALL, num_clips=1, min_seconds=1.0, max_seconds=1.0, root_centred=True)
    write_dataset(tmp_path, cfg)
    disk, mem = load_written(tmp_path)[0], generate_clip(cfg, 0)
    assert disk.trajectory is not None and mem.trajectory is not None
    assert np.array_equal(disk.trajectory, mem.trajectory)


def test_reading_a_damaged_copy_names_the_file(tmp_path: Path) -> None:
    with pytest.raises(FileNotFoundError, match="manifest"):
        load_written(tmp_path)
    write_dataset(tmp_path, replace(SMALL, num_clips=2, min_seconds=1.0, max_seconds=1.0))
    (tmp_path / "audio" / "synth_00001.wav").unlink()
    ds = load_written(tmp_path)
    with pytest.raises(FileNotFoundError, match="synth_00001.wav"):
        ds[1]
    np.save(tmp_path / "motion" / "synth_00000.npy", np.zeros((3, 24, 3), np.float32))
    with pytest.raises(ValueError, match="synth_00000.npy"):
        ds[0]
    (tmp_path / "manifest.json").write_text('{"format": "other"}')
    with pytest.raises(ValueError, match="not a synth_dance manifest"):
        load_written(tmp_path)


def test_cli_writes_and_rejects_bad_options(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "synth"
    args = ["data", "synth", "--out", str(out), "--clips", "2", "--seconds", "1", "--no-progress"]
    assert momu_main([*args, "--skeleton", "openpose14", "--seed", "3"]) == 0
    manifest = json.loads((out / "manifest.json").read_text())
    assert manifest["skeleton"] == "openpose14" and manifest["config"]["seed"] == 3
    assert len(manifest["clips"]) == 2 and (out / "motion" / "synth_00001.npy").is_file()
    assert "wrote 2 clips" in capsys.readouterr().out

    assert momu_main([*args, "--styles", "disco"]) == 2
    assert "disco" in capsys.readouterr().err
    assert momu_main([*args, "--seconds", "0"]) == 2
    assert "min_seconds" in capsys.readouterr().err
    with pytest.raises(SystemExit) as exit_:
        momu_main([*args, "--skeleton", "nope"])
    assert exit_.value.code == 2
    assert "--skeleton" in capsys.readouterr().err.strip().splitlines()[-1]


def test_breaks_silence_the_music_and_the_motion_flows_through() -> None:
    cfg = replace(SMALL, min_seconds=20.0, max_seconds=20.0, break_prob=0.5)
    clip = generate_clip(cfg, 1)
    beats = np.asarray(clip.meta["beat_times"])
    onsets = np.asarray(clip.meta["onset_times"])
    keys = np.asarray(clip.meta["motion_beat_times"])
    breaks = clip.meta["break_times"]
    assert breaks and set(onsets) <= set(beats) and len(onsets) < len(beats)
    for start, end in breaks:
        assert np.any(np.isclose(onsets, start))  # the break's downbeat sounds ...
        assert not np.any((onsets > start + 1e-6) & (onsets < end - 1e-6))  # ... then no attack
        assert not np.any((keys > start + 0.2) & (keys < end - 0.2))  # one slow move, no key pose
        assert np.any(np.abs(keys - start) < 0.1)  # the dancer hits a pose on the downbeat
    # the beat grid continues through breaks
    np.testing.assert_allclose(np.diff(beats), 60.0 / clip.meta["bpm"])

    plain = generate_clip(replace(cfg, break_prob=0.0), 1)
    assert plain.meta["break_times"] == [] and plain.meta["onset_times"] == plain.meta["beat_times"]
