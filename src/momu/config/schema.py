"""The schema of a recipe config: every top-level key a recipe YAML may hold, in one place.

``recipes/configs/*.yaml`` and everything ``momu config show`` prints are checked against
:class:`RecipeConfig`: a key that is neither one of its fields nor a component node (a key naming a
registry kind — ``dataset``, ``method``, ``backbone`` …, validated by its part's dataclass) is an
error naming the key and the valid ones. Adding a top-level key is one field here.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Optional

from momu.engine.trainer import TrainConfig

__all__ = [
    "RecipeConfig",
    "RealDataConfig",
    "SubsetConfig",
    "LengthsConfig",
    "DanceDataConfig",
    "BallroomConfig",
    "FollowingConfig",
]


@dataclass
class RealDataConfig:
    """``real_data``: where Tables 2–6 read their real datasets (``--data DIR`` sets ``root``)."""

    root: Optional[str] = None  # noqa: UP045 - OmegaConf structured configs need typing.Optional


@dataclass
class SubsetConfig:
    """``subsets.<id>`` of ``recipes/configs/momu_tables.yaml``: one column group of Tables 2–6.

    Attributes:
        synth_dataset: the synthetic stand-in (``--data synth``).
        real_dataset: the real loader, its ``root`` relative to ``real_data.root``.
        real_joints: ``[joints, dims]`` of the real data's keypoints.
        seconds: clip, window and evaluation length of this subset (Tables 3–4).
    """

    synth_dataset: Any = None
    real_dataset: Any = None
    real_joints: Optional[list[int]] = None  # noqa: UP045
    seconds: Optional[float] = None  # noqa: UP045


@dataclass
class LengthsConfig:
    """``lengths``: MoFusion's two generation lengths in seconds (Table 1 and supp. Tables 1–2)."""

    short: float = 10.0
    long: float = 20.0


@dataclass
class DanceDataConfig:
    """``dance``: HarmoGAN's training and test dances (``--data DIR`` sets ``root``).

    Attributes:
        root: the real Dance with Melody folder; ``None`` reads ``synth_dataset``.
        real_dataset, synth_dataset: the two dataset nodes.
    """

    root: Optional[str] = None  # noqa: UP045
    real_dataset: Any = None
    synth_dataset: Any = None


@dataclass
class BallroomConfig:
    """``ballroom``: the Ballroom test music of HarmoGAN Tables I–II (§V-A: ``fraction`` of each genre)."""

    root: Optional[str] = None  # noqa: UP045
    dataset: Any = None
    fraction: float = 0.1
    seed: int = 0


@dataclass
class FollowingConfig:
    """``following``: the music-following benchmark a table scores its rows with (``recipes/mixing.py``;
    docs/following.md).

    Attributes:
        split: the dataset split the songs come from.
        songs: the first ``songs`` clips of ``split`` (by id).
        seconds: excerpt length (s); excerpts start 2 s in when the clip is long enough.
        generation_seeds: the seeds every song is answered with (input sensitivity needs 2).
        factors: tempo factors of the stretched inputs (tempo following).
    """

    split: str = "val"
    songs: int = 12
    seconds: float = 5.0
    generation_seeds: list[int] = field(default_factory=lambda: [0, 1])
    factors: list[float] = field(default_factory=lambda: [0.8, 0.9, 1.1, 1.25])


@dataclass
class RecipeConfig:
    """Top-level keys of a recipe config (``recipes/configs/momu.yaml``, ``momu_tables.yaml``).

    Attributes:
        seed: the base seed of every row (``--seeds`` overrides it).
        mixed_precision: ``no``, ``fp16`` or ``bf16``.
        dataset: the dataset node (``{name: synth_dance, ...}``).
        method: the method node (``{name: momu, ...}``), validated by the method's dataclass.
        real_data, subsets: Tables 2–6 (:class:`RealDataConfig`, :class:`SubsetConfig`).
        learnable_encoder, learnable_train, learnable_frames_per_latent: Tables 3–4's learnable
            motion encoder, its training stage and the motion frames it sees per latent frame.
        lengths: MoFusion's generation lengths (:class:`LengthsConfig`).
        dance, ballroom: HarmoGAN's data (:class:`DanceDataConfig`, :class:`BallroomConfig`).
        calibration_row, fig11_perturbations: set by HarmoGAN's calibration rows and Fig. 11's rows
            (:mod:`momu.methods.harmogan.evaluate`).
        following: the music-following benchmark of the mixing table (:class:`FollowingConfig`).
    """

    seed: int = 0
    mixed_precision: str = "no"
    dataset: Any = None
    method: Any = None
    real_data: RealDataConfig = field(default_factory=RealDataConfig)
    subsets: dict[str, SubsetConfig] = field(default_factory=dict)
    learnable_encoder: Any = None
    learnable_train: Optional[TrainConfig] = None  # noqa: UP045
    learnable_frames_per_latent: int = 1
    lengths: Optional[LengthsConfig] = None  # noqa: UP045
    dance: Optional[DanceDataConfig] = None  # noqa: UP045
    ballroom: Optional[BallroomConfig] = None  # noqa: UP045
    calibration_row: Optional[str] = None  # noqa: UP045
    fig11_perturbations: Any = None
    following: Optional[FollowingConfig] = None  # noqa: UP045
