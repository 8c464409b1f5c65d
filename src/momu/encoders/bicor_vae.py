"""BiCoR-VAE: paired motion and music VAEs with an aligned latent space (MoMu §3, App. A).

* :class:`KeypointVAE`: the motion VAE of MoMu §3.1 on 2D keypoints ``(B, T_m, J, 2)``; joints and
  coordinates are flattened into ``J * 2`` Conv1d channels. ``z_m = E_m(m) in R^{T_zm x d}``.
* :class:`MelVAE`: the music VAE of MoMu §3.1 on log-mel spectrograms ``(B, 80, T_a)``
  (MoMu App. B.2: 16 kHz, 80 bins, n_fft 1024, hop 256). ``z_a = E_a(a) in R^{T_za x d}``.
* :class:`BiCoRVAE` (registered ``bicor_vae``): the pair, with MoMu §3.2's frame alignment (motion
  frames evenly dropped so ``T_zm = T_za``), stage-2 freezing of the music VAE (App. A.2, Eq. 11),
  and optional replacement of either branch by a registered alternative (MoMu Table 7:
  ``motion_encoder: directional_vector`` (#1), ``music_encoder: waveform`` (#2)).
* :func:`stage2_loss`: MoMu Eq. 11, ``L_recon + lambda3 L_KL + lambda4 L_contrast`` with the music
  VAE frozen. Stage 1 (Eq. 10, VAE + GAN) is :func:`momu.losses.gan.two_step_update`.

Both branches have the Table 8 architecture (:mod:`momu.encoders.vae`). Inputs are expected to be
normalised (e.g. with :class:`momu.features.preprocess.Normalizer`); the VAEs do not rescale.
"""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import dataclass, field
from typing import Any

import torch
from einops import rearrange
from torch import nn

from momu.encoders.vae import DiagonalGaussian, SequenceVAE, VAE1dConfig, VAEOutput, paper_vae_config
from momu.registry import ENCODERS

__all__ = [
    "KeypointVAE",
    "MelVAE",
    "BiCoRVAEConfig",
    "paper_bicor_vae_config",
    "BiCoRVAE",
    "build_bicor_vae",
    "align_frames",
    "stage2_loss",
]

ALIGN_MODES = ("drop", "linear", "nearest")


class KeypointVAE(SequenceVAE):
    """Motion VAE on joint positions (MoMu §3.1): ``(B, T, J, D)`` <-> latents ``(B, T / ds, d)``."""

    modality = "motion"
    input_kind = "keypoints"

    def __init__(self, num_joints: int, joint_dims: int, cfg: VAE1dConfig) -> None:
        if num_joints < 1 or joint_dims < 1:
            raise ValueError(f"num_joints and joint_dims must be >= 1, got {num_joints}, {joint_dims}")
        super().__init__(num_joints * joint_dims, cfg)
        self.num_joints = num_joints
        self.joint_dims = joint_dims

    def _check(self, x: torch.Tensor) -> None:
        if x.ndim != 4 or x.shape[2:] != (self.num_joints, self.joint_dims):
            raise ValueError(
                f"motion must be (B, T, {self.num_joints}, {self.joint_dims}), got {tuple(x.shape)}"
            )

    def input_length(self, x: torch.Tensor) -> int:
        self._check(x)
        return int(x.shape[1])

    def to_channels(self, rep: torch.Tensor) -> torch.Tensor:
        self._check(rep)
        return rearrange(rep, "b t j d -> b (j d) t")

    def from_channels(self, y: torch.Tensor, length: int) -> torch.Tensor:
        return rearrange(y[..., :length], "b (j d) t -> b t j d", j=self.num_joints)


class MelVAE(SequenceVAE):
    """Music VAE on log-mel spectrograms (MoMu §3.1): ``(B, n_mels, T_a)`` <-> ``(B, T_a / ds, d)``."""

    modality = "music"
    input_kind = "mel"

    def __init__(self, mel_bins: int, cfg: VAE1dConfig) -> None:
        super().__init__(mel_bins, cfg)
        self.mel_bins = mel_bins

    def input_length(self, x: torch.Tensor) -> int:
        if x.ndim != 3 or x.shape[1] != self.mel_bins:
            raise ValueError(f"mel must be (B, {self.mel_bins}, T), got {tuple(x.shape)}")
        return int(x.shape[-1])

    def to_channels(self, rep: torch.Tensor) -> torch.Tensor:
        self.input_length(rep)
        return rep

    def from_channels(self, y: torch.Tensor, length: int) -> torch.Tensor:
        return y[..., :length]


