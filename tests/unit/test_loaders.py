"""Each real-dataset loader reads its published layout (written by tests/fixtures/layouts.py)."""

from __future__ import annotations

import pickle
from pathlib import Path

import numpy as np
import pytest
from tests.fixtures import layouts

from momu.config import ConfigError
from momu.data.aistpp import normalize_sequence_name, parse_sequence_name
from momu.data.common import DataFileError, MissingDataFileError
from momu.data.humanml3d import parse_text_line
from momu.registry import DATASETS, RegistryError

LOADERS = ("aistpp", "loris", "d2m", "dance_with_melody", "ballroom", "humanml3d")


def build(name: str, root: Path, **params: object):  # noqa: ANN201
    return DATASETS.build(name, {"root": str(root), **params})


@pytest.fixture(scope="module")
def aist_root(tmp_path_factory: pytest.TempPathFactory) -> Path:
    root = tmp_path_factory.mktemp("aistpp")
    layouts.write_aistpp(root)
    return root


def test_all_loaders_are_registered_with_a_root_option() -> None:
    for name in LOADERS:
        entry = DATASETS.get(name)
        assert entry.source == "momu" and hasattr(entry.default_config(), "root")


def test_misspelled_option_names_the_valid_keys(aist_root: Path) -> None:
    with pytest.raises((ConfigError, RegistryError, ValueError), match="music_dir"):
        build("aistpp", aist_root, musik_dir="x")


# ------------------------------------------------------------------------------------------ AIST++
def test_aistpp_splits_ignore_list_and_sequence_names(aist_root: Path) -> None:
    train = build("aistpp", aist_root, split="train", load_audio=False)
    assert train.ids == sorted(layouts.AISTPP_GOOD[:2])
    assert build("aistpp", aist_root, split="val", load_audio=False).ids == [layouts.AISTPP_GOOD[2]]
    everything = build("aistpp", aist_root, split="all", load_audio=False)
    assert sorted(everything.ids) == sorted(layouts.AISTPP_GOOD)  # the ignored sequence is skipped
    assert layouts.AISTPP_IGNORED in everything.ignored
    assert normalize_sequence_name(" gBR_sBM_c01_d04_mBR0_ch01.json ") == "gBR_sBM_cAll_d04_mBR0_ch01"
    assert parse_sequence_name("gBR_sBM_cAll_d04_mBR0_ch01")["music_id"] == "mBR0"
    with pytest.raises(ValueError, match="6 '_'-fields"):
        parse_sequence_name("gBR_sBM_d04")


def test_aistpp_clip_holds_scaled_keypoints_smpl_and_the_music(aist_root: Path) -> None:
    ds = build("aistpp", aist_root, split="train", sample_rate=None)
    clip = ds[ds.ids.index(layouts.AISTPP_GOOD[0])]
    with open(aist_root / "keypoints3d" / f"{clip.id}.pkl", "rb") as f:
        raw = pickle.load(f)["keypoints3d"]
    assert clip.motion.shape == (120, 17, 3) and clip.motion.dtype == np.float32
    assert clip.fps == 60.0 and clip.skeleton == "coco17" and clip.style == "gBR"
    ok = np.isfinite(raw).all(axis=-1)
    np.testing.assert_allclose(clip.motion[ok], raw[ok] * 0.01, rtol=1e-6)
    assert np.isfinite(clip.motion).all() and clip.meta["interpolated_keypoints"] == 5
    assert clip.meta["music_id"] == "mBR0" and clip.meta["split"] == "train"
    assert clip.meta["smpl_poses"].shape == (120, 72) and clip.meta["smpl_scaling"] == 93.0
    # The music (3 s) is cut to the motion (2 s); it starts with the motion.
    assert clip.sample_rate == layouts.AUDIO_SR and len(clip.audio) == 2 * layouts.AUDIO_SR
    music, _ = layouts.sf.read(str(aist_root / "wavs" / "mBR0.wav"), dtype="float32")
    np.testing.assert_allclose(clip.audio, music[: len(clip.audio)], atol=1e-6)


def test_aistpp_keypoints2d_view_and_window(aist_root: Path) -> None:
    ds = build("aistpp", aist_root, split="val", motion="keypoints2d", view=3, load_audio=False)
    clip = ds[0]
    assert clip.motion.shape == (120, 17, 2) and clip.meta["confidence"].shape == (120, 17)
    windowed = build("aistpp", aist_root, split="val", window_seconds=1.0, window_offset_seconds=0.5)[0]
    assert windowed.motion.shape[0] == 60 and windowed.meta["smpl_poses"].shape == (60, 72)
    assert len(windowed.audio) == windowed.sample_rate  # 1 s at the loader's 16 kHz default
    half = build(
        "aistpp", aist_root, split="val", target_fps=30.0, window_seconds=1.0, window_offset_seconds=0.5
    )[0]
    assert half.fps == 30.0 and half.motion.shape == (30, 17, 3) and half.meta["smpl_poses"].shape == (30, 72)
    np.testing.assert_array_equal(half.motion, windowed.motion[::2])  # every other frame of the 60 fps window
    too_long = build("aistpp", aist_root, split="val", window_seconds=5.0, load_audio=False)
    with pytest.raises(DataFileError, match=r"keypoints3d/gJB_.*\.pkl: .*shorter than the requested window"):
        too_long[0]


