"""Motion pre-processing: keypoint subsets, filling missing keypoints, frame dropping, normalisation.

* :func:`select_joints`, :func:`joint_indices`, :func:`openpose14_from_body25`,
  :func:`openpose14_from_coco17` — keypoint subsets (MoMu App. B.2 keeps 14 of OpenPose's BODY-25).
* :func:`confidence_mask` and :func:`interpolate_missing` — missing keypoints (NaN, or confidence at or
  below a threshold) filled from neighbouring frames (MoMu App. B.2: "We interpolate the missing detected
  keypoints from the neighboring frames"): linear between the nearest observed frames, held constant
  before the first / after the last observation.
* :func:`drop_frames_evenly` — MoMu §3.2: evenly drop motion frames so the motion has as many frames
  as the music (``T_zm = T_za``).
* :class:`Normalizer` — per-channel mean/std statistics, fitted on training data, saved as JSON or
  npz (never pickle), applied to numpy arrays or torch tensors.
"""

from __future__ import annotations

import json
import math
from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any, TypeVar

import numpy as np
import torch

from momu.io import atomic_path, write_json

__all__ = [
    "BODY25_JOINT_NAMES",
    "MissingKeypointsError",
    "joint_indices",
    "select_joints",
    "openpose14_from_body25",
    "openpose14_from_coco17",
    "confidence_mask",
    "interpolate_missing",
    "even_frame_indices",
    "drop_frames_evenly",
    "Normalizer",
]

Array = TypeVar("Array", np.ndarray, torch.Tensor)

#: OpenPose BODY-25 keypoint order.
BODY25_JOINT_NAMES: tuple[str, ...] = (
    "nose", "neck", "r_shoulder", "r_elbow", "r_wrist", "l_shoulder", "l_elbow", "l_wrist", "mid_hip",
    "r_hip", "r_knee", "r_ankle", "l_hip", "l_knee", "l_ankle", "r_eye", "l_eye", "r_ear", "l_ear",
    "l_big_toe", "l_small_toe", "l_heel", "r_big_toe", "r_small_toe", "r_heel",
)  # fmt: skip


class MissingKeypointsError(ValueError):
    """Keypoints that interpolation may not fill; names the joint and the frames.

    Attributes:
        joint: joint index; ``joint_name``: its name when known; ``frames``: ``(first, last)`` missing frame.
    """

    def __init__(
        self, message: str, joint: int, frames: tuple[int, int], joint_name: str | None = None
    ) -> None:
        super().__init__(message)
        self.joint = joint
        self.joint_name = joint_name
        self.frames = frames


# ------------------------------------------------------------------------------------ subsets
def joint_indices(names: Sequence[str], wanted: Sequence[str]) -> list[int]:
    """Indices of ``wanted`` joint names in ``names`` (raises naming every missing joint)."""
    lookup = {n: i for i, n in enumerate(names)}
    missing = [w for w in wanted if w not in lookup]
    if missing:
        raise ValueError(f"joints {missing} not in the source layout; available: {list(names)}")
    return [lookup[w] for w in wanted]


def select_joints(motion: Array, indices: Sequence[int]) -> Array:
    """``motion[..., indices, :]`` for ``(..., J, D)`` motion (a copy), with a clear index error."""
    num = motion.shape[-2]
    bad = [i for i in indices if not -num <= int(i) < num]
    if bad:
        raise ValueError(f"select_joints: indices {bad} out of range for {num} joints")
    idx = list(map(int, indices))
    if isinstance(motion, torch.Tensor):
        return motion[..., idx, :]
    return np.asarray(motion)[..., idx, :].copy()


def _target_names(target: str) -> tuple[str, ...]:
    from momu.features.skeletons import get_skeleton

    return get_skeleton(target).joint_names


def openpose14_from_body25(keypoints: Array) -> Array:
    """The 14 keypoints MoMu/D2M keep (App. B.2) from OpenPose BODY-25 ``(..., 25, D)``, in the
    ``openpose14`` skeleton's order (nose, neck, right arm, left arm, right leg, left leg)."""
    if keypoints.shape[-2] != 25:
        raise ValueError(f"expected BODY-25 keypoints (..., 25, D), got shape {tuple(keypoints.shape)}")
    return select_joints(keypoints, joint_indices(BODY25_JOINT_NAMES, _target_names("openpose14")))