def align_frames(x: torch.Tensor, num_frames: int, *, dim: int = 1, mode: str = "linear") -> torch.Tensor:
    """Evenly drop frames of ``x`` along ``dim`` so it has ``num_frames`` (MoMu §3.2).

    Every mode drops frames exactly like the paper when ``num_frames <= x.shape[dim]``
    (:func:`momu.features.preprocess.drop_frames_evenly`). They differ only when the motion is
    sampled slower than the music latent rate requires (e.g. 60 fps motion against 62.5 mel
    frames/s), which the paper never meets:

    * ``"linear"`` (default): output frame ``i`` (at time ``i / num_frames`` of the clip) is the
      linear interpolation of the input at position ``i · T / num_frames``;
    * ``"nearest"``: the input frame nearest in time
      (:func:`momu.features.preprocess.even_frame_indices`), i.e. evenly spaced frames repeat. A
      repeated frame is a one-frame stop: MoMu's kinematic amplitude (Eq. 2) fires right after it,
      so nearest-frame upsampling plants a spurious kinematic beat every ``T / (num_frames − T)``
      frames (every 0.5 s for 60 → 62.5 fps) in the training targets;
    * ``"drop"``: the paper only; an error when frames would have to be added.
    """
    from momu.features.preprocess import drop_frames_evenly, even_frame_indices

    if mode not in ALIGN_MODES:
        raise ValueError(f"align mode must be one of {ALIGN_MODES}, got {mode!r}")
    length = int(x.shape[dim])
    if num_frames < 1:
        raise ValueError(f"num_frames must be >= 1, got {num_frames}")
    if num_frames == length:
        return x
    if num_frames < length:
        return drop_frames_evenly(x, num_frames, axis=dim)
    if mode == "drop":
        raise ValueError(
            f"cannot align {length} motion frames to {num_frames} by dropping frames (MoMu §3.2 needs "
            f"at least as many motion frames as the music requires); use align='linear' to interpolate "
            f"frames, raise the motion frame rate, or crop the music"
        )
    if mode == "nearest":
        idx = torch.as_tensor(even_frame_indices(length, num_frames), device=x.device)
        return x.index_select(dim, idx)
    pos = torch.arange(num_frames, dtype=torch.float64, device=x.device) * (length / num_frames)
    lo = pos.floor().long().clamp(max=length - 1)
    hi = (lo + 1).clamp(max=length - 1)
    shape = [1] * x.dim()
    shape[dim] = num_frames
    w = (pos - lo.to(torch.float64)).to(x.dtype if x.is_floating_point() else torch.float32).view(shape)
    return x.index_select(dim, lo) * (1 - w) + x.index_select(dim, hi) * w


@dataclass
class BiCoRVAEConfig:
    """BiCoR-VAE configuration (MoMu Table 8 per branch; App. B.2 inputs).

    Attributes:
        num_joints: keypoints per frame (MoMu App. B.2: the 14 OpenPose keypoints of ``openpose14``).
        joint_dims: coordinates per keypoint (2: image-plane keypoints).
        mel_bins: mel channels (MoMu App. B.2: 80).
        motion: the motion VAE (Table 8).
        music: the mel VAE (Table 8).
        align: frame alignment mode, ``"linear"`` (default: drops evenly like the paper when motion
            has enough frames, interpolates linearly otherwise), ``"nearest"`` (repeats frames
            instead) or ``"drop"`` (the paper only; errors when motion is too short). See
            :func:`align_frames`.
        motion_encoder: optional component node naming a registered motion VAE that replaces the
            keypoint VAE (``{name: directional_vector, ...}``, MoMu Table 7 #1); ``motion`` is then unused.
        music_encoder: optional component node naming a registered music VAE that replaces the mel
            VAE (``{name: waveform, ...}``, Table 7 #2); ``music`` and ``mel_bins`` are then unused.
    """

    num_joints: int = 14
    joint_dims: int = 2
    mel_bins: int = 80
    motion: VAE1dConfig = field(default_factory=VAE1dConfig)
    music: VAE1dConfig = field(default_factory=VAE1dConfig)
    align: str = "linear"
    motion_encoder: Any = None
    music_encoder: Any = None


