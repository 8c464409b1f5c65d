"""``harmogan``: the HarmoGAN method (HarmoGAN §IV–V) assembled from registered parts.

Training (:meth:`HarmoGAN.fit`, every segment through :meth:`momu.engine.context.RunContext.stage`):

1. **Pretraining** of G on the meter units of the training parts with ``0.1 L_kl + L_mse``
   (:class:`~momu.methods.harmogan.stages.PretrainStage`), one engine stage per constant-rate
   segment of the schedule (§V-B: lr 1e-3, ×[0.5, 0.2, 0.2, 0.5] every 50 of 225 epochs).
2. **Adversarial training** of G with Eq. 20 and of D_cd and D_st with Eq. 17–18
   (:class:`~momu.methods.harmogan.stages.AdversarialStage`), starting from the pretrained G (§V-B:
   lr 1e-4 ÷2 and ÷5 alternately every 5 of 45 epochs).

Stage keys hold everything that determines a segment's weights (data config, fps, split, MFCC and
meter settings, part configs, loss weights, schedule, seed, the previous segment's key), so rows of a
table that differ only in Eq. 20's weights share the pretraining, and tables that share rows share
everything (``<out>/harmogan_shared``).
"""

from __future__ import annotations

import dataclasses
import logging
from collections.abc import Callable, Mapping, Sequence
from typing import Any

import numpy as np
from torch import nn

from momu.config import build_component
from momu.engine.context import RunContext, stage_key_hash
from momu.engine.trainer import TrainConfig, steps_per_epoch
from momu.losses.gan import GANLoss
from momu.losses.harmony import HarmonyLoss
from momu.methods.harmogan.config import HarmoGANConfig, Schedule, check_config, lr_segments, plain_node
from momu.methods.harmogan.data import Dance, MeterUnitDataset, MfccStats, collate_units
from momu.methods.harmogan.model import HarmoGANModel
from momu.methods.harmogan.stages import AdversarialStage, PretrainStage, stage_step
from momu.registry import METHODS

__all__ = ["HarmoGAN", "build_harmogan"]

log = logging.getLogger(__name__)