def openpose14_from_coco17(keypoints: Array) -> Array:
    """``openpose14`` keypoints from COCO-17 ``(..., 17, D)``; the neck is the shoulders' midpoint.

    Works with ``D`` = 2, 3, or keypoints carrying a trailing confidence channel (the neck then gets
    the smaller of the two shoulder confidences).
    """
    from momu.features.skeletons import get_skeleton

    coco = get_skeleton("coco17").joint_names
    if keypoints.shape[-2] != len(coco):
        raise ValueError(f"expected COCO-17 keypoints (..., 17, D), got shape {tuple(keypoints.shape)}")
    out_names = _target_names("openpose14")
    ls, rs = coco.index("l_shoulder"), coco.index("r_shoulder")
    parts = []
    for name in out_names:
        if name == "neck":
            if isinstance(keypoints, torch.Tensor):
                neck = (keypoints[..., ls, :] + keypoints[..., rs, :]) / 2
            else:
                neck = (np.asarray(keypoints)[..., ls, :] + np.asarray(keypoints)[..., rs, :]) / 2
            parts.append(neck)
        else:
            parts.append(keypoints[..., coco.index(name), :])
    if isinstance(keypoints, torch.Tensor):
        return torch.stack(parts, dim=-2)
    return np.stack(parts, axis=-2)


# ------------------------------------------------------------------------------------ missing keypoints
def confidence_mask(keypoints: np.ndarray, threshold: float = 0.0) -> tuple[np.ndarray, np.ndarray]:
    """Split ``(T, J, D + 1)`` keypoints-with-confidence into positions and a validity mask.

    Returns ``(positions (T, J, D), valid (T, J) bool)``: a keypoint is valid when its confidence is
    above ``threshold`` (OpenPose writes 0 for undetected keypoints) and its coordinates are finite.
    """
    x = np.asarray(keypoints, dtype=np.float64)
    if x.ndim != 3 or x.shape[-1] < 2:
        raise ValueError(f"keypoints: expected (T, J, D+1) with a confidence channel, got shape {x.shape}")
    pos, conf = x[..., :-1], x[..., -1]
    valid = (conf > threshold) & np.all(np.isfinite(pos), axis=-1)
    return pos.copy(), valid


def _runs(missing: np.ndarray) -> list[tuple[int, int]]:
    """``(start, end)`` (inclusive) of each run of True in a 1-D bool array."""
    if not missing.any():
        return []
    padded = np.concatenate([[False], missing, [False]])
    edges = np.flatnonzero(np.diff(padded.astype(np.int8)))
    return [(int(s), int(e) - 1) for s, e in zip(edges[::2], edges[1::2])]


def interpolate_missing(
    keypoints: np.ndarray,
    mask: np.ndarray | None = None,
    max_gap: int | None = None,
    *,
    joint_names: Sequence[str] | None = None,
    on_long_gap: str = "raise",
) -> np.ndarray:
    """Fill missing keypoints from neighbouring frames (MoMu App. B.2).

    Args:
        keypoints: ``(T, J, D)`` positions; a keypoint is missing where any coordinate is NaN/inf.
        mask: optional ``(T, J)`` bool, True = observed (e.g. from :func:`confidence_mask`);
            keypoints with False are missing too.
        max_gap: longest run of consecutive missing frames of one joint that may be filled
            (``None``: any length). Runs at the start or end of the clip count too.
        joint_names: names for error messages.
        on_long_gap: ``"raise"`` (default) a :class:`MissingKeypointsError` for a run longer than
            ``max_gap``; ``"leave"`` it NaN (for callers that report it themselves).

    Returns:
        ``(T, J, D)`` float64 copy: gaps between two observed frames linearly interpolated, leading /
        trailing gaps set to the nearest observed value. Observed keypoints are unchanged.

    Raises:
        MissingKeypointsError: a joint is missing in every frame (always), or a gap exceeds ``max_gap``
            with ``on_long_gap="raise"``; the message names the joint and the frames.
    """
    if on_long_gap not in ("raise", "leave"):
        raise ValueError(f"on_long_gap must be 'raise' or 'leave', got {on_long_gap!r}")
    if max_gap is not None and max_gap < 0:
        raise ValueError(f"max_gap must be >= 0 or None, got {max_gap}")
    x = np.array(keypoints, dtype=np.float64, copy=True)
    if x.ndim != 3 or x.shape[0] == 0:
        raise ValueError(f"keypoints: expected (T, J, D) with T >= 1, got shape {x.shape}")
    num_frames, num_joints, _ = x.shape
    missing = ~np.all(np.isfinite(x), axis=-1)
    if mask is not None:
        m = np.asarray(mask, dtype=bool)
        if m.shape != (num_frames, num_joints):
            raise ValueError(f"mask: expected shape ({num_frames}, {num_joints}), got {m.shape}")
        missing |= ~m
    if not missing.any():
        return x

    def label(j: int) -> str:
        if joint_names is not None and j < len(joint_names):
            return f"joint {j} ({joint_names[j]})"
        return f"joint {j}"

    t = np.arange(num_frames, dtype=np.float64)
    for j in map(int, np.flatnonzero(missing.any(axis=0))):
        gone = missing[:, j]
        name = joint_names[j] if joint_names is not None and j < len(joint_names) else None
        if gone.all():
            raise MissingKeypointsError(
                f"keypoints: {label(j)} is missing in all {num_frames} frames; nothing to interpolate from",
                int(j), (0, num_frames - 1), name,
            )  # fmt: skip
        long_runs: list[tuple[int, int]] = []
        if max_gap is not None:
            long_runs = [(s, e) for s, e in _runs(gone) if e - s + 1 > max_gap]
            if long_runs and on_long_gap == "raise":
                s, e = long_runs[0]
                raise MissingKeypointsError(
                    f"keypoints: {label(j)} is missing for {e - s + 1} consecutive frames ({s}..{e}), "
                    f"longer than max_gap={max_gap}",
                    int(j), (s, e), name,
                )  # fmt: skip
        seen = ~gone
        for d in range(x.shape[2]):
            # np.interp holds the end values constant outside the observed range.
            x[gone, j, d] = np.interp(t[gone], t[seen], x[seen, j, d])
        for s, e in long_runs:
            x[s : e + 1, j] = np.nan
    return x


