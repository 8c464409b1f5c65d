"""A trained MoMu-Diffusion (:class:`MoMuModel`): generation in every direction, save and load."""

from __future__ import annotations

import dataclasses
import logging
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np
import torch
from omegaconf import OmegaConf
from torch import nn

from momu.config import build_component
from momu.encoders.bicor_vae import BiCoRVAE
from momu.features.bones import correct_bone_lengths
from momu.features.preprocess import Normalizer
from momu.features.skeletons import get_skeleton
from momu.io import read_json, write_json
from momu.methods.momu.conditions import Conditions
from momu.methods.momu.config import MoMuConfig, _plain, vocoder_node
from momu.methods.momu.data import MoMuNormalizers, Rates
from momu.parts_io import load_part, save_part
from momu.samplers.base import lengths_to_mask

__all__ = ["MoMuModel", "sample_items"]

log = logging.getLogger(__name__)

FORMAT_VERSION = 1


def _item_noise(length: int, channels: int, seed: int) -> tuple[torch.Tensor, torch.Generator]:
    """An item's initial noise ``(length, channels)`` and its generator, which then draws the item's
    stochastic sampling steps: a sample depends on its seed only, not on the batch, the process or
    what ran before it."""
    gen = torch.Generator().manual_seed(int(seed))
    return torch.randn(length, channels, generator=gen), gen


def _pad(items: Sequence[torch.Tensor]) -> tuple[torch.Tensor, torch.Tensor | None]:
    """Stack ``(T_i, C)`` tensors into ``(B, T_max, C)`` (zero padded) and a mask (None if all equal)."""
    lengths = [int(x.shape[0]) for x in items]
    longest = max(lengths)
    out = torch.zeros(len(items), longest, items[0].shape[-1], dtype=items[0].dtype)
    for i, x in enumerate(items):
        out[i, : x.shape[0]] = x
    mask = None if len(set(lengths)) == 1 else lengths_to_mask(lengths, longest)
    return out, mask


def sample_items(
    sampler: Any,
    backbone: nn.Module,
    conds: Sequence[torch.Tensor],
    seeds: Sequence[int],
    channels: int,
    guidance_scale: float | None = None,
) -> list[torch.Tensor]:
    """One CFG sample ``(T_i, channels)`` per condition ``(T_i, C)``, in one padded batch.

    Each item's initial noise and stochastic steps come from a generator seeded by its seed, so a
    sample depends on its seed and condition only.
    """
    if len(conds) != len(seeds):
        raise ValueError(f"seeds: {len(seeds)} seeds for {len(conds)} inputs")
    items = [_item_noise(c.shape[0], channels, s) for c, s in zip(conds, seeds)]
    noise, x_mask = _pad([n for n, _ in items])
    cond, cond_mask = _pad(list(conds))
    z = sampler.sample(
        backbone,
        noise,
        cond,
        x_mask=x_mask,
        cond_mask=cond_mask,
        guidance_scale=guidance_scale,
        generator=[g for _, g in items],
    )
    return [z[i, : c.shape[0]] for i, c in enumerate(conds)]


