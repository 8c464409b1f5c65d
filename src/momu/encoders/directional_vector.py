"""Directional-vector motion VAE: MoMu's "w/ Directional Vectors" ablation (Table 7 #1, §5.3).

"The directional vector-based method ... learns the unit directional vectors of the given
adjacency set, and reconstructs the human pose with the calculated mean bone lengths [48]"
(MoMu §5.3 "Motion Encoding"). The representation of a ``(B, T, J, D)`` motion is

* the root joint's position ``(B, T, D)`` (the adjacency set fixes everything but the root), and
* the unit direction of every bone of the skeleton, parent -> child, ``(B, T, J - 1, D)``
  (:func:`momu.features.bones.bone_directions`),

stacked as ``(B, T, J, D)`` (slot 0 = root, slot ``1 + b`` = bone ``b``) and flattened into
``J * D`` Conv1d channels for the Table 8 network. The VAE reconstructs this representation (the
reconstruction loss is on root + directions); decoding renormalises the predicted directions and
walks the tree from the root with the mean bone lengths
(:func:`momu.features.bones.positions_from_directions`). Those lengths are a buffer saved with the
weights: the skeleton's rest lengths until :meth:`DirectionalVectorVAE.fit_bone_lengths` sets the
dataset means (MoMu App. E's "mean bone length in the dataset"), which it should before training.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np
import torch
from einops import rearrange

from momu.encoders.vae import SequenceVAE, VAE1dConfig
from momu.features.bones import bone_directions, mean_bone_lengths, positions_from_directions
from momu.features.skeletons import get_skeleton
from momu.registry import ENCODERS

__all__ = ["DirectionalVectorConfig", "DirectionalVectorVAE", "build_directional_vector"]


@dataclass
class DirectionalVectorConfig:
    """Attributes:
    skeleton: joint layout name (:func:`momu.features.skeletons.get_skeleton`; MoMu: ``openpose14``).
        Its bones are the adjacency set; its ``dims`` the coordinates per joint.
    vae: the Table 8 network.
    """

    skeleton: str = "openpose14"
    vae: VAE1dConfig = field(default_factory=VAE1dConfig)


class DirectionalVectorVAE(SequenceVAE):
    """Motion VAE on (root position, unit bone directions); decodes positions with mean bone lengths."""

    modality = "motion"
    input_kind = "bone_directions"

    def __init__(self, cfg: DirectionalVectorConfig | None = None) -> None:
        cfg = cfg or DirectionalVectorConfig()
        try:
            skeleton = get_skeleton(cfg.skeleton)
        except KeyError as exc:
            raise ValueError(f"directional_vector.skeleton: {exc.args[0]}") from None
        super().__init__(skeleton.num_joints * skeleton.dims, cfg.vae)
        self.skeleton = skeleton
        self.num_joints = skeleton.num_joints
        self.joint_dims = skeleton.dims
        self.bones: tuple[tuple[int, int], ...] = tuple(skeleton.bones)
        self.root = skeleton.root
        self.mean_lengths: torch.Tensor
        self.register_buffer("mean_lengths", torch.as_tensor(skeleton.bone_lengths, dtype=torch.float32))

    def fit_bone_lengths(self, motions: torch.Tensor | np.ndarray | Sequence[np.ndarray]) -> torch.Tensor:
        """Set the decoding lengths to the mean bone lengths of ``motions``.

        ``motions``: ``(T, J, D)``, ``(B, T, J, D)`` or a list of ``(T, J, D)`` clips.
        """
        if isinstance(motions, torch.Tensor):
            motions = motions.detach().cpu().double().numpy()
        if isinstance(motions, np.ndarray):
            if motions.ndim < 3 or motions.shape[-2:] != (self.num_joints, self.joint_dims):
                raise ValueError(
                    f"motions must be (..., T, {self.num_joints}, {self.joint_dims}), got {motions.shape}"
                )
            lengths = mean_bone_lengths(motions.reshape(-1, self.num_joints, self.joint_dims), self.bones)
        else:
            lengths = mean_bone_lengths([np.asarray(m, dtype=np.float64) for m in motions], self.bones)
        if not np.all(np.isfinite(lengths)) or np.any(lengths <= 0):
            raise ValueError(f"mean bone lengths must be finite and positive, got {np.asarray(lengths)}")
        self.mean_lengths.copy_(torch.as_tensor(lengths, dtype=self.mean_lengths.dtype))
        return self.mean_lengths

    def _check(self, x: torch.Tensor, what: str) -> None:
        if x.ndim != 4 or x.shape[2:] != (self.num_joints, self.joint_dims):
            raise ValueError(
                f"{what} must be (B, T, {self.num_joints}, {self.joint_dims}), got {tuple(x.shape)}"
            )

    def input_length(self, x: torch.Tensor) -> int:
        self._check(x, "motion")
        return int(x.shape[1])

    def represent(self, x: torch.Tensor) -> torch.Tensor:
        """Positions ``(B, T, J, D)`` -> ``(B, T, J, D)``: root position, then the unit bone directions."""
        self._check(x, "motion")
        dirs = bone_directions(x, self.bones)  # (B, T, J-1, D)
        return torch.cat([x[:, :, self.root : self.root + 1], dirs], dim=2)

    def realize(self, rep: torch.Tensor) -> torch.Tensor:
        """``(B, T, J, D)`` root + directions -> positions with the mean bone lengths."""
        self._check(rep, "representation")
        b, t = rep.shape[:2]
        flat = rearrange(rep, "b t k d -> (b t) k d")
        positions: torch.Tensor = positions_from_directions(
            flat[:, 1:],
            self.mean_lengths.to(rep.dtype),
            self.bones,
            flat[:, 0],
            root_index=self.root,
            num_joints=self.num_joints,
        )
        return rearrange(positions, "(b t) j d -> b t j d", b=b, t=t)

    def to_channels(self, rep: torch.Tensor) -> torch.Tensor:
        return rearrange(rep, "b t k d -> b (k d) t")

    def from_channels(self, y: torch.Tensor, length: int) -> torch.Tensor:
        return rearrange(y[..., :length], "b (k d) t -> b t k d", d=self.joint_dims)


@ENCODERS.register("directional_vector", config=DirectionalVectorConfig)
def build_directional_vector(cfg: DirectionalVectorConfig) -> DirectionalVectorVAE:
    """Registry factory: the directional-vector motion VAE of MoMu Table 7 #1."""
    return DirectionalVectorVAE(cfg)