def paper_bicor_vae_config(**overrides: Any) -> BiCoRVAEConfig:
    """MoMu's published BiCoR-VAE size: Table 8 in both branches at base width 192.

    216.7M parameters in all (Table 8: 213M); see :func:`momu.encoders.vae.paper_vae_config`.
    """
    fields: dict[str, Any] = {"motion": paper_vae_config(), "music": paper_vae_config()}
    fields.update(overrides)
    return BiCoRVAEConfig(**fields)


class BiCoRVAE(nn.Module):
    """The paired motion and music VAEs of MoMu §3 with aligned latents ``(B, T_z, d)``.

    Attributes:
        motion_vae: the motion branch (:class:`KeypointVAE` or a Table 7 replacement).
        music_vae: the music branch (:class:`MelVAE` or a Table 7 replacement).
        latent_channels: ``d``, shared by both branches.
    """

    def __init__(
        self,
        motion_vae: SequenceVAE,
        music_vae: SequenceVAE,
        align: str = "linear",
    ) -> None:
        super().__init__()
        if motion_vae.modality != "motion":
            raise ValueError(f"motion_vae must be a motion branch, got a {motion_vae.modality!r} VAE")
        if music_vae.modality != "music":
            raise ValueError(f"music_vae must be a music branch, got a {music_vae.modality!r} VAE")
        if motion_vae.latent_channels != music_vae.latent_channels:
            raise ValueError(
                f"motion and music latents must have the same width d (MoMu §3.2), got "
                f"{motion_vae.latent_channels} and {music_vae.latent_channels}"
            )
        if align not in ALIGN_MODES:
            raise ValueError(f"align must be one of {ALIGN_MODES}, got {align!r}")
        self.motion_vae = motion_vae
        self.music_vae = music_vae
        self.align = align
        self.latent_channels = motion_vae.latent_channels
        self._music_frozen = False

    # ---------------------------------------------------------------- music
    @property
    def music_input(self) -> str:
        """What :meth:`encode_music` takes: ``"mel"`` ``(B, n_mels, T_a)`` or ``"waveform"`` ``(B, S)``."""
        return self.music_vae.input_kind

    def encode_music(self, music: torch.Tensor) -> DiagonalGaussian:
        """``q(z_a | a)``: music (mel ``(B, 80, T_a)``, or waveform) -> latents ``(B, T_z, d)``."""
        return self.music_vae.encode(music)

    def decode_music(self, z: torch.Tensor, num_frames: int | None = None) -> torch.Tensor:
        """Latents ``(B, T_z, d)`` -> music (mel ``(B, 80, num_frames)``; default ``T_z * ds``)."""
        return self.music_vae.decode(z, num_frames)

    def music_latent_length(self, num_frames: int) -> int:
        """Latent frames for ``num_frames`` music input frames (mel frames or samples)."""
        return self.music_vae.latent_length(num_frames)

    # ---------------------------------------------------------------- motion
    def motion_frames_for(self, num_latent_frames: int) -> int:
        """Motion frames that encode to exactly ``num_latent_frames`` latents."""
        return int(num_latent_frames) * self.motion_vae.frames_per_latent

    def align_motion(self, motion: torch.Tensor, num_latent_frames: int) -> torch.Tensor:
        """MoMu §3.2: evenly drop frames of motion ``(B, T_m, J, D)`` so ``T_zm = num_latent_frames``."""
        return align_frames(motion, self.motion_frames_for(num_latent_frames), dim=1, mode=self.align)

    def encode_motion(self, motion: torch.Tensor, num_latent_frames: int | None = None) -> DiagonalGaussian:
        """``q(z_m | m)``: motion ``(B, T_m, J, D)`` -> latents ``(B, T_z, d)``.

        With ``num_latent_frames`` (the music latent length), the motion is first aligned by
        :meth:`align_motion` so the two latents have equal length (MoMu §3.2).
        """
        if num_latent_frames is not None:
            motion = self.align_motion(motion, num_latent_frames)
        return self.motion_vae.encode(motion)

    def decode_motion(self, z: torch.Tensor, num_frames: int | None = None) -> torch.Tensor:
        """Latents ``(B, T_z, d)`` -> motion ``(B, num_frames, J, D)`` (default ``T_z * ds``)."""
        return self.motion_vae.decode(z, num_frames)

    def encode_pair(
        self, motion: torch.Tensor, music: torch.Tensor
    ) -> tuple[DiagonalGaussian, DiagonalGaussian, torch.Tensor]:
        """``(q(z_m), q(z_a), aligned motion)`` with ``T_zm = T_za`` (MoMu §3.2)."""
        q_music = self.encode_music(music)
        aligned = self.align_motion(motion, q_music.shape[1])
        return self.motion_vae.encode(aligned), q_music, aligned

    # ---------------------------------------------------------------- stage 2 freezing
    @property
    def music_frozen(self) -> bool:
        return self._music_frozen

    def freeze_music(self, frozen: bool = True) -> BiCoRVAE:
        """Freeze (or unfreeze) the music VAE for stage 2 (MoMu §3.3, App. A.2 Eq. 11).

        Frozen: its parameters stop requiring gradients and it stays in eval mode (no dropout)
        even when the whole model is put in train mode.
        """
        self._music_frozen = frozen
        for p in self.music_vae.parameters():
            p.requires_grad_(not frozen)
        self.music_vae.train(self.training and not frozen)
        return self

    def train(self, mode: bool = True) -> BiCoRVAE:
        super().train(mode)
        if self._music_frozen:
            self.music_vae.eval()
        return self

    def trainable_parameters(self) -> Iterator[nn.Parameter]:
        """Parameters that require gradients (the motion VAE's only, once the music VAE is frozen)."""
        return (p for p in self.parameters() if p.requires_grad)


