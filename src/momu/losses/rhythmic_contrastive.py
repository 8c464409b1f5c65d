"""Rhythmic contrastive loss of BiCoR-VAE (MoMu §3.2, Eq. 1-4; lambda4 = 1 in Eq. 11).

For each motion-music latent pair ``(z_m, z_a)`` (both ``(T_z, d)``, aligned by §3.2's frame
dropping) and the kinematic amplitude ``Q`` of the motion (Eq. 1-2, at the latent rate):

1. sample ``N_T`` clips ``[r_s, r_e)`` of ``clip_length`` latent frames (distinct start frames);
2. give each clip its maximum amplitude ``Q(r_s:r_e) = max(Q(r_s) .. Q(r_e))`` (Eq. 3) and divide
   the ``N_T`` clips into ``N_C`` categories by that value (``binning``);
3. draw ``N_S`` clips from ``N_S`` distinct categories (fewer when fewer categories are occupied);
4. max-pool each clip over time, ``c_a = P_max(z_a^{r_s:r_e})``, ``c_m = P_max(z_m^{r_s:r_e})`` (Eq. 3);
5. symmetric InfoNCE with temperature ``tau`` over cosine similarities (Eq. 4): the music and
   motion embeddings of the same clip are positives, every other clip of the pair is a negative.

The per-pair losses are averaged over the batch (or, with ``cross_pair_negatives``, the clips of
all pairs form one InfoNCE problem). Paper ambiguities and the choices made here: ``N_T``, ``N_C``,
``N_S``, the clip length and ``tau`` are not given by MoMu (defaults below; all config fields);
"divide into N_C categories" is read as equal-count (quantile) bins of the clip amplitudes, so that
every category is occupied and the ``N_S`` draws are from genuinely different rhythmic levels
(``binning="uniform"``: equal-width bins of [0, 1]); ``sim`` is the cosine similarity (as in CLIP).
"""

from __future__ import annotations

from dataclasses import dataclass

import torch
import torch.nn.functional as F
from torch import nn

from momu.registry import LOSSES

__all__ = [
    "RhythmicContrastiveConfig",
    "RhythmicContrastiveLoss",
    "build_rhythmic_contrastive_loss",
    "symmetric_info_nce",
    "clip_max_pool",
    "amplitude_categories",
    "sample_rhythmic_clips",
    "latent_kinematic_amplitude",
]

_BINNINGS = ("quantile", "uniform")


@dataclass
class RhythmicContrastiveConfig:
    """Attributes:
    weight: lambda4 of MoMu Eq. 11 (1.0).
    temperature: ``tau`` of Eq. 4 (not given by MoMu; 0.07, CLIP's initial value).
    num_clips: ``N_T``, clips sampled per pair.
    num_categories: ``N_C``, kinematic-amplitude categories.
    num_samples: ``N_S``, clips drawn from distinct categories (``<= num_categories``).
    clip_length: clip length in latent frames (8 = 0.26 s at the paper's 31.25 Hz latent rate).
    binning: ``"quantile"`` (equal-count categories) or ``"uniform"`` (equal-width on [0, 1]).
    cross_pair_negatives: also use the other pairs' clips of the batch as negatives.
    amplitude_bins: ``K``, angular bins of the directogram (Eq. 1).
    amplitude_window: Eq. 1 indicator, ``"paper"`` or ``"hard"`` (see :mod:`momu.features.kinematics`).
    """

    weight: float = 1.0
    temperature: float = 0.07
    num_clips: int = 32
    num_categories: int = 8
    num_samples: int = 8
    clip_length: int = 8
    binning: str = "quantile"
    cross_pair_negatives: bool = False
    amplitude_bins: int = 8
    amplitude_window: str = "paper"


def symmetric_info_nce(music: torch.Tensor, motion: torch.Tensor, temperature: float = 0.07) -> torch.Tensor:
    """MoMu Eq. 4: ``-½ log softmax_j(sim(c_a^i, c_m^j)/tau)[i] - ½ log softmax_j(sim(c_a^j, c_m^i)/tau)[i]``,
    averaged over ``i``.

    Args:
        music, motion: ``(N, d)`` clip embeddings; row ``i`` of each is the same clip (positive pair).
        temperature: ``tau > 0``.

    Returns:
        A scalar ``>= 0``; ``log N`` when all similarities are equal; unchanged by applying the same
        permutation to the rows of both inputs. ``sim`` is the cosine similarity.
    """
    if music.ndim != 2 or music.shape != motion.shape:
        raise ValueError(
            f"music and motion must both be (N, d), got {tuple(music.shape)} and {tuple(motion.shape)}"
        )
    if music.shape[0] < 1:
        raise ValueError("symmetric_info_nce needs at least one pair")
    if temperature <= 0:
        raise ValueError(f"temperature must be > 0, got {temperature}")
    logits = F.normalize(music, dim=-1) @ F.normalize(motion, dim=-1).T / temperature  # (N, N)
    labels = torch.arange(music.shape[0], device=music.device)
    return 0.5 * (F.cross_entropy(logits, labels) + F.cross_entropy(logits.T, labels))


