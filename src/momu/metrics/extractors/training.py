"""Training the feature extractors on labelled clips (``momu extractor train``).

See :mod:`momu.metrics.extractors`.
"""

from __future__ import annotations

import dataclasses
import logging
import shutil
import time
from collections.abc import Callable, Mapping, Sequence
from contextlib import closing, nullcontext
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import torch
import torch.nn.functional as F
from torch import nn
from tqdm.auto import tqdm

from momu.data.types import Clip
from momu.features.audio import check_waveform, momu_mel
from momu.metrics.extractors.networks import (
    AudioClassifier,
    AudioClassifierConfig,
    MotionClassifier,
    MotionClassifierConfig,
    audio_segments,
    motion_windows,
    prepare_motion,
)
from momu.metrics.extractors.storage import (
    AudioClassifierEmbedding,
    MotionExtractor,
    batched_slices,
    save_extractor,
)

logger = logging.getLogger(__name__)


@dataclass
class TrainConfig:
    """Optimisation of an extractor.

    The defaults train in seconds on a CPU; :meth:`paper` gives MoMu App. B.5's schedule
    (Adam, lr 1e-4, 100 epochs).

    Attributes:
        epochs: passes over the training clips.
        batch_size: windows / segments per step.
        lr: Adam learning rate.
        weight_decay: Adam weight decay.
        samples_per_clip: random windows (motion) or segments (audio) drawn per clip per epoch.
        val_fraction: fraction of clips held out (stratified by style) to report accuracy; 0 = none.
        seed: seeds the split, the window sampling and the initialisation.
        device: torch device.
    """

    epochs: int = 20
    batch_size: int = 16
    lr: float = 1e-3
    weight_decay: float = 0.0
    samples_per_clip: int = 8
    val_fraction: float = 0.2
    seed: int = 0
    device: str = "cpu"

    @classmethod
    def paper(cls) -> TrainConfig:
        """MoMu App. B.5: Adam, learning rate 1e-4, 100 epochs."""
        return cls(epochs=100, lr=1e-4)

    def __post_init__(self) -> None:
        if self.epochs < 1 or self.batch_size < 1 or self.samples_per_clip < 1:
            raise ValueError("TrainConfig: epochs, batch_size and samples_per_clip must be >= 1")
        if not 0.0 <= self.val_fraction < 1.0:
            raise ValueError(f"TrainConfig.val_fraction must be in [0, 1), got {self.val_fraction}")
        if self.lr <= 0:
            raise ValueError(f"TrainConfig.lr must be positive, got {self.lr}")


# ============================================================================ motion


def _labelled(clips: Sequence[Clip], need: str) -> tuple[list[Clip], list[str]]:
    usable = [c for c in clips if c.style is not None and getattr(c, need) is not None]
    if len(usable) < len(clips):
        logger.info("skipping %d clip(s) without a style label or %s", len(clips) - len(usable), need)
    classes = sorted({str(c.style) for c in usable})
    if len(classes) < 2:
        raise ValueError(
            f"training a classifier needs clips of at least 2 styles (Clip.style) with {need}; "
            f"found {len(usable)} usable clip(s) of styles {classes}"
        )
    return usable, classes


def _split(
    labels: np.ndarray, val_fraction: float, rng: np.random.Generator
) -> tuple[np.ndarray, np.ndarray]:
    """Stratified split of clip indices; every class keeps at least one training clip."""
    train, val = [], []
    for c in np.unique(labels):
        idx = rng.permutation(np.nonzero(labels == c)[0])
        n_val = min(len(idx) - 1, int(round(val_fraction * len(idx))))
        val += idx[:n_val].tolist()
        train += idx[n_val:].tolist()
    return np.array(sorted(train), dtype=int), np.array(sorted(val), dtype=int)


@dataclass
class Checkpointing:
    """Where and how often an extractor's training writes resumable checkpoints.

    Attributes:
        root: the checkpoint folder (``step_<n>/``, crash-safe: :mod:`momu.engine.state`).
        resume: continue from the newest intact checkpoint under ``root``.
        minutes: training minutes between checkpoints (0: only when stopped by a signal).
    """

    root: Path
    resume: bool = False
    minutes: float = 10.0


def _loop_state(epoch: int, batch: int, total: float, seen: int, history: list[float]) -> dict[str, Any]:
    return {"epoch": epoch, "batch": batch, "total": total, "seen": seen, "history": list(history)}


