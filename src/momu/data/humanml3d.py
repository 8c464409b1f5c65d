"""HumanML3D (Guo et al., CVPR 2022; MoFusion's text-to-motion data); registered as ``humanml3d``.

Motion only, with text. Layout under ``root`` (the output of HumanML3D's processing scripts)::

    new_joints/<id>.npy        (T, 22, 3) joint positions, metres, Y up, 20 fps (skeleton ``humanml22``)
    new_joint_vecs/<id>.npy    (T - 1, 263) the redundant motion features (optional, ``load_features``)
    texts/<id>.txt             one description per line: ``caption#tokens#start#end``
    train.txt val.txt test.txt all.txt    ids, one per line

``tokens`` are space-separated ``word/POS`` pairs; ``start``/``end`` (seconds) give the part of
the motion a caption describes, with ``0.0``/``0.0`` or ``nan`` meaning the whole motion.
``Clip.text`` holds the captions; ``meta["text_segments"]`` the parsed lines. Ids starting with
``M`` are HumanML3D's mirrored copies (``include_mirrored``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from momu.data.common import (
    DataFileError,
    ItemRef,
    LazyClipDataset,
    LoaderConfig,
    MissingDataFileError,
    check_split,
    clean_keypoints,
    load_npy,
    read_lines,
    require_root,
    skeleton_shape,
)
from momu.data.types import Clip
from momu.registry import DATASETS

__all__ = ["HumanML3DConfig", "HumanML3DDataset", "parse_text_line"]


@dataclass
class HumanML3DConfig(LoaderConfig):
    """Options of the ``humanml3d`` loader (``load_audio`` / ``sample_rate`` are unused: no audio).

    Attributes:
        fps: motion frame rate (20).
        include_mirrored: keep the ``M``-prefixed mirrored copies.
        require_text: a missing or empty ``texts/<id>.txt`` is an error (else the clip has no text).
        load_features: put ``new_joint_vecs/<id>.npy`` in ``meta["features"]``.
        max_gap: longest run of missing frames that is interpolated (frames).
    """

    split: str = "train"
    fps: float = 20.0
    include_mirrored: bool = True
    require_text: bool = True
    load_features: bool = False
    max_gap: int | None = 10


def _seconds(value: str) -> float | None:
    v = float(value)
    return None if math.isnan(v) else v


def parse_text_line(line: str) -> dict[str, Any]:
    """One HumanML3D description line as ``{caption, tokens, start, end}`` (``None``: whole motion).

    >>> parse_text_line("a man walks.#a/DET man/NOUN walk/VERB#0.0#0.0")["tokens"]
    ['a/DET', 'man/NOUN', 'walk/VERB']

    Raises:
        ValueError: fewer than two ``#``-fields, or unparsable start/end.
    """
    fields = line.split("#")
    if len(fields) < 2 or not fields[0].strip():
        raise ValueError(f"expected 'caption#tokens#start#end', got {line!r}")
    start = _seconds(fields[2]) if len(fields) > 2 and fields[2].strip() else None
    end = _seconds(fields[3]) if len(fields) > 3 and fields[3].strip() else None
    if start == 0.0 and end == 0.0:
        start = end = None
    if start is not None and end is not None and end < start:
        raise ValueError(f"end {end} before start {start} in {line!r}")
    return {"caption": fields[0].strip(), "tokens": fields[1].split(), "start": start, "end": end}


class HumanML3DDataset(LazyClipDataset):
    """HumanML3D motions with their descriptions (see the module docstring)."""

    name = "humanml3d"

    def __init__(self, cfg: HumanML3DConfig) -> None:
        root = require_root(cfg.root, self.name, "HumanML3D new_joints/, texts/ and split files")
        check_split(cfg.split, self.name)
        if cfg.fps <= 0:
            raise ValueError(f"{self.name}: fps must be positive, got {cfg.fps}")
        self.joints_dir = root / "new_joints"
        if not self.joints_dir.is_dir():
            raise FileNotFoundError(f"{self.name}: {self.joints_dir} does not exist")
        split_file = root / f"{cfg.split}.txt"
        if split_file.is_file():
            ids = read_lines(split_file)
        elif cfg.split == "all":
            ids = sorted(p.stem for p in self.joints_dir.glob("*.npy"))
        else:
            raise MissingDataFileError(split_file, f"split file for split={cfg.split!r} not found")
        split_of: dict[str, str] = {}
        for split in ("train", "val", "test"):
            if (root / f"{split}.txt").is_file():
                split_of.update((i, split) for i in read_lines(root / f"{split}.txt") if i not in split_of)
        refs = [
            ItemRef(i, self.joints_dir / f"{i}.npy", {"split": split_of.get(i, "none")})
            for i in dict.fromkeys(ids)
            if cfg.include_mirrored or not i.startswith("M")
        ]
        super().__init__(cfg, root, refs)
        self.cfg: HumanML3DConfig = cfg

    def _texts(self, item_id: str) -> list[dict[str, Any]]:
        path = self.root / "texts" / f"{item_id}.txt"
        if not path.is_file():
            if self.cfg.require_text:
                raise MissingDataFileError(path, "text file not found")
            return []
        segments = []
        for number, line in enumerate(read_lines(path), start=1):
            try:
                segments.append(parse_text_line(line))
            except ValueError as exc:
                raise DataFileError(path, f"line {number}: {exc}") from None
        if not segments and self.cfg.require_text:
            raise DataFileError(path, "no descriptions")
        return segments

    def load(self, ref: ItemRef) -> Clip:
        cfg = self.cfg
        joints, dims = skeleton_shape("humanml22")
        motion, filled = clean_keypoints(
            load_npy(ref.path), ref.path, joints=joints, dims=dims, max_gap=cfg.max_gap
        )
        segments = self._texts(ref.id)
        meta: dict[str, Any] = {
            "split": ref.extra["split"],
            "source": str(ref.path),
            "text_segments": segments,
            "mirrored": ref.id.startswith("M"),
            "interpolated_keypoints": filled,
        }
        if cfg.load_features:
            path = self.root / "new_joint_vecs" / f"{ref.id}.npy"
            feats = load_npy(path).astype(np.float32)
            if feats.ndim != 2 or abs(feats.shape[0] - motion.shape[0]) > 1:
                raise DataFileError(
                    path, f"expected ({motion.shape[0] - 1}, F) features, got shape {feats.shape}"
                )
            if not np.all(np.isfinite(feats)):
                raise DataFileError(path, "non-finite feature values")
            meta["features"] = feats
        return Clip(
            id=ref.id,
            motion=motion,
            fps=float(cfg.fps),
            skeleton="humanml22",
            text=[s["caption"] for s in segments],
            meta=meta,
        )


@DATASETS.register("humanml3d", config=HumanML3DConfig)
def build_humanml3d(cfg: HumanML3DConfig, **_: Any) -> HumanML3DDataset:
    """HumanML3D from ``cfg.root`` (see :mod:`momu.data.humanml3d`)."""
    return HumanML3DDataset(cfg)