def clip_max_pool(z: torch.Tensor, starts: torch.Tensor, length: int) -> torch.Tensor:
    """MoMu Eq. 3 ``P_max``: ``(T, d)`` latents, ``(n,)`` start frames -> ``(n, d)`` max over each clip."""
    if z.ndim != 2:
        raise ValueError(f"z must be (T, d), got {tuple(z.shape)}")
    if length < 1 or (starts.numel() and int(starts.max()) + length > z.shape[0]) or (starts < 0).any():
        raise ValueError(f"clips [start, start + {length}) must lie inside the {z.shape[0]} latent frames")
    index = starts.to(z.device)[:, None] + torch.arange(length, device=z.device)  # (n, L)
    return z[index].amax(dim=1)


def amplitude_categories(
    values: torch.Tensor, num_categories: int, binning: str = "quantile"
) -> torch.Tensor:
    """``(n,)`` clip amplitudes -> ``(n,)`` category ids in ``[0, num_categories)``.

    ``"quantile"``: by rank, ``rank * N_C // n`` (equal-count, ties broken by position);
    ``"uniform"``: ``floor(value * N_C)`` clamped to ``N_C - 1`` (values in [0, 1]).
    """
    if num_categories < 1:
        raise ValueError(f"num_categories must be >= 1, got {num_categories}")
    if binning not in _BINNINGS:
        raise ValueError(f"binning must be one of {_BINNINGS}, got {binning!r}")
    n = values.shape[0]
    if binning == "uniform":
        return (values * num_categories).floor().long().clamp(0, num_categories - 1)
    order = torch.argsort(values, stable=True)
    cats = torch.empty(n, dtype=torch.long, device=values.device)
    cats[order] = torch.arange(n, device=values.device) * num_categories // max(n, 1)
    return cats


def sample_rhythmic_clips(
    amplitude: torch.Tensor,
    cfg: RhythmicContrastiveConfig,
    *,
    valid_length: int | None = None,
    generator: torch.Generator | None = None,
) -> tuple[torch.Tensor, int]:
    """Steps 1-3 of the module docstring for one pair: start frames of the ``N_S`` chosen clips.

    Args:
        amplitude: ``(T_z,)`` kinematic amplitude at the latent rate.
        valid_length: latent frames that are real (default all); clips stay inside them.

    Returns:
        ``(starts, length)``: ``(n,)`` long start frames (``n <= N_S``, CPU) and the clip length used
        (``min(clip_length, valid_length)``).
    """
    total = int(amplitude.shape[0]) if valid_length is None else int(valid_length)
    if total < 1:
        raise ValueError("a pair needs at least one valid latent frame")
    length = min(cfg.clip_length, total)
    positions = total - length + 1
    amp = amplitude[:total].detach().float().cpu()
    n_t = min(cfg.num_clips, positions)
    starts = torch.randperm(positions, generator=generator)[:n_t]  # distinct start frames
    clip_amp = clip_max_pool(amp[:, None], starts, length)[:, 0]  # Eq. 3: Q(r_s:r_e)
    cats = amplitude_categories(clip_amp, cfg.num_categories, cfg.binning)
    occupied = torch.unique(cats)
    chosen = occupied[torch.randperm(occupied.numel(), generator=generator)[: cfg.num_samples]]
    picks = []
    for c in chosen.tolist():
        members = starts[cats == c]
        picks.append(members[int(torch.randint(members.numel(), (1,), generator=generator))])
    return torch.stack(picks), length


def latent_kinematic_amplitude(
    motion: torch.Tensor,
    num_latent_frames: int,
    *,
    bins: int = 8,
    window: str = "paper",
) -> torch.Tensor:
    """Kinematic amplitude ``Q`` (MoMu Eq. 1-2) of ``(B, T, J, D)`` motion at the latent rate: ``(B, T_z)``.

    ``Q`` is computed per motion frame with :func:`momu.features.kinematics.kinematic_amplitude_torch`
    (normalised to [0, 1] per sequence; frame 0 gets 0), then max-pooled over the
    ``T / T_z`` motion frames of each latent frame (the same max as Eq. 3). Frames beyond
    ``T_z * (T // T_z)`` are dropped; no gradient flows (the categories are discrete).
    """
    from momu.features.kinematics import kinematic_amplitude_torch

    if motion.ndim != 4:
        raise ValueError(f"motion must be (B, T, J, D), got {tuple(motion.shape)}")
    b, t = motion.shape[:2]
    if num_latent_frames < 1:
        raise ValueError(f"num_latent_frames must be >= 1, got {num_latent_frames}")
    if t < num_latent_frames:
        raise ValueError(f"motion has {t} frames, fewer than the {num_latent_frames} latent frames")
    with torch.no_grad():
        if t < 2:
            q = torch.zeros(b, t, device=motion.device)
        else:
            q = kinematic_amplitude_torch(motion.detach().float(), bins, window=window)  # (B, T-1)
            q = torch.cat([torch.zeros_like(q[:, :1]), q], dim=1)  # Q of frame 0 is 0
        per = t // num_latent_frames
        return q[:, : per * num_latent_frames].reshape(b, num_latent_frames, per).amax(dim=-1)