def test_aistpp_bad_options_and_layout(aist_root: Path, tmp_path: Path) -> None:
    with pytest.raises(ValueError, match="split must be one of"):
        build("aistpp", aist_root, split="dev")
    with pytest.raises(ValueError, match="motion must be one of"):
        build("aistpp", aist_root, motion="smpl")
    with pytest.raises(ValueError, match="'root' is required"):
        DATASETS.build("aistpp", {})
    with pytest.raises(FileNotFoundError, match="keypoints3d does not exist"):
        build("aistpp", tmp_path)
    (tmp_path / "keypoints3d").mkdir()
    with pytest.raises(MissingDataFileError, match="crossmodal_test.txt: split file"):
        build("aistpp", tmp_path, split="test")
    with pytest.raises(IndexError, match="out of range"):
        build("aistpp", aist_root, split="val")[5]
    with pytest.raises(ValueError, match="sample_rate must be positive"):
        build("aistpp", aist_root, sample_rate=0)
    with pytest.raises(ValueError, match="window_seconds must be positive"):
        build("aistpp", aist_root, window_seconds=-1.0)


def test_datasets_pickle_for_dataloader_workers(aist_root: Path) -> None:
    ds = build("aistpp", aist_root, split="train", load_audio=False)
    copy = pickle.loads(pickle.dumps(ds))
    assert copy.ids == ds.ids
    np.testing.assert_array_equal(copy[1].motion, ds[1].motion)


# ------------------------------------------------------------------------------ Dance with Melody
def test_dance_with_melody_clip(tmp_path: Path) -> None:
    layouts.write_dance_with_melody(tmp_path)
    ds = build("dance_with_melody", tmp_path, sample_rate=None)
    assert ds.ids == ["DANCE_C_1", "DANCE_W_2"]
    clip = ds[1]
    assert clip.motion.shape == (75, 21, 3) and clip.skeleton == "dwm21" and clip.fps == 25.0
    assert clip.style == "waltz" and clip.trajectory is not None and clip.trajectory.shape == (75, 3)
    assert clip.meta["start_position"] == 25 and clip.meta["length_mismatch_frames"] == 3
    assert clip.meta["audio_offset_seconds"] == pytest.approx(1.0)
    assert abs(len(clip.audio) / clip.sample_rate - 3.0) < 0.05
    assert clip.meta["interpolated_keypoints"] == 3 and np.isfinite(clip.motion).all()
    import json

    raw = np.asarray(json.loads((tmp_path / "DANCE_C_1" / "skeletons.json").read_text())["skeletons"])
    full = build("dance_with_melody", tmp_path, joints=23, load_audio=False)[0]
    assert full.skeleton == "dwm23" and full.motion.shape == (75, 23, 3)
    np.testing.assert_allclose(full.motion, raw * 0.01, rtol=1e-5, atol=1e-6)
    with pytest.raises(ValueError, match="joints must be 21 or 23"):
        build("dance_with_melody", tmp_path, joints=22)


# -------------------------------------------------------------------------------------------- LORIS
def test_loris_lists_fps_and_confidence(tmp_path: Path) -> None:
    layouts.write_loris(tmp_path)
    train = build("loris", tmp_path, split="train", sample_rate=None)
    assert train.ids == layouts.LORIS_GOOD["train"]
    clip = train[0]
    assert clip.motion.shape == (200, 17, 2) and clip.fps == pytest.approx(8.0) and clip.skeleton == "coco17"
    assert clip.meta["interpolated_keypoints"] == 4 and clip.style == "gBR"
    assert len(clip.audio) == 25 * layouts.AUDIO_SR
    assert build("loris", tmp_path, split="test", load_audio=False).ids == layouts.LORIS_GOOD["test"]
    with pytest.raises(ValueError, match="train and test lists only"):
        build("loris", tmp_path, split="val")
    hashed = build("loris", tmp_path, split="all", use_lists=False, load_audio=False)
    assert sorted(hashed.ids) == sorted(sum(layouts.LORIS_GOOD.values(), []))
    assert build("loris", tmp_path, fps=10.0, load_audio=False, length_tolerance_seconds=6.0)[0].fps == 10.0
    with pytest.raises(DataFileError, match="motion lasts 20.00 s"):
        build("loris", tmp_path, fps=10.0, load_audio=False)[0]
    with pytest.raises(FileNotFoundError, match="fe/pose2d_s50 does not exist"):
        build("loris", tmp_path, subset="floor_exercise", seconds=50)
    with pytest.raises(ValueError, match="dance: 25 only"):
        build("loris", tmp_path, seconds=50)