class HarmoGAN:
    """The registered ``harmogan`` method: builds the parts and trains them through a run context."""

    def __init__(self, cfg: HarmoGANConfig) -> None:
        check_config(cfg)
        self.cfg = cfg

    # ---------------------------------------------------------------- parts
    def _node(self, node: Any, joints: int, audio: bool = True) -> dict[str, Any]:
        plain = plain_node(node)
        plain["num_joints"] = int(joints)
        if audio:
            plain["audio_channels"] = int(self.cfg.mfcc.n_mfcc)
        return plain

    def nodes(self, joints: int) -> dict[str, dict[str, Any]]:
        """The part nodes with the data's widths."""
        c = self.cfg
        return {
            "generator": self._node(c.generator_encoder, joints),
            "cross_modal": self._node(c.cross_modal_discriminator_encoder, joints),
            "spatiotemporal": self._node(c.spatiotemporal_discriminator_encoder, joints, audio=False),
        }

    def harmony_loss(self) -> HarmonyLoss:
        loss = build_component(self.cfg.harmony_loss, "losses")
        if not isinstance(loss, HarmonyLoss):
            raise ValueError(f"method.harmony_loss: expected the 'harmony' loss, got {type(loss).__name__}")
        return loss

    # ---------------------------------------------------------------- stage keys
    def _common(self, data_key: Mapping[str, Any], joints: int) -> dict[str, Any]:
        c = self.cfg
        return {
            "data": dict(data_key),
            "fps": c.fps,
            "test_fraction": c.test_fraction,
            "mfcc": dataclasses.asdict(c.mfcc),
            "meter": dataclasses.asdict(c.meter),
            "kl_temperature": c.kl_temperature,
            "generator": self.nodes(joints)["generator"],
        }

    def _segments(self, schedule: Schedule, units: int, processes: int, seed: int) -> list[TrainConfig]:
        per_epoch = steps_per_epoch(units, TrainConfig(batch_size=schedule.batch_size), processes)
        return [
            TrainConfig(
                steps=epochs * per_epoch,
                batch_size=schedule.batch_size,
                lr=schedule.lr * factor,
                weight_decay=0.0,
                max_grad_norm=schedule.max_grad_norm,
                seed=int(seed) * 1000 + i,  # each segment its own data order
                log_every=max(1, per_epoch),
            )
            for i, (epochs, factor) in enumerate(lr_segments(schedule))
        ]

    def stage_keys(
        self, data_key: Mapping[str, Any], joints: int, units: int, processes: int, seed: int
    ) -> tuple[list[dict[str, Any]], list[dict[str, Any]]]:
        """Keys of the pretraining and adversarial segments, in training order."""
        c = self.cfg
        common = self._common(data_key, joints)
        pre, adv = [], []
        after: str | None = None
        for i, tc in enumerate(self._segments(c.pretrain, units, processes, seed)):
            key = {
                "stage": "harmogan_pretrain",
                "segment": i,
                "after": after,
                **common,
                "weights": dataclasses.asdict(c.pretrain_weights),
                "train": dataclasses.asdict(tc),
                "seed": seed,
            }
            pre.append(key)
            after = stage_key_hash(key)
        nodes = self.nodes(joints)
        for i, tc in enumerate(self._segments(c.adversarial, units, processes, seed)):
            key = {
                "stage": "harmogan_adversarial",
                "segment": i,
                "after": after,
                **common,
                "cross_modal": nodes["cross_modal"],
                "spatiotemporal": nodes["spatiotemporal"],
                "harmony_loss": plain_node(c.harmony_loss) if c.weights.harmo > 0 else None,
                "gan_loss": plain_node(c.gan_loss),
                "weights": dataclasses.asdict(c.weights),
                "weight_decay": [
                    c.adversarial.generator_weight_decay,
                    c.adversarial.discriminator_weight_decay,
                ],
                "train": dataclasses.asdict(tc),
                "seed": seed,
            }
            adv.append(key)
            after = stage_key_hash(key)
        return pre, adv

    # ---------------------------------------------------------------- training
    def fit(
        self,
        ctx: RunContext,
        dances: Sequence[Dance],
        units: MeterUnitDataset,
        stats: MfccStats,
        data_key: Mapping[str, Any],
        seed: int,
    ) -> tuple[HarmoGANModel, str]:
        """Train (or reuse) both stages on the meter units of the training parts of ``dances``.

        Returns the model and the hash of its last stage key (names its model folder).
        """
        c = self.cfg
        joints = int(dances[0].motion.shape[1])
        nodes = self.nodes(joints)
        pre_keys, adv_keys = self.stage_keys(
            data_key, joints, len(units), ctx.accelerator.num_processes, seed
        )
        pre_cfgs = self._segments(c.pretrain, len(units), ctx.accelerator.num_processes, seed)
        adv_cfgs = self._segments(c.adversarial, len(units), ctx.accelerator.num_processes, seed)
        log.info("harmogan: %d meter units of %.1f s; seed %d", len(units), c.meter.unit_seconds, seed)

        # The first segment of each stage builds its new modules under its own seed
        # (RunContext.stage); later segments continue the same modules.
        def build_pretrain() -> PretrainStage:
            generator = build_component(nodes["generator"], "encoders")
            return PretrainStage(generator, c.pretrain_weights, c.kl_temperature)

        pretrain: nn.Module | Callable[[], nn.Module] = build_pretrain
        for i, (key, tc) in enumerate(zip(pre_keys, pre_cfgs)):
            pretrain = ctx.stage(
                f"harmogan_pretrain_{i}", key, pretrain, units, stage_step, tc, collate_units
            )
        assert isinstance(pretrain, PretrainStage)
        generator: nn.Module = pretrain.generator

        def build_adversarial() -> AdversarialStage:
            gan = build_component(c.gan_loss, "losses")
            if not isinstance(gan, GANLoss):
                raise ValueError(f"method.gan_loss: expected the 'gan' loss, got {type(gan).__name__}")
            return AdversarialStage(
                generator,
                build_component(nodes["cross_modal"], "encoders"),
                build_component(nodes["spatiotemporal"], "encoders"),
                gan_loss=gan,
                harmony_loss=self.harmony_loss(),
                weights=c.weights,
                kl_temperature=c.kl_temperature,
                fps=c.fps,
                generator_weight_decay=c.adversarial.generator_weight_decay,
                discriminator_weight_decay=c.adversarial.discriminator_weight_decay,
            )

        stage: nn.Module | Callable[[], nn.Module] = build_adversarial
        for i, (key, tc) in enumerate(zip(adv_keys, adv_cfgs)):
            stage = ctx.stage(f"harmogan_adversarial_{i}", key, stage, units, stage_step, tc, collate_units)
        mean_pose = np.concatenate([d.motion[: d.split_frame] for d in dances]).mean(axis=0)
        model = HarmoGANModel(c, generator.eval(), stats, mean_pose)
        return model, stage_key_hash(adv_keys[-1])


@METHODS.register("harmogan", config=HarmoGANConfig)
def build_harmogan(cfg: HarmoGANConfig, **deps: object) -> HarmoGAN:
    """Factory of the ``harmogan`` method (HarmoGAN §IV–V)."""
    return HarmoGAN(cfg)