class RhythmicContrastiveLoss(nn.Module):
    """``lambda4 * L_contrast`` of MoMu Eq. 4 / Eq. 11 over a batch of aligned latent pairs."""

    def __init__(self, cfg: RhythmicContrastiveConfig | None = None) -> None:
        super().__init__()
        cfg = cfg or RhythmicContrastiveConfig()
        for name in ("num_clips", "num_categories", "num_samples", "clip_length", "amplitude_bins"):
            if getattr(cfg, name) < 1:
                raise ValueError(f"rhythmic_contrastive.{name} must be >= 1, got {getattr(cfg, name)}")
        if cfg.num_samples > cfg.num_categories:
            raise ValueError(
                f"rhythmic_contrastive.num_samples ({cfg.num_samples}) must be <= num_categories "
                f"({cfg.num_categories}): clips are drawn from distinct categories"
            )
        if cfg.temperature <= 0 or cfg.weight < 0:
            raise ValueError("rhythmic_contrastive: temperature must be > 0 and weight >= 0")
        if cfg.binning not in _BINNINGS:
            raise ValueError(f"rhythmic_contrastive.binning must be one of {_BINNINGS}, got {cfg.binning!r}")
        self.cfg = cfg

    def amplitude(self, motion: torch.Tensor, num_latent_frames: int) -> torch.Tensor:
        """``(B, T_z)`` kinematic amplitude of aligned motion ``(B, T, J, D)`` (at the latent rate)."""
        return latent_kinematic_amplitude(
            motion, num_latent_frames, bins=self.cfg.amplitude_bins, window=self.cfg.amplitude_window
        )

    def forward(
        self,
        z_music: torch.Tensor,
        z_motion: torch.Tensor,
        amplitude: torch.Tensor,
        *,
        mask: torch.Tensor | None = None,
        generator: torch.Generator | None = None,
    ) -> dict[str, torch.Tensor]:
        """``{"loss": weight * L, "contrast": L}`` for latents ``(B, T_z, d)`` and amplitude ``(B, T_z)``.

        ``mask``: optional ``(B, T_z)`` bool of valid latent frames (a prefix per item).
        """
        if z_music.ndim != 3 or z_music.shape != z_motion.shape:
            raise ValueError(
                f"z_music and z_motion must both be (B, T_z, d), got {tuple(z_music.shape)} and "
                f"{tuple(z_motion.shape)}"
            )
        if amplitude.shape != z_music.shape[:2]:
            raise ValueError(
                f"amplitude must be (B, T_z) = {tuple(z_music.shape[:2])}, got {tuple(amplitude.shape)}"
            )
        lengths = mask.sum(dim=1).tolist() if mask is not None else [z_music.shape[1]] * z_music.shape[0]
        music_clips, motion_clips, losses = [], [], []
        for i in range(z_music.shape[0]):
            starts, length = sample_rhythmic_clips(
                amplitude[i], self.cfg, valid_length=int(lengths[i]), generator=generator
            )
            c_a = clip_max_pool(z_music[i], starts, length)
            c_m = clip_max_pool(z_motion[i], starts, length)
            if self.cfg.cross_pair_negatives:
                music_clips.append(c_a)
                motion_clips.append(c_m)
            else:
                losses.append(symmetric_info_nce(c_a, c_m, self.cfg.temperature))
        if self.cfg.cross_pair_negatives:
            contrast = symmetric_info_nce(
                torch.cat(music_clips), torch.cat(motion_clips), self.cfg.temperature
            )
        else:
            contrast = torch.stack(losses).mean()
        return {"loss": self.cfg.weight * contrast, "contrast": contrast}


@LOSSES.register("rhythmic_contrastive", config=RhythmicContrastiveConfig)
def build_rhythmic_contrastive_loss(cfg: RhythmicContrastiveConfig) -> RhythmicContrastiveLoss:
    """Registry factory: MoMu's rhythmic contrastive loss (Eq. 1-4)."""
    return RhythmicContrastiveLoss(cfg)
