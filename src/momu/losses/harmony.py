"""HarmoGAN's harmony loss (Eq. 16) as a differentiable surrogate of the harmony metric: ``harmony``.

HarmoGAN trains its generator with ``L_harmo = −h ≈ −h_s + |M′ − N′|`` (Eq. 16), the harmony
evaluation of §III (Eq. 2–11) applied to the generated motion against the music. The paper does not
say how the discrete beats, masks and hits are differentiated; momu's surrogate replaces every hard
decision on the *motion* side by a sigmoid with a temperature, and is exactly the metric
(:mod:`momu.metrics.harmony`) when the temperatures are 0 (``tests/unit/test_losses_harmony.py``
checks ``h_s``, ``M′``, ``N′``, the hits and ``h`` against the numpy metric on hand-made and real
inputs):

* **Velocity sum** (Eq. 2): ``j_t = fps · Σ_p ‖v_t^p − v_{t−1}^p‖₂`` — differentiable as is.
* **Visual beats** (Eq. 3): candidate ``c`` (a frame with a velocity-sum value on both sides) is a
  beat with weight ``e_c = σ(−Δj_{c}Δj_{c+1} / (τ_b · mean Δj²))``; hard limit: the strict sign change
  of the metric (maxima and minima).
* **Visual saliency** (Eq. 5): ``s*_c = |j_c − p_c|`` where ``p_c`` is the velocity sum at the
  previous beat, a soft recurrence ``p_{c+1} = e_c j_c + (1 − e_c) p_c`` started at ``j_initial``
  (exactly the previous beat's value when the ``e`` are 0 or 1).
* **Visual mask** (Eq. 6): ``w_c = σ((s*_c − λ2 σ*) / (τ_m σ*))`` with ``σ*`` the ``e``-weighted
  population standard deviation of ``S*``; salient-beat weight ``u_c = e_c w_c``; ``M′ = Σ_c u_c``.
* **Hits** (Eq. 9): the audio beats are inputs (the music is not generated), so ``|ba′_i − bv_c| <
  T_delay`` is a constant indicator ``W_ic`` and ``hp_i = 1 − Π_c (1 − u_c W_ic)`` (1 iff some salient
  visual beat lies within T_delay in the hard limit).
* **Audio side** (Eq. 4, 7, 10): computed once per clip with the metric's own functions
  (:func:`audio_targets` = :func:`~momu.metrics.harmony.audio_beats` +
  :func:`~momu.metrics.harmony.salient_audio_beats`): salient beat times and max-normalised
  saliencies ``sa′``; ``h_s = Σ_i hp_i sa′_i``, ``N′`` = number of salient audio beats.

``form="paper"`` is Eq. 16's approximation ``−h_s + |M′ − N′|`` (raw counts, as written; with
``normalize=True`` divided by ``N′`` so the loss does not grow with clip length);
``form="h"`` is ``−h`` (Eq. 11, :func:`~momu.metrics.harmony.combine_harmony`). The batch loss is
the mean over items.

Using it in another method: any model whose training step produces joint positions ``(B, T, J, D)``
for a clip of known music can add ``weight · harmony_loss(motion, fps, targets)`` to its loss — e.g.
a diffusion method on the decoded ``x̂₀`` of each noisy sample (docs/papers/harmogan.md, "The
harmony loss in other methods"). :meth:`HarmonyLoss.decoded_loss` is that use
(:mod:`momu.losses.decoded`; MoMu's ``method.diffusion_losses``).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import torch
from torch import nn

from momu.losses.decoded import DecodedMotion
from momu.metrics.harmony import audio_beats, combine_harmony, salient_audio_beats
from momu.registry import LOSSES

__all__ = [
    "HarmonyLossConfig",
    "HarmonyLoss",
    "AudioTargets",
    "audio_targets",
    "pad_targets",
    "harmony_terms",
    "build_harmony_loss",
]

_FORMS = ("paper", "h")


@dataclass
class HarmonyLossConfig:
    """The ``harmony`` loss (HarmoGAN Eq. 16; metric constants of §V-B).

    Attributes:
        lambda1, lambda2, t_delay, beta, normalize_saliency: as in
            :class:`momu.metrics.harmony.HarmonyConfig` (0.1, 1, 0.25 s, 2, True).
        form: ``"paper"`` (``−h_s + |M′ − N′|``, Eq. 16) or ``"h"`` (``−h``, Eq. 11).
        normalize: divide the paper form by ``N′`` (off: Eq. 16 as written).
        beat_temperature: ``τ_b`` of the soft visual beats (0: the metric's hard beats).
        mask_temperature: ``τ_m`` of the soft visual saliency mask (0: the metric's hard mask).
    """

    lambda1: float = 0.1
    lambda2: float = 1.0
    t_delay: float = 0.25
    beta: float = 2.0
    normalize_saliency: bool = True
    form: str = "paper"
    normalize: bool = False
    beat_temperature: float = 0.1
    mask_temperature: float = 0.1

    def __post_init__(self) -> None:
        if self.form not in _FORMS:
            raise ValueError(f"harmony loss: form must be one of {_FORMS}, got {self.form!r}")
        if self.t_delay <= 0 or self.beta <= 0:
            raise ValueError(f"harmony loss: t_delay and beta must be > 0, got {self.t_delay}, {self.beta}")
        if self.beat_temperature < 0 or self.mask_temperature < 0:
            raise ValueError("harmony loss: temperatures must be >= 0 (0 = the metric's hard decisions)")


@dataclass(frozen=True)
class AudioTargets:
    """Salient audio beats of one clip: times (s, from the clip start) and normalised saliencies."""

    times: np.ndarray
    saliency: np.ndarray

    def window(self, start: float, seconds: float) -> AudioTargets:
        """The beats in ``[start, start + seconds)``, their times from ``start`` (a training window of
        a clip whose beats were found over the whole clip; saliencies keep the clip's normalisation)."""
        keep = (self.times >= start) & (self.times < start + seconds)
        return AudioTargets(self.times[keep] - start, self.saliency[keep])


def audio_targets(
    audio: np.ndarray, sr: int, *, lambda1: float = 0.1, normalize_saliency: bool = True
) -> AudioTargets:
    """The metric's salient audio beats ``B′_a`` and ``S′_a`` of a waveform (Eq. 4, 7, §III-B).

    Raises:
        EmptyBeatsError: the audio has no (salient) onset.
    """
    times, saliency = audio_beats(audio, sr)
    kept_t, kept_s = salient_audio_beats(times, saliency, lambda1, normalize_saliency)
    return AudioTargets(kept_t.astype(np.float64), kept_s.astype(np.float64))


def pad_targets(
    targets: Sequence[AudioTargets],
    device: torch.device | str | None = None,
    dtype: torch.dtype = torch.float32,
) -> tuple[torch.Tensor, torch.Tensor, torch.Tensor]:
    """A batch of targets as ``(times (B, K), saliency (B, K), mask (B, K) bool)``, zero-padded."""
    width = max([1, *(len(t.times) for t in targets)])
    times = torch.zeros(len(targets), width, dtype=dtype)
    sal = torch.zeros(len(targets), width, dtype=dtype)
    mask = torch.zeros(len(targets), width, dtype=torch.bool)
    for b, t in enumerate(targets):
        n = len(t.times)
        times[b, :n] = torch.as_tensor(t.times, dtype=dtype)
        sal[b, :n] = torch.as_tensor(t.saliency, dtype=dtype)
        mask[b, :n] = True
    return times.to(device), sal.to(device), mask.to(device)


def _step(x: torch.Tensor, temperature: float, scale: torch.Tensor) -> torch.Tensor:
    """``1[x > 0]`` at temperature 0, else ``σ(x / (temperature · scale))``."""
    if temperature == 0:
        return (x > 0).to(x.dtype)
    return torch.sigmoid(x / (temperature * scale))


def harmony_terms(
    motion: torch.Tensor,
    fps: float,
    audio_times: torch.Tensor,
    audio_saliency: torch.Tensor,
    audio_mask: torch.Tensor,
    cfg: HarmonyLossConfig | None = None,
) -> dict[str, torch.Tensor]:
    """Per-item ``h_s``, ``M′``, ``N′``, hits and ``h`` of the (soft) harmony evaluation (module docstring).

    Args:
        motion: ``(B, T, J, D)`` joint positions at ``fps``.
        audio_times, audio_saliency, audio_mask: ``(B, K)`` salient audio beats (:func:`pad_targets`).
        cfg: temperatures and constants (0 temperatures: the metric exactly).

    Returns:
        ``{"h_s", "n_visual", "n_audio", "hits", "h"}``, each ``(B,)``.
    """
    cfg = cfg or HarmonyLossConfig()
    if motion.ndim != 4:
        raise ValueError(f"harmony loss: motion must be (B, T, J, D), got shape {tuple(motion.shape)}")
    batch, frames = motion.shape[:2]
    dtype = motion.dtype
    sa = audio_saliency.to(dtype) * audio_mask.to(dtype)
    n_audio = audio_mask.to(dtype).sum(-1)
    zero = motion.new_zeros(batch)
    if frames < 4:  # no frame has velocity-sum values on both sides: no visual beat
        return {"h_s": zero, "n_visual": zero, "n_audio": n_audio, "hits": zero, "h": zero}
    j = torch.linalg.vector_norm(motion[:, 1:] - motion[:, :-1], dim=-1).sum(-1) * float(fps)  # (B, T-1)
    dj = j[:, 1:] - j[:, :-1]  # (B, T-2)
    prev, nxt = dj[:, :-1], dj[:, 1:]  # candidate c = 1..T-3 of j, at frame c + 1
    if cfg.beat_temperature == 0:
        e = (((prev > 0) & (nxt < 0)) | ((prev < 0) & (nxt > 0))).to(dtype)
    else:
        scale = dj.detach().pow(2).mean(-1, keepdim=True).clamp_min(1e-12)
        e = torch.sigmoid(-prev * nxt / (cfg.beat_temperature * scale))
    sv = j[:, 1:-1]  # (B, C) velocity sum at each candidate
    previous = j[:, 0]
    star = []
    for c in range(sv.shape[1]):  # Eq. 5 with the previous (soft) beat
        star.append((sv[:, c] - previous).abs())
        previous = e[:, c] * sv[:, c] + (1 - e[:, c]) * previous
    s_star = torch.stack(star, dim=1)  # (B, C)
    weight = e.sum(-1, keepdim=True)
    safe = weight.clamp_min(1e-12)
    mean = (e * s_star).sum(-1, keepdim=True) / safe
    sigma = (
        (e * (s_star - mean) ** 2).sum(-1, keepdim=True) / safe + 1e-24
    ).sqrt()  # ε: finite gradient at 0
    w = _step(s_star - cfg.lambda2 * sigma, cfg.mask_temperature, sigma.detach().clamp_min(1e-12))
    u = e * w  # (B, C) salient visual beat weights
    n_visual = u.sum(-1)
    beat_times = torch.arange(2, frames - 1, device=motion.device, dtype=dtype) / float(fps)  # (C,)
    near = (audio_times.to(dtype)[:, :, None] - beat_times[None, None, :]).abs() < cfg.t_delay  # (B, K, C)
    miss = 1 - u[:, None, :] * near.to(dtype)
    hp = (1 - miss.prod(-1)) * audio_mask.to(dtype)  # (B, K)
    h_s = (hp * sa).sum(-1)
    hits = hp.sum(-1)
    h = combine_harmony(h_s, n_audio, n_visual, cfg.beta)
    return {"h_s": h_s, "n_visual": n_visual, "n_audio": n_audio, "hits": hits, "h": h}


class HarmonyLoss(nn.Module):
    """``L_harmo`` (HarmoGAN Eq. 16) of a batch; see the module docstring."""

    def __init__(self, cfg: HarmonyLossConfig | None = None) -> None:
        super().__init__()
        self.cfg = cfg or HarmonyLossConfig()

    def forward(
        self,
        motion: torch.Tensor,
        fps: float,
        audio_times: torch.Tensor,
        audio_saliency: torch.Tensor,
        audio_mask: torch.Tensor,
    ) -> torch.Tensor:
        """Mean over the batch of the per-item loss (``form``, ``normalize``)."""
        return self.per_item(motion, fps, audio_times, audio_saliency, audio_mask).mean()

    def per_item(
        self,
        motion: torch.Tensor,
        fps: float,
        audio_times: torch.Tensor,
        audio_saliency: torch.Tensor,
        audio_mask: torch.Tensor,
    ) -> torch.Tensor:
        """The loss of each item ``(B,)`` (``form``, ``normalize``)."""
        t = harmony_terms(motion, fps, audio_times, audio_saliency, audio_mask, self.cfg)
        if self.cfg.form == "h":
            return -t["h"]
        loss = -t["h_s"] + (t["n_visual"] - t["n_audio"]).abs()
        if self.cfg.normalize:
            loss = loss / t["n_audio"].clamp_min(1.0)
        return loss

    # ------------------------------------------------------------ on another model's decoded x̂₀
    schedules_itself = False
    """:class:`~momu.losses.decoded.DecodedMotionLoss`: the caller weights the value by ᾱ_t."""
    needs_music_beats = True

    def decoded_loss(self, d: DecodedMotion) -> tuple[torch.Tensor, dict[str, torch.Tensor]]:
        """The per-item loss of decoded joint positions against each item's salient music beats
        (:mod:`momu.losses.decoded`; ``d.music_beats`` from :func:`audio_targets` of the item's
        music, cut to its frames by :meth:`AudioTargets.window`)."""
        if d.music_beats is None:
            raise ValueError("harmony: the decoded batch carries no music beats (music_beats)")
        times, saliency, mask = d.music_beats
        if d.mask is not None:  # beats past an item's last valid frame are not its music
            frames = d.mask.to(times.dtype).sum(dim=1, keepdim=True)
            mask = mask & (times < frames / float(d.fps))
        value = self.per_item(d.pred, d.fps, times, saliency, mask)
        return value, {"harmony": value.detach().mean()}


@LOSSES.register("harmony", config=HarmonyLossConfig)
def build_harmony_loss(cfg: HarmonyLossConfig) -> HarmonyLoss:
    """Registry factory: HarmoGAN's harmony loss (Eq. 16), a soft surrogate of the ``harmony`` metric."""
    return HarmonyLoss(cfg)
