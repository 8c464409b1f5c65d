"""A trained HarmoGAN (:class:`HarmoGANModel`): recurrent generation over meter units, save and load.

Generation (HarmoGAN §IV-A, Fig. 7 right): "our generator G is able to recurrently synthesize human
movements for an audio clip of arbitrary length segmented into K meter units, using only a single
initial pose input." :meth:`HarmoGANModel.generate` segments the music into meter units
(:func:`momu.methods.harmogan.meter.meter_units`, audio beats from the harmony metric's detector),
then for unit k = 1..K builds V_f from the poses already generated on the unit's transition frames
(the initial pose for the first unit; Eq. 12), runs G, and writes the frames of unit k's meter. The
meters tile the music, so the output has one pose per motion frame of the music, whatever its length.
At each seam the previous unit's own continuation (its frames past its meter) is blended linearly into
the new unit's first ``stitch_frames`` frames (momu's choice; the paper does not say how units join):
without it every meter start carries a velocity jump of about 3× the median joint speed, a spurious
salient visual beat on a strong onset.

``momu generate`` (dance for your music) should call::

    model = HarmoGANModel.load(folder)            # folder holds harmogan.json + generator/
    motion = model.generate(audio, sample_rate, initial_pose=None, seed=0)   # (T, J, 3) at model.fps
"""

from __future__ import annotations

import dataclasses
from pathlib import Path
from typing import Any

import numpy as np
import torch
from omegaconf import OmegaConf

from momu.features.audio import resample
from momu.io import read_json, write_json
from momu.methods.harmogan.config import HarmoGANConfig, plain_node
from momu.methods.harmogan.data import MfccStats, dance_mfcc
from momu.methods.harmogan.meter import initial_pose_input, meter_units, transition_indices
from momu.metrics._checks import as_waveform
from momu.metrics.harmony import audio_beats
from momu.parts_io import load_part, save_part

__all__ = ["HarmoGANModel", "FORMAT_VERSION"]

FORMAT_VERSION = 1