class MoMuModel:
    """A trained MoMu-Diffusion: BiCoR-VAE, θ_a, θ_m, normalisers; generation in every direction.

    Every generator takes per-item ``seeds``. In cross-modal generation an item's initial noise and
    the noise of its stochastic steps (DDPM) come from its own seeded generator, so an item is
    generated identically alone, in a batch, on another process, or after any other work (joint
    generation: the initial noise, with the deterministic DDIM steps of the default sampler).
    """

    def __init__(
        self,
        *,
        cfg: MoMuConfig,
        vae: BiCoRVAE,
        music_backbone: nn.Module,
        motion_backbone: nn.Module,
        norms: MoMuNormalizers,
        latent_music: Normalizer,
        latent_motion: Normalizer,
        rates: Rates,
        skeleton: str,
        bone_lengths: np.ndarray,
        backbone_nodes: tuple[dict[str, Any], dict[str, Any]],
    ) -> None:
        self.cfg = cfg
        self.vae = vae.eval()
        self.music_backbone = music_backbone.eval()
        self.motion_backbone = motion_backbone.eval()
        self.norms = norms
        self.latent_music = latent_music
        self.latent_motion = latent_motion
        self.rates = rates
        self.skeleton = skeleton
        self.bone_lengths = np.asarray(bone_lengths, dtype=np.float64)
        self.backbone_nodes = backbone_nodes
        self._samplers: dict[str, Any] = {}
        self._joint: Any = None
        self._vocoder: Any = None
        self._conditions: Conditions | None = None

    # ---------------------------------------------------------------- lazily built parts
    @property
    def sampler(self) -> Any:
        """The default cross-modal sampler (``cfg.sampler``)."""
        return self.sampler_for("default")

    def sampler_for(self, direction: str) -> Any:
        """The sampler of ``"music"`` (motion→music), ``"motion"`` (music→motion) or ``"default"``."""
        if direction not in self._samplers:
            self._samplers[direction] = build_component(self.cfg.sampler_node(direction), "samplers")
        return self._samplers[direction]

    @property
    def joint_sampler(self) -> Any:
        if self._joint is None:
            self._joint = build_component(self.cfg.joint_sampler, "samplers")
        return self._joint

    @property
    def vocoder(self) -> Any:
        if self._vocoder is None:
            self._vocoder = build_component(vocoder_node(self.cfg.vocoder), "vocoders")
        return self._vocoder

    @property
    def vocoder_name(self) -> str:
        """The registered name of the vocoder actually used (see :func:`vocoder_node`)."""
        return str(vocoder_node(self.cfg.vocoder)["name"])

    @property
    def latent_channels(self) -> int:
        return int(self.vae.latent_channels)

    @property
    def conditions(self) -> Conditions:
        """The denoisers' condition features and the motion representation (:mod:`.conditions`)."""
        if self._conditions is None:
            self._conditions = Conditions.of(self.cfg, self.skeleton)
        return self._conditions

    def use_beats_per_movement(self, beats: int) -> None:
        """Generate music with ``beats`` beats per beat θ_a tracks on a dance from now on
        (:meth:`.Conditions.with_beats_per_movement`; 1 is how the model was trained)."""
        self._conditions = self.conditions.with_beats_per_movement(beats)

    # ---------------------------------------------------------------- encoders
    def _standardise(self, z: torch.Tensor, norm: Normalizer) -> torch.Tensor:
        return norm.transform(z.float())

    @torch.no_grad()
    def encode_music(self, audio: np.ndarray, sample_rate: int) -> torch.Tensor:
        """Standardised music latent ``(T_z, d)`` of a waveform (``T_z`` = whole latent frames it covers)."""
        from momu.data.types import Clip
        from momu.methods.momu.data import _waveform

        wave = _waveform(
            Clip(id="input", motion=None, fps=1.0, audio=audio, sample_rate=sample_rate),
            self.rates.sample_rate,
        )
        n = self.rates.latent_frames(len(wave) / self.rates.sample_rate)
        if self.rates.music_input == "waveform":
            need = n * self.rates.samples_per_latent
            x = torch.from_numpy(np.pad(wave, (0, max(0, need - len(wave))))[:need])[None]
        else:
            mel = self.norms.mel_of(wave, self.rates.sample_rate)
            need = n * self.rates.music_frames_per_latent
            if mel.shape[1] < need:
                mel = np.pad(mel, ((0, 0), (0, need - mel.shape[1])), mode="edge")
            x = torch.from_numpy(np.ascontiguousarray(mel[:, :need]))[None]
        z = self.vae.encode_music(x).mode()[0]
        return self._standardise(z, self.latent_music)

    @torch.no_grad()
    def encode_motion(self, motion: np.ndarray, fps: float) -> torch.Tensor:
        """Standardised motion latent ``(T_z, d)`` of ``(T, J, D)`` keypoints at ``fps``."""
        m = np.asarray(motion, dtype=np.float32)
        if m.ndim != 3:
            raise ValueError(f"motion must be (T, J, D), got shape {m.shape}")
        n = self.rates.latent_frames(m.shape[0] / float(fps))
        rep = np.asarray(self.conditions.motion_in(m, float(fps)), dtype=np.float32)
        x = torch.from_numpy(self.norms.motion.transform(rep))[None]
        z = self.vae.encode_motion(x, n).mode()[0]
        return self._standardise(z, self.latent_motion)

    def condition_from_music(self, audio: np.ndarray, sample_rate: int) -> torch.Tensor:
        """θ_m's condition ``(T_z, C)`` for a waveform: its music latent and/or its condition features."""
        c = self.conditions
        n = self.rates.latent_frames(len(audio) / float(sample_rate))
        latent = (
            self.encode_music(audio, sample_rate)
            if (c.latents or c.from_music is None)
            else torch.zeros(n, 0)
        )
        track = c.music_track(audio, sample_rate)
        features = None if track is None else track.features(latent.shape[0], self.rates.latent_rate)
        return c.combine(latent, features)

    def condition_from_motion(self, motion: np.ndarray, fps: float) -> torch.Tensor:
        """θ_a's condition ``(T_z, C)`` for world keypoints: the motion latent and/or its features."""
        c = self.conditions
        n = self.rates.latent_frames(np.asarray(motion).shape[0] / float(fps))
        latent = (
            self.encode_motion(motion, fps) if (c.latents or c.from_motion is None) else torch.zeros(n, 0)
        )
        track = c.motion_track(np.asarray(motion), float(fps))
        features = None if track is None else track.features(latent.shape[0], self.rates.latent_rate)
        return c.combine(latent, features)

    # ---------------------------------------------------------------- decoders
    @torch.no_grad()
    def decode_music(self, z: torch.Tensor) -> np.ndarray:
        """Standardised latent ``(T_z, d)`` -> waveform ``(S,)`` at ``rates.sample_rate``."""
        raw = self.latent_music.inverse(z.float())[None]
        out = self.vae.decode_music(raw)[0].cpu().numpy()
        if self.rates.music_input == "waveform":
            return np.clip(out, -1.0, 1.0).astype(np.float32)
        return np.asarray(self.vocoder.synthesize(self.norms.mel_inverse(out)), dtype=np.float32)

    @torch.no_grad()
    def decode_motion(self, z: torch.Tensor) -> np.ndarray:
        """Standardised latent ``(T_z, d)`` -> keypoints ``(T_z · frames_per_latent, J, D)``.

        The frame rate is ``rates.motion_fps``.
        """
        raw = self.latent_motion.inverse(z.float())[None]
        out = self.vae.decode_motion(raw)[0].cpu().numpy()
        rep = np.asarray(self.norms.motion.inverse(out), dtype=np.float32)
        motion = np.asarray(self.conditions.motion_out(rep, self.rates.motion_fps), dtype=np.float32)
        if self.cfg.rigid_bones and self.skeleton and get_skeleton(self.skeleton).dims == 3:
            from momu.export.rigid import rigid_motion

            lengths = self.bone_lengths if self.bone_lengths.size else None
            motion = np.asarray(rigid_motion(motion, self.skeleton, lengths), dtype=np.float32)
        if self.cfg.bone_correction and self.bone_lengths.size:
            motion = np.asarray(
                correct_bone_lengths(
                    motion.astype(np.float64),
                    get_skeleton(self.skeleton).bones,
                    self.bone_lengths,
                    self.cfg.bone_ratio,
                ),
                dtype=np.float32,
            )
        return motion

    # ---------------------------------------------------------------- generation
    def _cfg_sample(
        self,
        direction: str,
        conds: Sequence[torch.Tensor],
        seeds: Sequence[int],
        guidance_scale: float | None,
    ) -> list[torch.Tensor]:
        backbone = self.music_backbone if direction == "music" else self.motion_backbone
        return sample_items(
            self.sampler_for(direction), backbone, conds, seeds, self.latent_channels, guidance_scale
        )

    def music_to_motion(
        self,
        audios: Sequence[np.ndarray],
        sample_rate: int,
        seeds: Sequence[int],
        *,
        guidance_scale: float | None = None,
    ) -> list[np.ndarray]:
        """Music→motion (θ_m, CFG Eq. 7): one ``(T, J, D)`` motion at ``rates.motion_fps`` per waveform.

        ``guidance_scale`` overrides the sampler's (``motion_sampler``, else ``sampler``).
        """
        conds = [self.condition_from_music(a, sample_rate) for a in audios]
        return [self.decode_motion(z) for z in self._cfg_sample("motion", conds, seeds, guidance_scale)]

    def motion_to_music(
        self,
        motions: Sequence[np.ndarray],
        fps: float | Sequence[float],
        seeds: Sequence[int],
        *,
        guidance_scale: float | None = None,
    ) -> list[np.ndarray]:
        """Motion→music (θ_a, CFG Eq. 7; mel decoded and vocoded): waveforms at ``rates.sample_rate``.

        ``guidance_scale`` overrides the sampler's (``music_sampler``, else ``sampler``).
        """
        rates = [float(fps)] * len(motions) if isinstance(fps, (int, float)) else [float(f) for f in fps]
        conds = [self.condition_from_motion(m, f) for m, f in zip(motions, rates)]
        return [self.decode_music(z) for z in self._cfg_sample("music", conds, seeds, guidance_scale)]

    @torch.no_grad()
    def joint(self, seconds: Sequence[float], seeds: Sequence[int]) -> list[tuple[np.ndarray, np.ndarray]]:
        """Joint generation by cross guidance (Alg. 2, T_c = γT): ``(waveform, motion)`` per length.

        Items of different lengths are generated in one padded batch with masks (MoMu §5.3). Each
        item's initial noise and stochastic steps come from generators seeded by its seed, so a pair
        depends on its seed only.
        """
        if len(seconds) != len(seeds):
            raise ValueError(f"seeds: {len(seeds)} seeds for {len(seconds)} lengths")
        if not self.conditions.latents:
            return self._joint_in_turn(seconds, seeds)
        d = self.latent_channels
        lengths = [self.rates.latent_frames(float(s)) for s in seconds]
        music_items = [_item_noise(n, d, 2 * s) for n, s in zip(lengths, seeds)]
        music_noise, mask = _pad([noise for noise, _ in music_items])
        motion_noise, _ = _pad([_item_noise(n, d, 2 * s + 1)[0] for n, s in zip(lengths, seeds)])
        z_a, z_m = self.joint_sampler.sample(
            self.music_backbone,
            self.motion_backbone,
            music_noise,
            motion_noise,
            music_mask=mask,
            motion_mask=mask,
            generator=[gen for _, gen in music_items],  # each item's stochastic steps: its own seed
        )
        return [
            (self.decode_music(z_a[i, :n]), self.decode_motion(z_m[i, :n])) for i, n in enumerate(lengths)
        ]

    def _joint_in_turn(
        self, seconds: Sequence[float], seeds: Sequence[int]
    ) -> list[tuple[np.ndarray, np.ndarray]]:
        """Joint generation of a model conditioned on features alone (no latent for cross guidance):
        θ_a samples the music unconditionally (guidance scale 0: ε(∅)), then θ_m dances to it."""
        d = self.latent_channels
        conds = [
            torch.zeros(n, self.conditions.cond_width("music", d))
            for n in (self.rates.latent_frames(float(s)) for s in seconds)
        ]
        latents = self._cfg_sample("music", conds, [2 * s for s in seeds], 0.0)
        audios = [self.decode_music(z) for z in latents]
        motions = self.music_to_motion(audios, self.rates.sample_rate, [2 * s + 1 for s in seeds])
        return list(zip(audios, motions))

    # ---------------------------------------------------------------- save / load
    def save(self, folder: str | Path) -> Path:
        """Write ``momu.json``, a part folder per module (config.json + model.safetensors), JSON stats."""
        folder = Path(folder)
        folder.mkdir(parents=True, exist_ok=True)
        enc = dict(_plain(self.cfg.encoder))
        save_part(self.vae, "encoders", enc.pop("name"), enc, folder / "encoder")
        for sub, node, module in (
            ("music_backbone", self.backbone_nodes[0], self.music_backbone),
            ("motion_backbone", self.backbone_nodes[1], self.motion_backbone),
        ):
            params = dict(node)
            save_part(module, "backbones", params.pop("name"), params, folder / sub)
        self.norms.save(folder)
        self.latent_music.save(folder / "latent_music_normalizer.json")
        self.latent_motion.save(folder / "latent_motion_normalizer.json")
        from momu import __version__

        write_json(
            folder / "momu.json",
            {
                "format": FORMAT_VERSION,
                "method": "momu",
                "momu_version": __version__,
                "config": OmegaConf.to_container(OmegaConf.structured(self.cfg), resolve=True),
                "rates": dataclasses.asdict(self.rates),
                "skeleton": self.skeleton,
                "bone_lengths": self.bone_lengths.tolist(),
            },
        )
        return folder

    @classmethod
    def load(cls, folder: str | Path) -> MoMuModel:
        """Load a folder written by :meth:`save` (parts strictly; errors name the file)."""
        folder = Path(folder)
        meta_path = folder / "momu.json"
        if not meta_path.is_file():
            raise FileNotFoundError(f"{meta_path}: not a saved MoMu model (momu.json missing)")
        meta = read_json(meta_path)
        if not isinstance(meta, dict) or meta.get("method") != "momu":
            raise ValueError(f"{meta_path}: not a MoMu model record")
        if int(meta.get("format", 0)) > FORMAT_VERSION:
            raise ValueError(f"{meta_path}: format {meta['format']} is newer than this momu reads")
        cfg = OmegaConf.to_object(OmegaConf.merge(OmegaConf.structured(MoMuConfig), meta["config"]))
        assert isinstance(cfg, MoMuConfig)
        vae = load_part(folder / "encoder")
        if not isinstance(vae, BiCoRVAE):
            raise ValueError(f"{folder / 'encoder'}: not a BiCoR-VAE")
        music_bb = load_part(folder / "music_backbone")
        motion_bb = load_part(folder / "motion_backbone")
        from momu.parts_io import read_part_config

        nodes = tuple(
            {"name": rec["name"], **(rec["config"] or {})}
            for rec in (
                read_part_config(folder / "music_backbone"),
                read_part_config(folder / "motion_backbone"),
            )
        )
        return cls(
            cfg=cfg,
            vae=vae,
            music_backbone=music_bb,
            motion_backbone=motion_bb,
            norms=MoMuNormalizers.load(folder),
            latent_music=Normalizer.load(folder / "latent_music_normalizer.json"),
            latent_motion=Normalizer.load(folder / "latent_motion_normalizer.json"),
            rates=Rates(**meta["rates"]),
            skeleton=str(meta.get("skeleton", "")),
            bone_lengths=np.asarray(meta.get("bone_lengths", []), dtype=np.float64),
            backbone_nodes=(nodes[0], nodes[1]),
        )
