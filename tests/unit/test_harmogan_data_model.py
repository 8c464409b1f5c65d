"""HarmoGAN data (15 fps dances, temporal split, meter units, windows, Ballroom), perturbations and the
trained model's recurrent generation and save / load."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import soundfile as sf
import torch

from momu.features.audio import MfccConfig
from momu.methods.harmogan.ballroom import ballroom_column, ballroom_test_clips, select_tracks
from momu.methods.harmogan.config import HarmoGANConfig
from momu.methods.harmogan.data import (
    MeterUnitDataset,
    collate_units,
    eval_windows,
    meter_unit_arrays,
    mfcc_stats,
    prepare_dances,
    project_2d,
    window_clip,
)
from momu.methods.harmogan.meter import MeterConfig
from momu.methods.harmogan.model import HarmoGANModel
from momu.methods.harmogan.perturb import chunk_permuted, shifted_audio, static_pose, time_warped
from momu.registry import DATASETS, ENCODERS


@pytest.fixture(scope="module")
def dances():  # type: ignore[no-untyped-def]
    ds = DATASETS.build(
        "synth_dance",
        {
            "num_clips": 2,
            "skeleton": "dwm21",
            "fps": 15.0,
            "root_centred": True,
            "min_seconds": 20.0,
            "max_seconds": 20.0,
            "styles": ["hiphop", "ballet"],
        },
    )
    return prepare_dances(ds, 15.0, 0.3, MfccConfig())


def test_dances_split_in_time_and_features_align(dances) -> None:  # type: ignore[no-untyped-def]
    for d in dances:
        assert d.motion.shape == (300, 21, 3) and d.fps == 15.0
        assert d.frames("train") == (0, 210) and d.frames("test") == (210, 300)
        assert d.mfcc.shape == (300, 20) and len(d.audio) == 300 * d.sample_rate // 15
    assert np.array_equal(project_2d(dances[0].motion), dances[0].motion[..., :2])
    with pytest.raises(ValueError, match="fps"):
        prepare_dances(
            DATASETS.build("synth_dance", {"num_clips": 1, "skeleton": "dwm21"}), 15.0, 0.2, MfccConfig()
        )


def test_meter_units_come_from_the_training_part_only(dances) -> None:  # type: ignore[no-untyped-def]
    stats = mfcc_stats(dances)
    arrays = meter_unit_arrays(dances, MeterConfig(unit_seconds=2.0), stats)
    n = arrays["motion"].shape[0]
    assert n > 10 and arrays["motion"].shape[1:] == (30, 21, 3) and arrays["pose_2d"].shape[1:] == (30, 21, 2)
    assert arrays["mfcc"].shape == (n, 30, 20) and arrays["transition"].shape == (n, 30)
    train = np.concatenate([d.motion[: d.split_frame] for d in dances])
    flat = train.reshape(len(train), -1)
    for unit in arrays["motion"][:: max(1, n // 8)]:  # every unit frame is a training frame
        assert np.min(np.abs(flat - unit[-1].reshape(1, -1)).sum(1)) == 0.0
    ti = arrays["transition"].astype(bool)
    assert ti[:, 0].all()
    assert np.allclose(arrays["initial_poses"][0][~ti[0]][0], arrays["motion"][0][ti[0]].mean(0))  # Eq. 12
    ds = MeterUnitDataset(arrays)
    batch = collate_units([ds[0], ds[1]])
    assert batch["audio_mask"].shape == batch["audio_times"].shape and batch["audio_mask"].dtype == torch.bool
    assert int(batch["audio_mask"][0].sum()) == int(arrays["audio_count"][0])
    assert set(ds.meters) <= {"2/4", "3/4", "4/4", "6/8"}


def test_windows_and_perturbations(dances) -> None:  # type: ignore[no-untyped-def]
    windows = eval_windows(dances, "test", 3.0)
    assert [w.start for w in windows if w.dance == 0] == [210, 255]
    clip = window_clip(dances[0], windows[0])
    assert clip.num_frames == 45 and len(clip.audio) == 3 * clip.sample_rate  # type: ignore[arg-type]
    d, w = dances[0], windows[1]
    early = shifted_audio(d, w, 0.25)
    a0 = int(round(w.start * d.sample_rate / d.fps)) - d.sample_rate // 4
    assert np.array_equal(early, d.audio[a0 : a0 + 3 * d.sample_rate])
    fast = time_warped(d, w, 1.25)
    assert fast.shape == (45, 21, 3)
    assert np.allclose(fast[4], d.motion[w.start - 11 + 5])  # moved back: 1.25 x 44 frames fit before the end
    same = time_warped(d, windows[0], 1.0)
    assert np.allclose(same, d.motion[210:255])
    rng = np.random.default_rng(0)
    still = static_pose(clip.motion, 1e-4, rng)  # type: ignore[arg-type]
    assert np.abs(still - clip.motion.mean(0)).max() < 1e-3 and still.std(0).mean() == pytest.approx(
        1e-4, rel=0.2
    )  # type: ignore[union-attr]
    perm = chunk_permuted(clip.motion, 15, rng)  # type: ignore[arg-type]
    assert perm.shape == clip.motion.shape and not np.array_equal(perm[:15], clip.motion[:15])  # type: ignore[index]


def _model(dances) -> HarmoGANModel:  # type: ignore[no-untyped-def]
    cfg = HarmoGANConfig()
    gen = ENCODERS.build("harmogan_generator", {"hidden": 16, "noise_dim": 4})
    return HarmoGANModel(cfg, gen, mfcc_stats(dances), dances[0].motion.mean(0))


def test_generation_covers_music_of_any_length(dances, tmp_path: Path) -> None:  # type: ignore[no-untyped-def]
    model = _model(dances)
    sr = dances[0].sample_rate
    for seconds in (0.5, 3.0, 17.3):
        audio = np.tile(dances[0].audio, 2)[: int(seconds * sr)]
        motion = model.generate(audio, sr, seed=3)
        assert motion.shape == (int(np.floor(seconds * 15 + 1e-6)), 21, 3) and np.isfinite(motion).all()
    audio = dances[1].audio[: 4 * sr]
    a = model.generate(audio, sr, initial_pose=dances[1].motion[0], seed=1)
    assert np.array_equal(a, model.generate(audio, sr, initial_pose=dances[1].motion[0], seed=1))
    assert not np.array_equal(a, model.generate(audio, sr, initial_pose=dances[1].motion[0], seed=2))
    with pytest.raises(ValueError, match="initial_pose"):
        model.generate(audio, sr, initial_pose=np.zeros((20, 3)))
    with pytest.raises(ValueError, match="at least 2 frames"):
        model.generate(audio[:500], sr)
    model.save(tmp_path / "m")
    loaded = HarmoGANModel.load(tmp_path / "m")
    assert np.array_equal(loaded.generate(audio, sr, initial_pose=dances[1].motion[0], seed=1), a)
    assert loaded.skeleton == "dwm21" and loaded.fps == 15.0
    with pytest.raises(FileNotFoundError, match="harmogan.json"):
        HarmoGANModel.load(tmp_path)


def _ballroom(root: Path) -> Path:
    sr = 8000
    rng = np.random.default_rng(0)
    counts = {"ChaChaCha": 11, "Rumba-American": 2, "Rumba-Misc": 3, "VienneseWaltz": 4, "Waltz": 6}
    for folder, n in counts.items():
        (root / folder).mkdir(parents=True)
        for i in range(n):
            sf.write(
                str(root / folder / f"t{i}.wav"),
                0.1 * rng.standard_normal(int(13.0 * sr)).astype(np.float32),
                sr,
            )
    return root


def test_ballroom_columns_selection_and_clips(tmp_path: Path) -> None:
    assert ballroom_column("Rumba-International") == "rumba" and ballroom_column("VienneseWaltz") == "waltz"
    with pytest.raises(ValueError, match="no Table I column"):
        ballroom_column("Polka")
    root = _ballroom(tmp_path / "Ballroom")
    ds = DATASETS.build("ballroom", {"root": str(root), "sample_rate": 8000})
    chosen = select_tracks(list(ds.ids), 0.1, seed=0)
    columns = [ballroom_column(ds.ids[i].split("/")[0]) for i in chosen]
    assert columns.count("cha-cha") == 2 and columns.count("rumba") == 1 and columns.count("waltz") == 1
    assert chosen == select_tracks(list(ds.ids), 0.1, seed=0) and chosen != select_tracks(
        list(ds.ids), 0.1, seed=1
    )
    clips = ballroom_test_clips(ds, 0.1, 6.0, seed=0)
    assert len(clips) == 2 * len(chosen)  # 13-s tracks: two 6-s clips each
    assert all(len(c.audio) == 6 * 8000 and c.style in ("cha-cha", "rumba", "waltz") for c in clips)  # type: ignore[arg-type]