def _fit_loop(
    model: nn.Module,
    sample_batch: Any,
    num_samples: int,
    train: TrainConfig,
    desc: str,
    checkpointing: Checkpointing | None = None,
    on_step: Callable[[int, int], None] | None = None,
) -> list[float]:
    """Adam over ``train.epochs`` epochs of ``num_samples`` samples; returns the mean loss per epoch.

    The progress bar counts optimizer steps; ``on_step(step, steps)`` is called after each one (a
    table run's progress line shows it). With ``checkpointing``, SIGTERM or Ctrl-C (or the exit of
    an ``accelerate launch`` parent) writes a checkpoint after the current step and raises
    :class:`~momu.engine.trainer.Preempted`; so does every ``checkpointing.minutes`` of training
    (without stopping). A run resumed from a checkpoint ends with the same weights as an
    uninterrupted one: the checkpoint holds the model, Adam, the sampling generator, the epoch's
    sample order and position, and the global RNG states.
    """
    from momu.engine.signals import stop_flag
    from momu.engine.state import (
        capture_rng,
        load_tensors_and_json,
        recover_checkpoints,
        restore_rng,
        resume_point,
        write_checkpoint,
    )
    from momu.engine.trainer import Preempted
    from momu.io import read_json

    opt = torch.optim.Adam(model.parameters(), lr=train.lr, weight_decay=train.weight_decay)
    rng = np.random.default_rng(train.seed + 1)
    slices = batched_slices(num_samples, train.batch_size)
    epoch, batch, total, seen, history = 0, 0, 0.0, 0, []
    order = np.arange(num_samples)
    found = None
    if checkpointing is not None and checkpointing.resume:
        for note in recover_checkpoints(checkpointing.root):
            logger.warning("%s", note)
        found = resume_point(checkpointing.root, desc)
    if found is not None:
        model.load_state_dict(load_tensors_and_json(found, "model"), strict=True)
        opt.load_state_dict(load_tensors_and_json(found, "optimizer"))
        saved = load_tensors_and_json(found, "loop")
        rng.bit_generator.state = read_json(found / "sampler.json")
        order = np.asarray(saved["order"])
        restore_rng(load_tensors_and_json(found, "rng"))
        meta = read_json(found / "progress.json")
        epoch, batch, total, seen, history = (
            meta["epoch"], meta["batch"], meta["total"], meta["seen"], meta["history"]
        )  # fmt: skip
        logger.info("%s: resumed from %s (epoch %d, batch %d)", desc, found, epoch, batch)

    def save(step: int) -> Path:
        assert checkpointing is not None
        return write_checkpoint(
            checkpointing.root,
            step,
            {
                "model": model.state_dict(),
                "optimizer": opt.state_dict(),
                "loop": {"order": order},
                "rng": capture_rng(),
            },
            {"sampler": rng.bit_generator.state, "progress": _loop_state(epoch, batch, total, seen, history)},
            keep=1,
        )

    model.train()
    steps = train.epochs * len(slices)
    bar = tqdm(total=steps, initial=epoch * len(slices) + batch, desc=desc, unit="step", leave=False)
    last_save = time.monotonic()
    signals = stop_flag() if checkpointing is not None else nullcontext(None)  # else: signals as they are
    with signals as flag, closing(bar):  # the bar's line is cleared also when stopped
        while epoch < train.epochs:  # one optimizer step per pass
            if batch == 0:
                order = rng.permutation(num_samples)
                total, seen = 0.0, 0
            x, mask, y = sample_batch(order[slices[batch]], rng)
            logits = model(x, mask) if mask is not None else model(x)
            loss = F.cross_entropy(logits, y)
            opt.zero_grad(set_to_none=True)
            loss.backward()
            opt.step()
            total += float(loss.detach()) * len(y)
            seen += len(y)
            batch += 1
            bar.update(1)
            if on_step is not None:
                on_step(epoch * len(slices) + batch, steps)
            if batch == len(slices):
                history.append(total / seen)
                bar.set_postfix(epoch=len(history), loss=f"{history[-1]:.4f}")
                epoch, batch = epoch + 1, 0
            if checkpointing is None or flag is None or epoch >= train.epochs:
                continue
            if flag.stop:
                raise Preempted(save(epoch * len(slices) + batch), flag.reason, flag.status)
            if checkpointing.minutes > 0 and time.monotonic() - last_save >= 60.0 * checkpointing.minutes:
                save(epoch * len(slices) + batch)
                last_save = time.monotonic()
    model.eval()
    return history


