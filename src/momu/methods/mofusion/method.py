"""``mofusion``: MoFusion (CVPR 2023) assembled from registered parts and trained by the shared engine.

One stage (:class:`~momu.methods.mofusion.stages.MoFusionStage`) through
:meth:`momu.engine.context.RunContext.stage`: the ε-backbone over MoFusion's §3 pose vector at
``fps`` = 20, conditioned on the §3.3 mel (``task: music``) or on text-encoder tokens
(``task: text``), trained with the ``scheduled_kinematic`` loss (Eq. 4–7). The stage key holds
everything that sets the weights (task, data config, rate, window, backbone, loss, scheduler, text
encoder with its vocabulary, training settings, seed), so rows that differ only in how they are
evaluated (generation length, forecasting) share one trained model (supp. Tables 1–2).

Derived, not configured: the backbone's ``in_channels`` (3J from the data's skeleton) and
``cond_channels`` (80 mel bands, or the text encoder's width), when the backbone's config has those
fields; the loss's ``skeleton``; a ``text_transformer``'s vocabulary (from the training captions).
"""

from __future__ import annotations

import dataclasses
import logging
from collections.abc import Mapping
from typing import Any

from momu.config import build_component, instantiate_config, to_container
from momu.encoders.text_transformer import WordTokenizer
from momu.engine.context import RunContext
from momu.features.mofusion_pose import pose_channels
from momu.features.skeletons import get_skeleton
from momu.methods.mofusion.config import MoFusionConfig, check_config
from momu.methods.mofusion.data import (
    MoFusionNormalizers,
    MusicWindows,
    TextItems,
    clip_mel,
    clip_pose,
    collate_music,
    collate_text,
    crop,
    split_indices,
)
from momu.methods.mofusion.model import MoFusionModel
from momu.methods.mofusion.stages import MoFusionStage, stage_step
from momu.registry import BACKBONES, ENCODERS, LOSSES, METHODS

__all__ = ["MoFusion", "build_mofusion", "node_with"]

log = logging.getLogger(__name__)


def _plain(node: Any) -> dict[str, Any]:
    plain = to_container(node) if not isinstance(node, (dict, str)) else node
    return {"name": plain} if isinstance(plain, str) else dict(plain)


def node_with(node: Any, registry: Any, **values: Any) -> dict[str, Any]:
    """``node`` with ``values`` set for the keys its part's config dataclass has (others untouched)."""
    plain = _plain(node)
    entry = registry.get(plain["name"])
    fields = {f.name for f in dataclasses.fields(entry.config)} if entry.config is not None else set()
    plain.update({k: v for k, v in values.items() if k in fields})
    return plain


def text_width(node: Mapping[str, Any]) -> int:
    """The token width of the text encoder ``node`` names: its config's ``width``, else a built one's."""
    entry = ENCODERS.get(str(node["name"]))
    if entry.config is not None:
        cfg = instantiate_config(entry, {k: v for k, v in node.items() if k != "name"})
        if hasattr(cfg, "width"):
            return int(cfg.width)
    return int(build_component(dict(node), "encoders").width)