# ------------------------------------------------------------------------------------ frame dropping
def even_frame_indices(num_frames: int, target: int) -> np.ndarray:
    """Indices of ``target`` frames taken evenly from ``num_frames`` (MoMu §3.2 frame dropping).

    Output frame ``i`` (at time ``i/target`` of the clip) takes input frame ``floor(i·T/target + ½)``,
    the one nearest in time (clipped to ``T − 1``). For ``target ≤ T`` the indices are strictly
    increasing (frames are dropped evenly); for ``target > T`` frames repeat (nearest-neighbour
    resampling — :func:`drop_frames_evenly` refuses that case).
    """
    if num_frames <= 0:
        raise ValueError(f"num_frames must be positive, got {num_frames}")
    if target <= 0:
        raise ValueError(f"target number of frames must be positive, got {target}")
    idx = np.floor(np.arange(target, dtype=np.float64) * num_frames / target + 0.5).astype(np.int64)
    return np.minimum(idx, num_frames - 1)


def drop_frames_evenly(motion: Array, num_frames: int, *, axis: int = 0) -> Array:
    """MoMu §3.2: evenly drop frames of ``motion`` along ``axis`` so it has ``num_frames`` frames.

    Used to match motion frames to music (latent) frames, ``T_zm = T_za``. Numpy arrays or tensors.

    Raises:
        ValueError: ``num_frames`` is not positive or exceeds the motion's frames (nothing to drop).
    """
    length = int(motion.shape[axis])
    if num_frames > length:
        raise ValueError(
            f"cannot drop frames to reach {num_frames} frames from {length}: the target exceeds the motion"
        )
    idx = even_frame_indices(length, int(num_frames))
    if isinstance(motion, torch.Tensor):
        return motion.index_select(axis, torch.as_tensor(idx, device=motion.device))
    return np.take(np.asarray(motion), idx, axis=axis)


