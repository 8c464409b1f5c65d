"""Learned metrics on the real Dance-with-Melody subset (3D mocap, 21 joints, 25 fps, minutes-long dances).

Skipped where the subset is absent; its size is read from the folder (8 dances, then 23)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from tests.helpers.shared_data import DWM_STYLES, dance_with_melody_folders

from momu.data.types import Clip
from momu.encoders.dstformer import DSTformerConfig
from momu.metrics.extractors import MotionClassifierConfig, MotionExtractor, TrainConfig, train_extractor
from momu.registry import DATASETS, METRICS


def test_motion_classifier_and_metrics_on_real_mocap(shared_data: Path, tmp_path: Path) -> None:
    root = shared_data / "dance_with_melody"
    if not root.is_dir():
        pytest.skip(f"{root} not found")
    folders = dance_with_melody_folders(root)
    ds = DATASETS.build("dance_with_melody", {"root": str(root), "load_audio": False})
    dances = [ds[i] for i in range(len(ds))]
    styles = sorted({DWM_STYLES[f.name.split("_")[1]] for f in folders})
    assert len(styles) > 1, "the classifier needs two styles or more"
    assert sorted({c.style for c in dances}) == styles
    cfg = MotionClassifierConfig(
        fps=12.5, window=25, hidden=16, dstformer=DSTformerConfig(dim_feat=8, dim_rep=4, depth=1, num_heads=2)
    )
    out = tmp_path / "dwm.safetensors"
    ext, summary = train_extractor(
        "motion",
        dances,
        out,
        model_config=cfg,
        train=TrainConfig(epochs=1, samples_per_clip=2, val_fraction=0.0),
    )
    assert isinstance(ext, MotionExtractor)
    assert summary["class_names"] == styles
    feats = ext.clip_features(dances)  # whole dances: ~60-100 windows each
    assert feats.shape == (len(folders), 21 * 4) and np.all(np.isfinite(feats))

    halves_a = [Clip(c.id, c.motion[: len(c.motion) // 2], c.fps) for c in dances]
    halves_b = [Clip(c.id, c.motion[len(c.motion) // 2 :], c.fps) for c in dances]
    fid = METRICS.build("fid_learned", {"extractor": str(out)})
    assert abs(fid(halves_a, halves_a)["fid_learned"]) < 1e-6
    assert fid(halves_a, halves_b)["fid_learned"] > 0
    kld = METRICS.build("mean_kld", {"extractor": str(out)})(halves_a, halves_b)["mean_kld"]
    assert np.isfinite(kld) and kld >= 0