class MoFusion:
    """The registered ``mofusion`` method: builds the parts and trains them through a run context."""

    def __init__(self, cfg: MoFusionConfig) -> None:
        check_config(cfg)
        self.cfg = cfg

    # ---------------------------------------------------------------- data
    def train_clips(self, dataset: Any) -> list[Any]:
        idx = split_indices(dataset, "train", self.cfg.task)
        if not idx:
            need = "audio" if self.cfg.task == "music" else "text"
            raise ValueError(f"the dataset has no 'train' clips with motion and {need}")
        return [dataset[i] for i in idx]

    def text_encoder_node(self, clips: list[Any]) -> dict[str, Any] | None:
        """The text encoder node; a ``text_transformer`` without a vocabulary gets the captions'."""
        if self.cfg.task != "text":
            return None
        node = _plain(self.cfg.text_encoder)
        if node["name"] == "text_transformer" and len(node.get("vocab") or []) <= 2:
            max_tokens = int(node.get("max_tokens", 32))
            node["vocab"] = WordTokenizer.from_texts((t for c in clips for t in c.text), max_tokens).vocab
        return node

    def nodes(self, skeleton: str, text_node: dict[str, Any] | None, text_width: int) -> tuple[dict, dict]:
        """The backbone and loss nodes with their derived fields."""
        channels = pose_channels(get_skeleton(skeleton).num_joints)
        cond = int(self.cfg.mel_bins) if self.cfg.task == "music" else int(text_width)
        backbone = node_with(self.cfg.backbone, BACKBONES, in_channels=channels, cond_channels=cond)
        loss = node_with(self.cfg.loss, LOSSES, skeleton=skeleton)
        return backbone, loss

    # ---------------------------------------------------------------- stage key
    def stage_key(
        self, data_key: Mapping[str, Any], seed: int, backbone: dict, loss: dict, text: dict | None
    ) -> dict[str, Any]:
        c = self.cfg
        return {
            "stage": "mofusion",
            "task": c.task,
            "data": dict(data_key),
            "fps": c.fps,
            "window_seconds": c.window_seconds,
            "window_hop_seconds": c.window_hop_seconds,
            "mel_bins": c.mel_bins,
            "backbone": backbone,
            "loss": loss,
            "scheduler": _plain(c.scheduler),
            "text_encoder": text,
            "train_text": c.train_text if text else None,
            "train": dataclasses.asdict(c.train),
            "seed": seed,
        }

    def prepare(self, dataset: Any) -> tuple[list[Any], str, dict | None]:
        """Training clips (3D, one skeleton), the skeleton name and the text encoder node."""
        clips = self.train_clips(dataset)
        skeleton = str(clips[0].skeleton or "")
        if not skeleton or any(c.skeleton != skeleton for c in clips):
            raise ValueError("mofusion: every training clip needs the same named 3D skeleton")
        return clips, skeleton, self.text_encoder_node(clips)

    # ---------------------------------------------------------------- training
    def fit(
        self, ctx: RunContext, dataset: Any, data_key: Mapping[str, Any], seed: int
    ) -> tuple[MoFusionModel, str]:
        """Train (or reuse) the stage on the ``train`` split; returns the model and its stage folder name."""
        c = self.cfg
        clips, skeleton, text_node = self.prepare(dataset)
        root = get_skeleton(skeleton).root
        if c.task == "text":
            clips = [
                crop(cl, 0.0, min(c.window_seconds, cl.duration)) if cl.duration > c.window_seconds else cl
                for cl in clips
            ]
        poses = [clip_pose(cl, c.fps, root) for cl in clips]
        mels = [clip_mel(cl) for cl in clips] if c.task == "music" else None
        norms = MoFusionNormalizers.fit(poses, mels)
        width = text_width(text_node) if text_node is not None else 0
        backbone_node, loss_node = self.nodes(skeleton, text_node, width)
        key = self.stage_key(data_key, seed, backbone_node, loss_node, text_node)

        def build() -> MoFusionStage:  # under the stage's own seed (RunContext.stage)
            text_encoder = None
            if text_node is not None:
                text_encoder = build_component(text_node, "encoders")
                if not c.train_text:
                    text_encoder.requires_grad_(False)
            scheduler = build_component(c.scheduler, "schedulers")
            loss = build_component(loss_node, "losses", scheduler=scheduler)
            loss.set_statistics(norms.pose.mean, norms.pose.std)
            return MoFusionStage(build_component(backbone_node, "backbones"), loss, text_encoder)

        def data() -> Any:
            if c.task == "music":
                windows = MusicWindows(clips, norms, c.fps, c.window_seconds, c.window_hop_seconds, root)
                log.info(
                    "mofusion: %d training items: windows of %.1f s and %d whole clips shorter than that",
                    len(windows), c.window_seconds, windows.whole_clips,
                )  # fmt: skip
                return windows
            return TextItems(clips, norms, c.fps, c.window_seconds, root)

        collate = collate_text if c.task == "text" else collate_music
        train_cfg = dataclasses.replace(c.train, seed=seed)
        trained = ctx.stage("mofusion", key, build, data, stage_step, train_cfg, collate)
        trained = trained.to("cpu").eval()
        assert isinstance(trained, MoFusionStage)
        model = MoFusionModel(
            cfg=c,
            backbone=trained.backbone,
            norms=norms,
            skeleton=skeleton,
            backbone_node=backbone_node,
            text_encoder=trained.text_encoder,
            text_encoder_node=text_node,
        )
        return model, ctx.stage_folder_name("mofusion", key, train_cfg)


@METHODS.register("mofusion", config=MoFusionConfig)
def build_mofusion(cfg: MoFusionConfig, **deps: Any) -> MoFusion:
    """Registry factory: the MoFusion method (``fit`` it through a run context)."""
    return MoFusion(cfg)
