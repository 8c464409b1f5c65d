"""A HarmoGAN run's data from its config, cached on disk: the dances and their meter units.

The table configs hold a ``dance`` node::

    dance:
      root: null            # --data DIR: a Dance with Melody root; null: the synth_dance stand-in
      real_dataset: {name: dance_with_melody, ...}
      synth_dataset: {name: synth_dance, skeleton: dwm21, root_centred: true, ...}

With ``root`` set the real loader reads it with ``target_fps`` = the method's 15 fps (linear
interpolation from 25 fps); otherwise ``synth_dance`` generates its clips at 15 fps. Decoding eight
MP3s and detecting the onsets of ~600 meter units takes tens of seconds on a shared CPU and every row
and seed of a table needs the same data, so :func:`load_dances` and :func:`load_units` keep them in a
:class:`~momu.features.cache.FeatureCache` keyed by the data config, the method's data settings and the
source files' identities (size and modification time).
"""

from __future__ import annotations

import dataclasses
from pathlib import Path
from typing import Any

import numpy as np
from omegaconf import DictConfig

from momu.config import build_component, to_container
from momu.features.cache import FeatureCache, file_identity
from momu.methods.harmogan.config import HarmoGANConfig, plain_node
from momu.methods.harmogan.data import Dance, MfccStats, meter_unit_arrays, mfcc_stats, prepare_dances

__all__ = ["dataset_node", "data_key", "load_dances", "load_units"]


def dataset_node(cfg: DictConfig | dict[str, Any], fps: float) -> dict[str, Any]:
    """The dataset node a run reads: the real loader at ``dance.root`` (at ``fps``) or the synthetic one."""
    dance = to_container(cfg["dance"]) if not isinstance(cfg["dance"], dict) else dict(cfg["dance"])
    root = dance.get("root")
    if root:
        if not Path(str(root)).is_dir():
            raise FileNotFoundError(f"dance.root: dataset folder {root} not found")
        node = plain_node(dance["real_dataset"])
        node.update(root=str(Path(str(root)).resolve()), target_fps=float(fps))
        return node
    node = plain_node(dance["synth_dataset"])
    node["fps"] = float(fps)
    return node


def data_key(cfg: DictConfig | dict[str, Any], method: HarmoGANConfig) -> dict[str, Any]:
    """What determines the dances: the dataset node and the method's frame rate, split and A_f."""
    return {
        "dataset": dataset_node(cfg, method.fps),
        "fps": method.fps,
        "test_fraction": method.test_fraction,
        "mfcc": dataclasses.asdict(method.mfcc),
    }


def _source(node: dict[str, Any]) -> Any:
    root = node.get("root")
    if not root:
        return "generated"
    files = sorted(p for p in Path(str(root)).rglob("*") if p.is_file())
    return [file_identity(p) for p in files]


def _to_arrays(dances: list[Dance]) -> dict[str, np.ndarray]:
    out: dict[str, np.ndarray] = {
        "ids": np.asarray([d.id for d in dances]),
        "styles": np.asarray([d.style or "" for d in dances]),
        "split_frames": np.asarray([d.split_frame for d in dances], np.int64),
        "sample_rates": np.asarray([d.sample_rate for d in dances], np.int64),
        "fps": np.asarray([d.fps for d in dances], np.float64),
    }
    for i, d in enumerate(dances):
        out[f"motion_{i}"], out[f"audio_{i}"], out[f"mfcc_{i}"] = d.motion, d.audio, d.mfcc
    return out


def _from_arrays(arrays: dict[str, np.ndarray]) -> list[Dance]:
    return [
        Dance(
            id=str(arrays["ids"][i]),
            style=str(arrays["styles"][i]) or None,
            motion=arrays[f"motion_{i}"],
            audio=arrays[f"audio_{i}"],
            sample_rate=int(arrays["sample_rates"][i]),
            fps=float(arrays["fps"][i]),
            mfcc=arrays[f"mfcc_{i}"],
            split_frame=int(arrays["split_frames"][i]),
        )
        for i in range(len(arrays["ids"]))
    ]


def load_dances(
    cfg: DictConfig | dict[str, Any], method: HarmoGANConfig, cache: FeatureCache
) -> tuple[list[Dance], dict[str, Any]]:
    """The run's dances and their :func:`data_key` (from the cache when present)."""
    key = data_key(cfg, method)

    def compute() -> dict[str, np.ndarray]:
        dataset = build_component(key["dataset"], "datasets")
        return _to_arrays(prepare_dances(dataset, method.fps, method.test_fraction, method.mfcc))

    arrays = cache.get_or_compute("harmogan_dances", key, _source(key["dataset"]), compute)
    assert isinstance(arrays, dict)
    return _from_arrays(arrays), key


def load_units(
    dances: list[Dance], key: dict[str, Any], method: HarmoGANConfig, cache: FeatureCache
) -> tuple[dict[str, np.ndarray], MfccStats]:
    """The meter units of the training parts (:func:`~momu.methods.harmogan.data.meter_unit_arrays`)
    and the A_f statistics they are standardised with (from the cache when present)."""
    stats = mfcc_stats(dances)
    harmony = plain_node(method.harmony_loss)
    lambda1 = float(harmony.get("lambda1", 0.1))
    normalize = bool(harmony.get("normalize_saliency", True))
    config = {
        "data": key,
        "meter": dataclasses.asdict(method.meter),
        "lambda1": lambda1,
        "normalize": normalize,
    }

    def compute() -> dict[str, np.ndarray]:
        return meter_unit_arrays(dances, method.meter, stats, lambda1=lambda1, normalize_saliency=normalize)

    arrays = cache.get_or_compute("harmogan_units", config, _source(key["dataset"]), compute)
    assert isinstance(arrays, dict)
    return arrays, stats