class HarmoGANModel:
    """A trained generator with its A_f statistics and the training data's mean pose.

    Attributes:
        cfg: the method config it was trained with. generator: G. stats: A_f standardisation.
        mean_pose: ``(J, 3)`` default initial pose. skeleton: joint layout name. fps: motion rate.
    """

    def __init__(
        self,
        cfg: HarmoGANConfig,
        generator: torch.nn.Module,
        stats: MfccStats,
        mean_pose: np.ndarray,
        skeleton: str = "dwm21",
    ) -> None:
        self.cfg = cfg
        self.generator = generator.eval()
        self.stats = stats
        self.mean_pose = np.asarray(mean_pose, dtype=np.float32)
        self.skeleton = skeleton

    @property
    def fps(self) -> float:
        return float(self.cfg.fps)

    @property
    def sample_rate(self) -> int:
        return int(self.cfg.mfcc.sample_rate)

    @torch.no_grad()
    def generate(
        self, audio: np.ndarray, sr: int, initial_pose: np.ndarray | None = None, seed: int = 0
    ) -> np.ndarray:
        """Dance for ``audio`` of any length: ``(T, J, 3)`` float32 at :attr:`fps`, T = floor(duration · fps).

        Args:
            audio: mono ``(S,)`` (or ``(C, S)``) waveform at ``sr`` Hz.
            initial_pose: ``(J, 3)`` root-centred pose the dance starts from (default: the training
                data's mean pose).
            seed: draws the generator's noise (a sample depends on its seed only).

        Raises:
            ValueError: bad audio, an initial pose of the wrong shape, or music shorter than two frames.
        """
        wave, rate = as_waveform(audio, sr)
        if rate != self.sample_rate:
            wave, rate = resample(wave, rate, self.sample_rate), self.sample_rate
        frames = int(np.floor(len(wave) / rate * self.fps + 1e-6))
        if frames < 2:
            raise ValueError(
                f"generate: the music is {len(wave) / rate:.3f} s long; it needs at least 2 frames"
            )
        pose0 = self.mean_pose if initial_pose is None else np.asarray(initial_pose, dtype=np.float32)
        if pose0.shape != self.mean_pose.shape:
            raise ValueError(f"generate: initial_pose must be {self.mean_pose.shape}, got {pose0.shape}")
        features = self.stats.apply(dance_mfcc(wave, rate, self.cfg.mfcc, self.fps, frames))
        times, saliency = audio_beats(wave, rate)
        units = meter_units(times, saliency, frames / self.fps, self.fps, self.cfg.meter)
        out = np.repeat(pose0[None], frames, axis=0)
        device = next(self.generator.parameters()).device
        ahead = np.zeros((0, *pose0.shape), dtype=np.float32)  # the previous unit's frames past its meter
        for k, unit in enumerate(units):
            s, e = unit.start, unit.start + unit.length
            a_f = np.pad(features[s:e], ((0, max(0, e - frames)), (0, 0)), mode="edge")
            ti = transition_indices(unit)
            known = np.pad(out[s:e], ((0, max(0, e - frames)), (0, 0), (0, 0)), mode="edge")
            v_f = initial_pose_input(known, ti)
            gen = torch.Generator().manual_seed(int(seed) * 1_000_003 + k)
            result = self.generator(
                torch.from_numpy(a_f)[None].to(device),
                torch.from_numpy(v_f)[None].to(device),
                torch.from_numpy(ti)[None].to(device),
                generator=gen,
            )
            motion = result.motion[0].cpu().numpy()
            lo, hi = unit.meter_start, unit.meter_end
            out[lo:hi] = motion[lo - s : hi - s]
            n = min(self.cfg.stitch_frames, len(ahead), hi - lo)
            if n > 0:  # blend the seam: the previous unit's continuation fades into this unit's frames
                alpha = (np.arange(1, n + 1, dtype=np.float32) / (n + 1))[:, None, None]
                out[lo : lo + n] = (1 - alpha) * ahead[:n] + alpha * out[lo : lo + n]
            ahead = motion[hi - s :]
        return out.astype(np.float32)

    # ------------------------------------------------------------------ save / load
    def save(self, folder: str | Path) -> Path:
        """Write ``harmogan.json`` (config, statistics, mean pose) and ``generator/`` (a saved part)."""
        from momu import __version__

        folder = Path(folder)
        folder.mkdir(parents=True, exist_ok=True)
        node = self.generator_node()
        save_part(self.generator, "encoders", node.pop("name"), node, folder / "generator")
        write_json(
            folder / "harmogan.json",
            {
                "format": FORMAT_VERSION,
                "method": "harmogan",
                "momu_version": __version__,
                "config": OmegaConf.to_container(OmegaConf.structured(self.cfg), resolve=True),
                "skeleton": self.skeleton,
                "mfcc_mean": self.stats.mean.tolist(),
                "mfcc_std": self.stats.std.tolist(),
                "mean_pose": self.mean_pose.tolist(),
            },
        )
        return folder

    def generator_node(self) -> dict[str, Any]:
        """The generator's component node with the widths it was built with."""
        gcfg = getattr(self.generator, "cfg", None)
        if not dataclasses.is_dataclass(gcfg) or isinstance(gcfg, type):
            raise TypeError("HarmoGANModel: the generator has no config dataclass (cfg) to save")
        return {"name": plain_node(self.cfg.generator_encoder)["name"], **dataclasses.asdict(gcfg)}

    @classmethod
    def load(cls, folder: str | Path) -> HarmoGANModel:
        """Load a folder written by :meth:`save` (the generator strictly; errors name the file)."""
        folder = Path(folder)
        meta_path = folder / "harmogan.json"
        if not meta_path.is_file():
            raise FileNotFoundError(f"{meta_path}: not a saved HarmoGAN model (harmogan.json missing)")
        meta = read_json(meta_path)
        if not isinstance(meta, dict) or meta.get("method") != "harmogan":
            raise ValueError(f"{meta_path}: not a HarmoGAN model record")
        if int(meta.get("format", 0)) > FORMAT_VERSION:
            raise ValueError(f"{meta_path}: format {meta['format']} is newer than this momu reads")
        cfg = OmegaConf.to_object(OmegaConf.merge(OmegaConf.structured(HarmoGANConfig), meta["config"]))
        assert isinstance(cfg, HarmoGANConfig)
        generator = load_part(folder / "generator")
        stats = MfccStats(np.asarray(meta["mfcc_mean"], np.float32), np.asarray(meta["mfcc_std"], np.float32))
        return cls(cfg, generator, stats, np.asarray(meta["mean_pose"], np.float32), str(meta["skeleton"]))