def train_motion_classifier(
    clips: Sequence[Clip],
    cfg: MotionClassifierConfig | None = None,
    train: TrainConfig | None = None,
    checkpointing: Checkpointing | None = None,
    on_step: Callable[[int, int], None] | None = None,
) -> tuple[MotionClassifier, dict[str, Any]]:
    """Train a motion style classifier on labelled clips (MoMu App. B.5).

    Each epoch draws ``samples_per_clip`` random windows of ``cfg.window`` frames from every training
    clip (the whole clip, padded and masked, when it is shorter). ``cfg.class_names`` and the DSTformer's
    ``num_joints``/``dim_in`` are filled from the data when left empty / mismatched.

    Returns:
        ``(model, summary)``; the summary holds the per-epoch loss, the class names, the clip split
        and the held-out clip accuracy (``val_accuracy``, None without a validation split).
    """
    train = train or TrainConfig()
    usable, classes = _labelled(clips, "motion")
    first = np.asarray(usable[0].motion)
    if first.ndim != 3:
        raise ValueError(f"clip {usable[0].id!r}: motion must be (T, J, D), got shape {first.shape}")
    cfg = cfg or MotionClassifierConfig()
    dcfg = dataclasses.replace(cfg.dstformer, num_joints=int(first.shape[1]), dim_in=int(first.shape[2]))
    cfg = dataclasses.replace(cfg, class_names=classes, dstformer=dcfg)
    torch.manual_seed(train.seed)
    rng = np.random.default_rng(train.seed)
    labels = np.array([classes.index(str(c.style)) for c in usable])
    tr_idx, va_idx = _split(labels, train.val_fraction, rng)
    prepared = [
        prepare_motion(usable[i].motion, usable[i].fps, cfg, f"clip {usable[i].id!r}") for i in tr_idx
    ]
    model = MotionClassifier(cfg).to(train.device)
    device = torch.device(train.device)
    owners = np.repeat(np.arange(len(prepared)), train.samples_per_clip)

    def sample_batch(
        sel: np.ndarray, rng: np.random.Generator
    ) -> tuple[torch.Tensor, torch.Tensor, torch.Tensor]:
        xs, ms = [], []
        for k in owners[sel]:
            motion = prepared[k]
            start = int(rng.integers(0, max(1, motion.shape[0] - cfg.window + 1)))
            w, m = motion_windows(motion[start : start + cfg.window], cfg.window)
            xs.append(w[0])
            ms.append(m[0])
        y = torch.as_tensor(labels[tr_idx][owners[sel]], device=device)
        return torch.from_numpy(np.stack(xs)).to(device), torch.from_numpy(np.stack(ms)).to(device), y

    history = _fit_loop(model, sample_batch, len(owners), train, "motion classifier", checkpointing, on_step)
    summary: dict[str, Any] = {
        "class_names": classes,
        "loss_history": history,
        "train_clips": [usable[i].id for i in tr_idx],
        "val_clips": [usable[i].id for i in va_idx],
        "val_accuracy": None,
        "train": dataclasses.asdict(train),
    }
    extractor = MotionExtractor(model, device=train.device)
    if len(va_idx):
        predicted = extractor.clip_probabilities([usable[i] for i in va_idx]).argmax(axis=1)
        summary["val_accuracy"] = float(np.mean(predicted == labels[va_idx]))
    logger.info("motion classifier: final loss %.4f, val accuracy %s", history[-1], summary["val_accuracy"])
    return model.cpu(), summary