def _build_branch(node: Any, modality: str, fallback: SequenceVAE | None) -> SequenceVAE:
    if node is None:
        assert fallback is not None
        return fallback
    from momu.config import build_component

    branch = build_component(node, "encoders")
    if not isinstance(branch, SequenceVAE) or branch.modality != modality:
        name = node if isinstance(node, str) else dict(node).get("name")
        raise ValueError(f"bicor_vae.{modality}_encoder: encoder {name!r} is not a {modality} VAE")
    return branch


@ENCODERS.register("bicor_vae", config=BiCoRVAEConfig)
def build_bicor_vae(cfg: BiCoRVAEConfig) -> BiCoRVAE:
    """Registry factory for MoMu's BiCoR-VAE (optionally with Table 7 replacement branches)."""
    motion = _build_branch(
        cfg.motion_encoder,
        "motion",
        None if cfg.motion_encoder is not None else KeypointVAE(cfg.num_joints, cfg.joint_dims, cfg.motion),
    )
    music = _build_branch(
        cfg.music_encoder, "music", None if cfg.music_encoder is not None else MelVAE(cfg.mel_bins, cfg.music)
    )
    return BiCoRVAE(motion, music, align=cfg.align)


def stage2_loss(
    model: BiCoRVAE,
    motion: torch.Tensor,
    music: torch.Tensor,
    *,
    vae_loss: Any,
    contrastive: Any,
    generator: torch.Generator | None = None,
) -> dict[str, torch.Tensor]:
    """MoMu Eq. 11: ``L_stage2 = L_recon + lambda3 L_KL + lambda4 L_contrast`` for one batch.

    The music VAE must be frozen (:meth:`BiCoRVAE.freeze_music`): its latent ``z_a`` is the
    posterior mean, computed without gradients. The motion is aligned to ``z_a``'s length
    (§3.2), reconstructed through the motion VAE (``vae_loss``: :class:`momu.losses.vae.VAELoss`,
    ``kl_weight = lambda3``), and the posterior means of both modalities enter the rhythmic
    contrastive loss (``contrastive``: :class:`momu.losses.rhythmic_contrastive.RhythmicContrastiveLoss`,
    ``weight = lambda4``) with the kinematic amplitude of the aligned motion (Eq. 1–3).

    Args:
        motion: ``(B, T_m, J, D)`` keypoints.
        music: the music branch's input (mel ``(B, 80, T_a)`` or waveform ``(B, S)``).

    Returns:
        ``{"loss", "reconstruction", "kl", "contrast"}`` (``loss`` is what to back-propagate).
    """
    if not model.music_frozen:
        raise ValueError("stage2_loss: freeze the music VAE first (model.freeze_music()), MoMu Eq. 11")
    with torch.no_grad():
        z_music = model.encode_music(music).mode()
    aligned = model.align_motion(motion, z_music.shape[1])
    out: VAEOutput = model.motion_vae(aligned, generator=generator)
    terms = vae_loss(out.reconstruction, out.target, out.posterior, time_dim=1)  # (B, T, ...) motion
    amplitude = contrastive.amplitude(aligned, z_music.shape[1])
    contrast = contrastive(z_music, out.posterior.mean, amplitude, generator=generator)
    return {
        "loss": terms["loss"] + contrast["loss"],
        "reconstruction": terms["reconstruction"],
        "kl": terms["kl"],
        "contrast": contrast["contrast"],
    }
