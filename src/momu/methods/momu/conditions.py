"""What MoMu's denoisers are conditioned on, and how its motion is represented (issue 32).

MoMu Eq. 6 conditions θ_m (music→motion) on the music latent and θ_a (motion→music) on the motion
latent. :class:`Conditions` adds, from :class:`~momu.methods.momu.config.MoMuConfig`:

* condition *features* from a registered encoder with ``track``/``features`` (``music_rhythm`` for
  θ_m, ``motion_rhythm`` for θ_a), computed once over a whole input and cut per window, placed
  after the latent (``condition_latents: true``) or alone;
* the motion representation the VAE learns (``positions`` or ``root_velocity``,
  :mod:`momu.features.root_motion`), with world positions built from a root-centred clip's
  ``trajectory`` when it has one.

With neither set (the default) every method here returns what the paper's model uses, unchanged.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from typing import Any

import numpy as np
import torch

from momu.config import build_component
from momu.data.types import Clip
from momu.errors import one_line
from momu.features.root_motion import check_representation, from_root_velocity, to_root_velocity
from momu.features.skeletons import SKELETON_NAMES, get_skeleton

__all__ = ["Conditions", "check_condition_parts", "world_positions"]


def world_positions(clip: Clip) -> np.ndarray:
    """``(T, J, D)`` keypoints of ``clip`` with its root trajectory added back when it is root-centred."""
    motion = np.asarray(clip.motion)
    if clip.trajectory is None:
        return motion
    return motion + np.asarray(clip.trajectory, dtype=motion.dtype)[: motion.shape[0], None, :]


def _features_part(node: Any, name: str) -> Any:
    """The condition-feature part of ``method.<name>`` (``None`` for ``null``); a ``ValueError`` naming
    the key when it cannot be built or lacks the protocol (docs/protocols.md, "Condition features")."""
    if node is None:
        return None
    try:
        part = build_component(node, "encoders")
    except (ValueError, LookupError, ImportError) as exc:  # bad params, unknown name, broken plugin
        raise ValueError(f"method.{name}: {one_line(exc)}") from None
    if not (hasattr(part, "track") and hasattr(part, "out_channels")):
        raise ValueError(
            f"method.{name}: {type(part).__name__} has no track()/out_channels (docs/protocols.md)"
        )
    return part


def check_condition_parts(cfg: Any) -> None:
    """Build ``method.motion_condition`` and ``method.music_condition`` once, so that an unknown name,
    a bad parameter or a part without the protocol fails with the key before anything is trained."""
    for name in ("motion_condition", "music_condition"):
        _features_part(getattr(cfg, name), name)


@dataclass
class Conditions:
    """Condition features and motion representation of one MoMu configuration.

    Attributes:
        from_music: θ_m's feature part (computed from music), or ``None``.
        from_motion: θ_a's feature part (computed from motion), or ``None``.
        latents: whether the other modality's latent stays in the condition.
        representation: ``positions`` or ``root_velocity``.
        root: the skeleton's root joint (used by ``root_velocity``).
    """

    from_music: Any
    from_motion: Any
    latents: bool
    representation: str
    root: int

    @classmethod
    def of(cls, cfg: Any, skeleton: str) -> Conditions:
        """The conditions of a :class:`~momu.methods.momu.config.MoMuConfig` for data of ``skeleton``."""
        dims = get_skeleton(skeleton).dims if skeleton in SKELETON_NAMES else None
        check_representation(cfg.motion_representation, dims)
        root = get_skeleton(skeleton).root if skeleton in SKELETON_NAMES else 0
        return cls(
            _features_part(cfg.motion_condition, "motion_condition"),
            _features_part(cfg.music_condition, "music_condition"),
            bool(cfg.condition_latents),
            str(cfg.motion_representation),
            int(root),
        )

    # ------------------------------------------------------------------ motion representation
    def motion_in(self, positions: np.ndarray, fps: float) -> np.ndarray:
        """World keypoints → what the motion VAE learns."""
        if self.representation == "positions":
            return positions
        return to_root_velocity(positions, fps, self.root)

    def motion_out(self, features: np.ndarray, fps: float) -> np.ndarray:
        """What the motion VAE decodes → world keypoints (``root_velocity``: the path starts at 0)."""
        if self.representation == "positions":
            return features
        return from_root_velocity(features, fps, self.root)

    def clip_motion(self, clip: Clip) -> np.ndarray:
        """A training clip's motion in the representation (``positions``: ``clip.motion`` as it is)."""
        if self.representation == "positions":
            return np.asarray(clip.motion)
        return self.motion_in(world_positions(clip), clip.fps)

    @property
    def reads_dance_beats(self) -> bool:
        """Whether θ_a's condition is a rhythm part that reads a dance's beats (``subdivide``): what
        :meth:`with_beats_per_movement` splits."""
        return hasattr(getattr(self.from_motion, "cfg", None), "subdivide")

    def with_beats_per_movement(self, beats: int) -> Conditions:
        """These conditions with θ_a's rhythm split into ``beats`` beats per beat it tracks on a dance
        (its ``subdivide``: a dancer who moves once per bar of a waltz, ``beats=3``, gives music at the
        waltz's beat, not at the bar).

        Raises:
            ValueError: ``beats`` < 1, or θ_a is not conditioned on a rhythm part with ``subdivide``.
        """
        cfg = getattr(self.from_motion, "cfg", None)
        if cfg is None or not self.reads_dance_beats:
            raise ValueError("this model's music is not conditioned on the dance's beats (music_condition)")
        if beats < 1:
            raise ValueError(f"beats per movement must be >= 1, got {beats}")
        return replace(self, from_motion=type(self.from_motion)(replace(cfg, subdivide=int(beats))))

    # ------------------------------------------------------------------ condition features
    def cond_width(self, direction: str, latent_channels: int) -> int:
        """Condition width of the denoiser generating ``direction`` (``"motion"``: θ_m, ``"music"``: θ_a)."""
        part = self.from_music if direction == "motion" else self.from_motion
        width = latent_channels if (self.latents or part is None) else 0
        return width + (int(part.out_channels) if part is not None else 0)

    @property
    def any_features(self) -> bool:
        return self.from_music is not None or self.from_motion is not None

    def music_track(self, audio: np.ndarray, sample_rate: float) -> Any:
        """θ_m's feature track of a song (``None`` without motion_condition)."""
        return None if self.from_music is None else self.from_music.track(audio, sample_rate)

    def motion_track(self, positions: np.ndarray, fps: float) -> Any:
        """θ_a's feature track of a dance in world keypoints (``None`` without music_condition)."""
        return None if self.from_motion is None else self.from_motion.track(positions, fps)

    def combine(self, latent: torch.Tensor, features: np.ndarray | torch.Tensor | None) -> torch.Tensor:
        """The condition ``(T, C)``: the latent ``(T, d)`` (when kept) followed by ``features``."""
        if features is None:
            return latent
        f = torch.as_tensor(np.asarray(features), dtype=latent.dtype)[: latent.shape[0]]
        if f.shape[0] < latent.shape[0]:
            f = torch.cat([f, f[-1:].expand(latent.shape[0] - f.shape[0], -1)])
        return torch.cat([latent, f], dim=-1) if self.latents else f