# ------------------------------------------------------------------------------------ normalisation
@dataclass
class Normalizer:
    """Per-channel standardisation ``(x − mean) / std`` with stored statistics.

    ``mean`` and ``std`` have the trailing *feature shape* (``(C,)`` for ``(..., C)`` features,
    ``(J, D)`` for ``(T, J, D)`` motion). Channels whose std is below ``eps`` get std 1, so constant
    channels map to 0 instead of blowing up.
    """

    mean: np.ndarray
    std: np.ndarray
    eps: float = 1e-8

    def __post_init__(self) -> None:
        self.mean = np.asarray(self.mean, dtype=np.float64)
        self.std = np.asarray(self.std, dtype=np.float64)
        if self.mean.shape != self.std.shape:
            raise ValueError(f"Normalizer: mean shape {self.mean.shape} != std shape {self.std.shape}")
        if not (np.all(np.isfinite(self.mean)) and np.all(np.isfinite(self.std))):
            raise ValueError("Normalizer: statistics contain NaN/inf")
        if np.any(self.std < 0):
            raise ValueError("Normalizer: std must be non-negative")
        self.std = np.where(self.std < self.eps, 1.0, self.std)

    @property
    def feature_shape(self) -> tuple[int, ...]:
        return tuple(self.mean.shape)

    @classmethod
    def fit(
        cls, data: np.ndarray | Iterable[np.ndarray], feature_ndim: int = 1, eps: float = 1e-8
    ) -> Normalizer:
        """Statistics over every axis but the trailing ``feature_ndim`` ones.

        ``data`` is one array or an iterable of arrays (clips of different lengths); all samples weigh
        equally. Accumulated in float64 (population std, ddof 0).
        """
        arrays = [np.asarray(data)] if isinstance(data, np.ndarray) else [np.asarray(a) for a in data]
        if not arrays:
            raise ValueError("Normalizer.fit: no data")
        shape = arrays[0].shape[arrays[0].ndim - feature_ndim :]
        count = 0
        total = np.zeros(shape, dtype=np.float64)
        total_sq = np.zeros(shape, dtype=np.float64)
        for i, a in enumerate(arrays):
            if a.ndim < feature_ndim or a.shape[a.ndim - feature_ndim :] != shape:
                raise ValueError(f"Normalizer.fit: array {i} has shape {a.shape}, expected (..., {shape})")
            flat = a.reshape((-1,) + shape).astype(np.float64)
            if not np.all(np.isfinite(flat)):
                raise ValueError(f"Normalizer.fit: array {i} contains NaN/inf")
            count += flat.shape[0]
            total += flat.sum(0)
            total_sq += (flat**2).sum(0)
        if count == 0:
            raise ValueError("Normalizer.fit: the data has no samples")
        mean = total / count
        var = np.maximum(total_sq / count - mean**2, 0.0)
        return cls(mean, np.sqrt(var), eps)

    def _stats(self, x: Any) -> tuple[Any, Any]:
        shape = self.feature_shape
        if tuple(x.shape[x.ndim - len(shape) :]) != shape:
            raise ValueError(
                f"Normalizer: input shape {tuple(x.shape)} does not end in feature shape {shape}"
            )
        if isinstance(x, torch.Tensor):
            return (
                torch.as_tensor(self.mean, dtype=x.dtype, device=x.device),
                torch.as_tensor(self.std, dtype=x.dtype, device=x.device),
            )
        return self.mean, self.std

    def transform(self, x: Array) -> Array:
        """``(x − mean) / std`` (numpy → float64 unless float32 input, torch keeps dtype/device)."""
        mean, std = self._stats(x)
        out = (x - mean) / std
        if isinstance(x, np.ndarray) and x.dtype == np.float32:
            return out.astype(np.float32)  # type: ignore[no-any-return]
        return out  # type: ignore[no-any-return]

    def inverse(self, x: Array) -> Array:
        """``x · std + mean``."""
        mean, std = self._stats(x)
        out = x * std + mean
        if isinstance(x, np.ndarray) and x.dtype == np.float32:
            return out.astype(np.float32)  # type: ignore[no-any-return]
        return out  # type: ignore[no-any-return]

    def save(self, path: str | Path) -> Path:
        """Write the statistics atomically: ``.json`` (human-readable) or ``.npz`` (no pickle)."""
        path = Path(path)
        if path.suffix == ".json":
            return write_json(
                path,
                {
                    "kind": "momu.Normalizer",
                    "eps": self.eps,
                    "mean": self.mean.tolist(),
                    "std": self.std.tolist(),
                },
            )
        if path.suffix == ".npz":
            with atomic_path(path) as tmp:
                np.savez(tmp, mean=self.mean, std=self.std, eps=np.asarray(self.eps))
            return path
        raise ValueError(f"{path}: Normalizer.save needs a .json or .npz suffix")

    @classmethod
    def load(cls, path: str | Path) -> Normalizer:
        """Read statistics written by :meth:`save`; errors name the file."""
        path = Path(path)
        if not path.is_file():
            raise FileNotFoundError(f"{path}: normaliser statistics not found")
        try:
            if path.suffix == ".json":
                data = json.loads(path.read_text(encoding="utf-8"))
                return cls(np.asarray(data["mean"]), np.asarray(data["std"]), float(data.get("eps", 1e-8)))
            if path.suffix == ".npz":
                with np.load(path, allow_pickle=False) as z:
                    eps = float(z["eps"]) if "eps" in z.files else 1e-8
                    return cls(z["mean"], z["std"], eps)
        except (KeyError, ValueError, OSError, json.JSONDecodeError) as exc:
            raise ValueError(f"{path}: not valid normaliser statistics: {exc}") from None
        raise ValueError(f"{path}: Normalizer.load needs a .json or .npz file")

    def __eq__(self, other: object) -> bool:
        if not isinstance(other, Normalizer):
            return NotImplemented
        return (
            self.mean.shape == other.mean.shape
            and bool(np.array_equal(self.mean, other.mean))
            and bool(np.array_equal(self.std, other.std))
            and math.isclose(self.eps, other.eps)
        )

    __hash__ = None  # type: ignore[assignment]