def train_audio_classifier(
    clips: Sequence[Clip],
    cfg: AudioClassifierConfig | None = None,
    train: TrainConfig | None = None,
    checkpointing: Checkpointing | None = None,
    on_step: Callable[[int, int], None] | None = None,
) -> tuple[AudioClassifier, dict[str, Any]]:
    """Train the default audio embedding: a log-mel CNN classifying 0.96 s segments by style.

    Each epoch draws ``samples_per_clip`` random segments (any start frame) per training clip; the mel
    standardisation statistics come from the training clips. Returns ``(model, summary)`` like
    :func:`train_motion_classifier` (validation accuracy = clip-level, mean logits over segments).
    """
    train = train or TrainConfig()
    usable, classes = _labelled(clips, "audio")
    cfg = dataclasses.replace(cfg or AudioClassifierConfig(), class_names=classes)
    torch.manual_seed(train.seed)
    rng = np.random.default_rng(train.seed)
    labels = np.array([classes.index(str(c.style)) for c in usable])
    tr_idx, va_idx = _split(labels, train.val_fraction, rng)
    mels = []
    for i in tr_idx:
        clip = usable[i]
        if clip.sample_rate is None:
            raise ValueError(f"clip {clip.id!r}: has audio but no sample rate")
        wave = check_waveform(clip.audio, clip.sample_rate, name=f"clip {clip.id!r}")
        mel = momu_mel(wave, clip.sample_rate, cfg.mel)
        if mel.shape[1] < cfg.segment_frames:
            raise ValueError(
                f"clip {clip.id!r}: audio shorter than one {cfg.segment_frames}-frame segment "
                f"({mel.shape[1]} mel frames)"
            )
        mels.append(mel)
    stacked = np.concatenate(mels, axis=1)
    model = AudioClassifier(cfg)
    model.mel_mean.copy_(torch.from_numpy(stacked.mean(axis=1)))
    model.mel_std.copy_(torch.from_numpy(stacked.std(axis=1) + 1e-5))
    device = torch.device(train.device)
    model.to(device)
    owners = np.repeat(np.arange(len(mels)), train.samples_per_clip)
    seg = cfg.segment_frames

    def sample_batch(sel: np.ndarray, rng: np.random.Generator) -> tuple[torch.Tensor, None, torch.Tensor]:
        xs = []
        for k in owners[sel]:
            start = int(rng.integers(0, mels[k].shape[1] - seg + 1))
            xs.append(mels[k][:, start : start + seg])
        y = torch.as_tensor(labels[tr_idx][owners[sel]], device=device)
        return torch.from_numpy(np.stack(xs)).to(device), None, y

    history = _fit_loop(model, sample_batch, len(owners), train, "audio classifier", checkpointing, on_step)
    summary: dict[str, Any] = {
        "class_names": classes,
        "loss_history": history,
        "train_clips": [usable[i].id for i in tr_idx],
        "val_clips": [usable[i].id for i in va_idx],
        "val_accuracy": None,
        "train": dataclasses.asdict(train),
    }
    if len(va_idx):
        correct = []
        with torch.no_grad():
            for i in va_idx:
                clip = usable[i]
                segs = torch.from_numpy(audio_segments(clip.audio, clip.sample_rate, cfg)).to(device)
                correct.append(int(model(segs).mean(dim=0).argmax()) == labels[i])
        summary["val_accuracy"] = float(np.mean(correct))
    logger.info("audio classifier: final loss %.4f, val accuracy %s", history[-1], summary["val_accuracy"])
    return model.cpu(), summary


def train_extractor(
    kind: str,
    clips: Sequence[Clip],
    out: str | Path | None = None,
    *,
    model_config: MotionClassifierConfig | AudioClassifierConfig | None = None,
    train: TrainConfig | None = None,
    provenance: Mapping[str, str] | None = None,
    checkpointing: Checkpointing | None = None,
    on_step: Callable[[int, int], None] | None = None,
) -> tuple[MotionExtractor | AudioClassifierEmbedding, dict[str, Any]]:
    """Train a ``"motion"`` or ``"audio"`` extractor on labelled clips and (optionally) save it to ``out``.

    ``provenance`` is stored in the saved ``.json`` (:func:`~momu.metrics.extractors.storage.save_extractor`).
    ``checkpointing``: resumable checkpoints (on SIGTERM / Ctrl-C and every few minutes, see
    :class:`Checkpointing`); they are deleted once the extractor is saved. ``on_step(step, steps)``:
    called after every optimizer step.

    Returns the evaluation wrapper (with checkpoint path and sha256 when saved) and the training summary.
    """
    if kind in ("motion", "motion_classifier"):
        if model_config is not None and not isinstance(model_config, MotionClassifierConfig):
            raise ValueError("model_config must be a MotionClassifierConfig for kind 'motion'")
        model: MotionClassifier | AudioClassifier
        model, summary = train_motion_classifier(clips, model_config, train, checkpointing, on_step)
    elif kind in ("audio", "audio_classifier"):
        if model_config is not None and not isinstance(model_config, AudioClassifierConfig):
            raise ValueError("model_config must be an AudioClassifierConfig for kind 'audio'")
        model, summary = train_audio_classifier(clips, model_config, train, checkpointing, on_step)
    else:
        raise ValueError(f"extractor kind must be 'motion' or 'audio', got {kind!r}")
    digest = None if out is None else save_extractor(out, model, summary, provenance)
    if checkpointing is not None and out is not None:
        shutil.rmtree(checkpointing.root, ignore_errors=True)
    device = (train or TrainConfig()).device
    if isinstance(model, MotionClassifier):
        return MotionExtractor(model, checkpoint=out, sha256=digest, device=device), summary
    return AudioClassifierEmbedding(model, checkpoint=out, sha256=digest, device=device), summary
