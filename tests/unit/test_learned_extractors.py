"""Training, saving and loading the learned-metric extractors (MoMu App. B.5 motion classifier, audio CNN)."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
import torch

from momu.data.synth import SynthConfig, SynthDance
from momu.data.types import Clip
from momu.encoders.dstformer import DSTformerConfig
from momu.metrics.extractors import (
    AudioClassifierConfig,
    AudioClassifierEmbedding,
    MotionClassifierConfig,
    MotionExtractor,
    TrainConfig,
    audio_segments,
    file_sha256,
    load_extractor,
    motion_windows,
    prepare_motion,
    train_extractor,
)

STYLES = ["ballet", "hiphop", "zumba"]
TINY_MOTION = MotionClassifierConfig(
    fps=15.0, window=30, hidden=32, dstformer=DSTformerConfig(dim_feat=16, dim_rep=8, depth=1, num_heads=2)
)


def _synth(split: str, n: int = 36) -> list[Clip]:
    cfg = SynthConfig(
        num_clips=n, min_seconds=3.0, max_seconds=3.0, skeleton="openpose14", fps=15.0, styles=STYLES
    )
    ds = SynthDance(cfg, split=split)
    return [ds[i] for i in range(len(ds))]


@pytest.fixture(scope="module")
def synth_train() -> list[Clip]:
    return _synth("train")


@pytest.fixture(scope="module")
def synth_heldout() -> list[Clip]:
    return _synth("val") + _synth("test")


@pytest.fixture(scope="module")
def motion_model(
    synth_train: list[Clip], tmp_path_factory: pytest.TempPathFactory
) -> tuple[MotionExtractor, dict, Path]:
    out = tmp_path_factory.mktemp("motion") / "motion.safetensors"
    ext, summary = train_extractor(
        "motion", synth_train, out, model_config=TINY_MOTION, train=TrainConfig(epochs=8, val_fraction=0.0)
    )
    assert isinstance(ext, MotionExtractor)
    return ext, summary, out


def test_motion_classifier_training_reduces_loss_and_separates_styles(
    motion_model: tuple[MotionExtractor, dict, Path], synth_heldout: list[Clip]
) -> None:
    ext, summary, _ = motion_model
    losses = summary["loss_history"]
    assert len(losses) == 8
    assert losses[-1] < 0.8 * losses[0]
    assert summary["class_names"] == STYLES
    predicted = ext.predict(synth_heldout)
    accuracy = np.mean([p == c.style for p, c in zip(predicted, synth_heldout)])
    assert accuracy >= 0.6, f"held-out accuracy {accuracy:.2f} (chance 0.33)"


def test_saved_motion_extractor_round_trips_strictly(
    motion_model: tuple[MotionExtractor, dict, Path], synth_heldout: list[Clip], tmp_path: Path
) -> None:
    ext, _, path = motion_model
    meta = json.loads(path.with_suffix(".json").read_text())
    assert meta["kind"] == "motion_classifier" and meta["sha256"] == file_sha256(path)
    assert meta["config"]["dstformer"]["num_joints"] == 14 and meta["config"]["class_names"] == STYLES
    loaded = load_extractor(path)
    assert isinstance(loaded, MotionExtractor) and loaded.sha256 == ext.sha256 == file_sha256(path)
    clips = synth_heldout[:3]
    np.testing.assert_array_equal(loaded.clip_features(clips), ext.clip_features(clips))
    assert loaded.clip_features(clips).shape == (3, 14 * 8)
    probs = loaded.clip_probabilities(clips)
    np.testing.assert_allclose(probs.sum(axis=1), 1.0, rtol=1e-6)

    # a config that does not fit the weights is refused (strict loading)
    bad = tmp_path / "bad.safetensors"
    bad.write_bytes(path.read_bytes())
    meta["config"]["dstformer"]["dim_rep"] = 4
    bad.with_suffix(".json").write_text(json.dumps(meta))
    with pytest.raises(ValueError, match="do not fit"):
        load_extractor(bad)
    bad.with_suffix(".json").unlink()
    with pytest.raises(FileNotFoundError, match="config not found"):
        load_extractor(bad)


def test_motion_extractor_checks_the_skeleton(motion_model: tuple[MotionExtractor, dict, Path]) -> None:
    ext, _, _ = motion_model
    with pytest.raises(ValueError, match=r"'smpl'.*\(T, 14, 2\)"):
        ext.clip_features([Clip("smpl", np.zeros((30, 24, 3), np.float32), 30.0)])
    with pytest.raises(ValueError, match="NaN"):
        ext.clip_features([Clip("nan", np.full((30, 14, 2), np.nan, np.float32), 30.0)])


def test_prepare_motion_resamples_and_scales() -> None:
    cfg = MotionClassifierConfig(fps=15.0, dstformer=DSTformerConfig(num_joints=2, dim_in=2))
    motion = np.zeros((5, 2, 2))
    motion[:, 1, 0] = 2.0  # joints 2 apart -> each 1 from the centroid -> scale 1... times frame offset
    motion[:, :, 1] = np.arange(5)[:, None] * 10.0
    out = prepare_motion(motion, 30.0, cfg)
    # 5 frames at 30 fps = frames 0, 2, 4 at 15 fps; body scale 1 (mean joint distance to centroid)
    np.testing.assert_allclose(out[:, 0, 1], [0.0, 20.0, 40.0])
    np.testing.assert_allclose(out[:, 1, 0], 2.0)
    with pytest.raises(ValueError, match="coincide"):
        prepare_motion(np.ones((4, 2, 2)), 15.0, cfg)


def test_motion_windows_translate_and_mask() -> None:
    x = np.arange(5 * 2 * 2, dtype=np.float32).reshape(5, 2, 2)
    windows, mask = motion_windows(x, 2)
    assert windows.shape == (3, 2, 2, 2)
    assert mask.tolist() == [[True, True], [True, True], [True, False]]
    np.testing.assert_allclose(windows[:, 0].mean(axis=1), 0.0)  # first frame's centroid at the origin
    np.testing.assert_allclose(windows[1, 1], x[3] - x[2].mean(axis=0))
    assert np.all(windows[2, 1] == 0)


def test_audio_classifier_learns_styles(
    synth_train: list[Clip], synth_heldout: list[Clip], tmp_path: Path
) -> None:
    cfg = AudioClassifierConfig(segment_frames=60, channels=[8, 16, 16], embed_dim=16)
    out = tmp_path / "audio.safetensors"
    emb, summary = train_extractor(
        "audio", synth_train, out, model_config=cfg, train=TrainConfig(epochs=6, val_fraction=0.0)
    )
    assert isinstance(emb, AudioClassifierEmbedding)
    assert summary["loss_history"][-1] < 0.8 * summary["loss_history"][0]
    loaded = load_extractor(out)
    assert isinstance(loaded, AudioClassifierEmbedding) and loaded.sha256 == file_sha256(out)
    correct = []
    with torch.no_grad():
        for clip in synth_heldout:
            segs = torch.from_numpy(audio_segments(clip.audio, clip.sample_rate, loaded.cfg))
            correct.append(loaded.cfg.class_names[int(loaded.model(segs).mean(0).argmax())] == clip.style)
    assert np.mean(correct) >= 0.6
    np.testing.assert_array_equal(
        loaded.frame_embeddings(synth_heldout[0]), emb.frame_embeddings(synth_heldout[0])
    )
    assert loaded.frame_embeddings(synth_heldout[0]).shape == (3, 16)  # 3 s -> three 0.96 s segments


def test_training_needs_two_labelled_styles() -> None:
    clips = [
        Clip(f"c{i}", np.random.default_rng(i).normal(size=(20, 14, 2)), 15.0, style="solo") for i in range(3)
    ]
    with pytest.raises(ValueError, match="at least 2 styles"):
        train_extractor("motion", clips)
    with pytest.raises(ValueError, match="kind"):
        train_extractor("video", clips)


def test_trained_features_tell_real_from_frozen_motion(
    motion_model: tuple[MotionExtractor, dict, Path], synth_train: list[Clip], synth_heldout: list[Clip]
) -> None:
    """fid_learned / mean_kld on trained features: held-out real dances are closer to the training set
    than the same dances frozen on their first pose (a calibration a reader of Table 6 relies on)."""
    from momu.registry import METRICS

    ext, _, _ = motion_model
    frozen = [
        Clip(c.id, np.repeat(c.motion[:1], len(c.motion), axis=0), c.fps, style=c.style)
        for c in synth_heldout
    ]
    fid = METRICS.build("fid_learned", extractor=ext)
    assert fid(synth_heldout, synth_train)["fid_learned"] < fid(frozen, synth_train)["fid_learned"]
    kld = METRICS.build("mean_kld", extractor=ext)
    assert kld(synth_heldout, synth_heldout)["mean_kld"] == 0.0
    assert kld(frozen, synth_heldout)["mean_kld"] > 0.05
