"""The ``harmogan`` method's configuration (HarmoGAN §IV–V; every number of §V-B is a field).

Paper values (§V-B) and where they live:

* pretraining: 225 epochs, ``L_pretrain = 0.1 L_kl + L_mse``, Adam, batch 10, lr 1e-3 "gradually
  decreases after every 50 epochs, following a decay factor schedule [0.5, 0.2, 0.2, 0.5]" —
  :attr:`HarmoGANConfig.pretrain` and :attr:`HarmoGANConfig.pretrain_weights`;
* GAN training: 45 epochs, lr 1e-4 "divided by 2 and 5 alternately after every 5 epochs", weight decay
  1e-3 (discriminators) and 1e-4 (generator), Adam, batch 10 — :attr:`HarmoGANConfig.adversarial`;
* ``λ_kl = 1e-4``, ``λ_mse = λ_feat = λ_gan = 1e-3``, ``λ_harmo = 1`` (Eq. 20) —
  :attr:`HarmoGANConfig.weights`;
* harmony constants λ1 = 0.1, λ2 = 1, T_delay = 0.25 s, β = 2 — the ``harmony_loss`` node (and the
  metric's :class:`~momu.metrics.harmony.HarmonyConfig`);
* 15 fps, 21 joints (§V-A) — :attr:`HarmoGANConfig.fps`, the data.

A learning-rate schedule is a list of constant-rate *segments* (:func:`lr_segments`), each trained as
one engine stage that starts from the previous segment's weights; the engine's Adam (AdamW with no
decoupled decay) restarts its moment estimates at each segment boundary (a deviation from one
continuous optimiser; the engine has no step schedule). Weight decay is Adam's L2 form
(``torch.optim.Adam(weight_decay=w)`` adds ``w·θ`` to the gradient), added to the loss as
``½ w ‖θ‖²`` per network.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

from momu.config import to_container
from momu.features.audio import MfccConfig
from momu.methods.harmogan.meter import MeterConfig

__all__ = [
    "LossWeights",
    "Schedule",
    "AdversarialSchedule",
    "HarmoGANEvalConfig",
    "HarmoGANConfig",
    "lr_segments",
    "plain_node",
]


def _node(name: str, **params: Any) -> Callable[[], dict[str, Any]]:
    return lambda: {"name": name, **params}


def plain_node(node: Any) -> dict[str, Any]:
    """A component node as a plain dict (a bare name becomes ``{name: ...}``)."""
    plain = to_container(node) if not isinstance(node, (dict, str)) else node
    return {"name": plain} if isinstance(plain, str) else dict(plain)


@dataclass
class LossWeights:
    """Weights of Eq. 20 (§V-B: 1e-4, 1e-3, 1e-3, 1, 1e-3). ``kl`` and ``mse`` also weight pretraining."""

    kl: float = 1e-4
    mse: float = 1e-3
    feat: float = 1e-3
    harmo: float = 1.0
    gan: float = 1e-3


@dataclass
class Schedule:
    """An Adam schedule of constant-rate segments (§V-B pretraining: 225 epochs, lr 1e-3, ×[0.5, 0.2,
    0.2, 0.5] every 50 epochs).

    Attributes:
        epochs: total epochs over the meter units. batch_size: units per step (per process).
        lr: initial learning rate. decay_every: epochs per segment (0: one segment).
        decay_factors: the rate is multiplied by the next factor at each segment boundary.
        cycle_factors: reuse the factors cyclically (the GAN stage's "÷2 and ÷5 alternately").
        max_grad_norm: gradient clipping (0: none; the paper clips nothing).
    """

    epochs: int = 225
    batch_size: int = 10
    lr: float = 1e-3
    decay_every: int = 50
    decay_factors: list[float] = field(default_factory=lambda: [0.5, 0.2, 0.2, 0.5])
    cycle_factors: bool = False
    max_grad_norm: float = 0.0


@dataclass
class AdversarialSchedule(Schedule):
    """§V-B GAN training: 45 epochs, lr 1e-4 ÷2 and ÷5 alternately every 5 epochs, weight decay 1e-3 for
    the discriminators and 1e-4 for the generator."""

    epochs: int = 45
    lr: float = 1e-4
    decay_every: int = 5
    decay_factors: list[float] = field(default_factory=lambda: [0.5, 0.2])
    cycle_factors: bool = True
    generator_weight_decay: float = 1e-4
    discriminator_weight_decay: float = 1e-3


def lr_segments(schedule: Schedule) -> list[tuple[int, float]]:
    """``[(epochs, lr multiplier)]`` of a schedule: constant-rate segments of ``decay_every`` epochs.

    >>> lr_segments(Schedule(epochs=120, decay_every=50, decay_factors=[0.5, 0.2]))
    [(50, 1.0), (50, 0.5), (20, 0.1)]
    """
    if schedule.epochs < 1 or schedule.batch_size < 1 or schedule.lr <= 0:
        raise ValueError("a schedule needs epochs >= 1, batch_size >= 1 and lr > 0")
    every = schedule.decay_every if schedule.decay_every > 0 else schedule.epochs
    out: list[tuple[int, float]] = []
    factor, done, k = 1.0, 0, 0
    while done < schedule.epochs:
        n = min(every, schedule.epochs - done)
        out.append((n, factor))
        done += n
        factors = schedule.decay_factors
        if factors and (schedule.cycle_factors or k < len(factors)):
            factor *= float(factors[k % len(factors)])
        k += 1
    return out


@dataclass
class HarmoGANEvalConfig:
    """How a trained HarmoGAN is evaluated (not part of any stage key).

    Attributes:
        clip_seconds: evaluation clip length (6 s: the paper's Ballroom clips, §V-A).
        hop_seconds: hop between held-out windows (``None``: ``clip_seconds``, no overlap).
        static_noise_m: standard deviation (m) of the noise on the static-pose calibration row (0.1 mm).
        speed_factor: time scale of the sped-up calibration row (×1.25).
        chunk_seconds: chunk length of Fig. 11's permutation perturbation (1 s).
        slow_factor: Fig. 11's slow warp (×0.8); the fast warp is ``speed_factor``.
    """

    clip_seconds: float = 6.0
    hop_seconds: float | None = None
    static_noise_m: float = 1e-4
    speed_factor: float = 1.25
    chunk_seconds: float = 1.0
    slow_factor: float = 0.8


@dataclass
class HarmoGANConfig:
    """The ``harmogan`` method (HarmoGAN §IV, §V-B).

    Component nodes: ``generator_encoder`` (``harmogan_generator``), ``cross_modal_discriminator_encoder``
    (D_cd), ``spatiotemporal_discriminator_encoder`` (D_st), ``harmony_loss`` (``harmony``, Eq. 16) and
    ``gan_loss`` (``gan`` with the ``vanilla`` objective: Eq. 17–19; its ``weight`` is unused, λ_gan is
    :attr:`weights`). Joint and MFCC widths are set from the data.

    Attributes:
        fps: motion frame rate (15, §V-A). test_fraction: held-out tail of every dance (temporal split).
        mfcc: A_f's MFCC parameters (the paper gives none; ``frame_rate`` is ignored: A_f is resampled
            to the motion frames). meter: meter units (§IV-A). kl_temperature: τ of Eq. 13's P(·) =
            softmax of each frame's flattened 2D coordinates / τ (m).
        pretrain_weights: ``kl`` and ``mse`` of L_pretrain (0.1 and 1); weights: Eq. 20.
        pretrain, adversarial: the two schedules. evaluation: :class:`HarmoGANEvalConfig`.
    """

    generator_encoder: Any = field(default_factory=_node("harmogan_generator"))
    cross_modal_discriminator_encoder: Any = field(
        default_factory=_node("harmogan_cross_modal_discriminator")
    )
    spatiotemporal_discriminator_encoder: Any = field(
        default_factory=_node("harmogan_spatiotemporal_discriminator")
    )
    harmony_loss: Any = field(default_factory=_node("harmony"))
    gan_loss: Any = field(
        default_factory=_node("gan", objective="vanilla", adaptive_weight=False, weight=1.0)
    )
    fps: float = 15.0
    test_fraction: float = 0.2
    mfcc: MfccConfig = field(default_factory=MfccConfig)
    meter: MeterConfig = field(default_factory=MeterConfig)
    kl_temperature: float = 0.1
    stitch_frames: int = 4
    pretrain_weights: LossWeights = field(
        default_factory=lambda: LossWeights(kl=0.1, mse=1.0, feat=0.0, harmo=0.0, gan=0.0)
    )
    weights: LossWeights = field(default_factory=LossWeights)
    pretrain: Schedule = field(default_factory=Schedule)
    adversarial: AdversarialSchedule = field(default_factory=AdversarialSchedule)
    evaluation: HarmoGANEvalConfig = field(default_factory=HarmoGANEvalConfig)


def check_config(cfg: HarmoGANConfig) -> None:
    """Raise ``ValueError`` naming the first inconsistent field."""
    if cfg.fps <= 0 or cfg.kl_temperature <= 0:
        raise ValueError("method.fps and method.kl_temperature must be > 0")
    if cfg.stitch_frames < 0:
        raise ValueError(f"method.stitch_frames must be >= 0, got {cfg.stitch_frames}")
    if not 0.0 < cfg.test_fraction < 1.0:
        raise ValueError(f"method.test_fraction must be in (0, 1), got {cfg.test_fraction}")
    for name in ("pretrain_weights", "weights"):
        bad = [k for k, v in dataclasses.asdict(getattr(cfg, name)).items() if v < 0]
        if bad:
            raise ValueError(f"method.{name}: weights must be >= 0 ({', '.join(bad)})")
    if plain_node(cfg.gan_loss).get("objective", "lsgan") != "vanilla":
        raise ValueError(
            "method.gan_loss.objective must be 'vanilla' (the log-likelihood terms of Eq. 17-19)"
        )
    ev = cfg.evaluation
    if ev.clip_seconds <= 0 or ev.speed_factor <= 0 or ev.slow_factor <= 0 or ev.chunk_seconds <= 0:
        raise ValueError(
            "method.evaluation: clip_seconds, speed_factor, slow_factor, chunk_seconds must be > 0"
        )
    lr_segments(cfg.pretrain)
    lr_segments(cfg.adversarial)