def test_loris_mismatched_lists_name_the_list(tmp_path: Path) -> None:
    layouts.write_loris(tmp_path)
    audio_list = tmp_path / "dance" / "dance_audio_s25_train_segment.txt"
    audio_list.write_text(audio_list.read_text().replace("gPO_sFM", "gXX_sFM"))
    with pytest.raises(DataFileError, match="dance_audio_s25_train_segment.txt: names different segments"):
        build("loris", tmp_path, split="train")


# ---------------------------------------------------------------------------------------------- D2M
def test_d2m_units_sequences_audio_features_and_stats(tmp_path: Path) -> None:
    layouts.write_d2m(tmp_path)
    ds = build("d2m", tmp_path)
    assert len(ds) == 9 and {c for c in ds.ids if "unitseq3" in c} == {
        f"{s}/vid{i}/0001/unitseq3/0" for i, s in enumerate(("ballet", "hiphop", "zumba"))
    }
    unit = ds[ds.ids.index("hiphop/vid1/0001/unit/1")]
    assert unit.motion.shape == (32, 14, 2) and unit.fps == 15.0 and unit.skeleton == "openpose14"
    assert unit.style == "hiphop" and unit.audio is None and unit.meta["audio_features"].shape == (150, 28)
    np.testing.assert_allclose(unit.motion, np.load(tmp_path / "hiphop/vid1/0001/unit/1.npy"))
    seq = ds[ds.ids.index("zumba/vid2/0001/unitseq3/0")]
    assert seq.motion.shape == (96, 14, 2) and seq.meta["num_units"] == 3
    assert set(ds.stats) == {"pose_mean", "pose_std", "audio_mean", "audio_std"}
    assert len(build("d2m", tmp_path, styles=["ballet"])) == 3
    assert len(build("d2m", tmp_path, unit_glob="unit")) == 6
    splits = {c.meta["split"] for c in (ds[i] for i in range(len(ds))) if c.meta["video"] == "vid0"}
    assert len(splits) == 1  # a video's units share one split
    with pytest.raises(ValueError, match="unknown styles"):
        build("d2m", tmp_path, styles=["tango"])


# ----------------------------------------------------------------------------------------- Ballroom
def test_ballroom_music_only_clips_with_beats(tmp_path: Path) -> None:
    layouts.write_ballroom(tmp_path)
    ds = build("ballroom", tmp_path, beats_dir="beats", sample_rate=None)
    assert ds.ids == [
        "ChaChaCha/Albums-Cafe_Paradiso-05",
        "ChaChaCha/Albums-Cafe_Paradiso-06",
        "Waltz/Media-105901",
    ]
    clip = ds[2]
    assert clip.motion is None and clip.style == "Waltz" and clip.duration == pytest.approx(2.0)
    np.testing.assert_allclose(clip.meta["beat_times"], [0.0, 0.5, 1.0, 1.5])
    np.testing.assert_array_equal(clip.meta["beat_positions"], [1, 2, 3, 4])
    assert build("ballroom", tmp_path, genres=["Waltz"]).ids == ["Waltz/Media-105901"]
    with pytest.raises(FileNotFoundError, match=r"genre folder\(s\) \['Samba'\] not found"):
        build("ballroom", tmp_path, genres=["Samba"])
    windowed = build("ballroom", tmp_path, beats_dir="beats", window_seconds=1.0, window_offset_seconds=0.75)[
        0
    ]
    np.testing.assert_allclose(windowed.meta["beat_times"], [0.25, 0.75])


# ---------------------------------------------------------------------------------------- HumanML3D
def test_humanml3d_splits_texts_and_mirrors(tmp_path: Path) -> None:
    layouts.write_humanml3d(tmp_path)
    train = build("humanml3d", tmp_path)
    assert train.ids == ["000001", "M000001"]
    clip = train[0]
    assert clip.motion.shape == (40, 22, 3) and clip.fps == 20.0 and clip.skeleton == "humanml22"
    assert clip.text == ["a person walks forward.", "someone steps ahead then stops."]
    assert clip.meta["text_segments"][1]["start"] == 0.5 and clip.meta["text_segments"][0]["start"] is None
    assert train[1].meta["mirrored"] is True
    assert build("humanml3d", tmp_path, include_mirrored=False).ids == ["000001"]
    test = build("humanml3d", tmp_path, split="test")[0]
    assert test.meta["text_segments"][0]["end"] is None and test.num_frames == 47
    with pytest.raises(MissingDataFileError, match="new_joint_vecs/000001.npy"):
        build("humanml3d", tmp_path, load_features=True)[0]
    assert parse_text_line("a b.#a/DET#1.0#2.0") == {
        "caption": "a b.",
        "tokens": ["a/DET"],
        "start": 1.0,
        "end": 2.0,
    }
    with pytest.raises(ValueError, match="end 1.0 before start 2.0"):
        parse_text_line("x#y#2.0#1.0")
