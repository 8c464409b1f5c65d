"""``synth_dance``: the built-in procedural dataset of paired music and dance (issue 3 §1).

Public API: :class:`SynthConfig`, :class:`SynthDance` (in memory, lazy), :func:`generate_clip`,
:func:`write_dataset` / :func:`load_written` (wav + npy + manifest.json), and the registered dataset
``synth_dance`` (:class:`SynthDanceConfig` = :class:`SynthConfig` + ``split`` + ``root``).
"""

from __future__ import annotations

from dataclasses import dataclass

from momu.data.synth.dataset import (
    DEFAULT_STYLES,
    SPLITS,
    CameraConfig,
    SynthConfig,
    SynthDance,
    generate_clip,
    split_of,
    validate_config,
)
from momu.data.synth.store import WrittenSynthDance, load_written, write_dataset
from momu.data.synth.styles import STYLE_NAMES, STYLES, Style, get_style
from momu.data.types import ClipDataset
from momu.registry import DATASETS

__all__ = [
    "CameraConfig",
    "DEFAULT_STYLES",
    "SPLITS",
    "STYLES",
    "STYLE_NAMES",
    "Style",
    "SynthConfig",
    "SynthDance",
    "SynthDanceConfig",
    "WrittenSynthDance",
    "build_synth_dance",
    "generate_clip",
    "get_style",
    "load_written",
    "split_of",
    "validate_config",
    "write_dataset",
]


@dataclass
class SynthDanceConfig(SynthConfig):
    """The registered dataset's config: :class:`SynthConfig` plus

    Attributes:
        split: ``train`` / ``val`` / ``test``, or ``all`` for every clip.
        root: folder of a copy written by ``momu data synth`` / :func:`write_dataset`; when set,
            clips are read from it (the generator fields are then ignored) instead of generated.
    """

    split: str = "all"
    root: str | None = None


@DATASETS.register("synth_dance", config=SynthDanceConfig)
def build_synth_dance(cfg: SynthDanceConfig) -> ClipDataset:
    """``synth_dance`` generated in memory, or read from ``cfg.root`` when given."""
    if cfg.root:
        return load_written(cfg.root, cfg.split)
    return SynthDance(cfg, split=cfg.split)
