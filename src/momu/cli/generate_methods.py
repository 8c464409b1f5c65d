"""``momu generate`` for the other methods' models: MoFusion (music→dance, text→motion) and HarmoGAN.

The model folder's record (:class:`~momu.cli.generate_io.ModelRecord`) says which method saved it;
:func:`check_model` refuses, before anything is loaded, what that model cannot do (``music`` / ``joint``
need MoMu, ``text`` a MoFusion text model, ``dance`` a music model, ``forecast`` / ``inbetween`` a
MoFusion model, ``edit`` a MoFusion text model, ``--guidance`` MoMu's classifier-free guidance, a length
past a backbone's positional table). Generation goes through each method's own API,
which covers a whole song in one call:

* MoFusion (:class:`~momu.methods.mofusion.MoFusionModel`): its 1D U-Net is fully convolutional, so
  ``music_to_dance`` / ``text_to_motion`` take any length in one pass (a ``dit`` backbone is bounded
  by its ``max_length``); global joint positions at the model's rate (20 fps).
* HarmoGAN (:class:`~momu.methods.harmogan.HarmoGANModel`): ``generate`` runs recurrently over the
  song's meter units; root-centred joint positions at 15 fps.
"""

from __future__ import annotations

import argparse
import logging
from typing import Any

import numpy as np

from momu.cli.generate_io import GenerateInputError, ModelRecord, Song, check_seconds

__all__ = [
    "INPAINTING",
    "check_model",
    "check_length",
    "describe",
    "generate_method_dance",
    "method_dance",
    "generate_text",
    "load_method_model",
]

log = logging.getLogger(__name__)

INPAINTING = ("forecast", "inbetween", "edit")
"""MoFusion's inpainting tasks (§4.4; editing: the abstract), :mod:`momu.cli.generate_inpaint`."""
TEXT_SECONDS_DEFAULT = 4.0
"""``momu generate text`` length without ``--seconds`` (when the model's window is longer)."""


def describe(record: ModelRecord) -> str:
    """``a MoMu model`` / ``a MoFusion music→dance model`` / ... (for error messages)."""
    if record.method == "momu":
        return "a MoMu model"
    if record.method == "harmogan":
        return "a HarmoGAN (music→dance) model"
    return "a MoFusion text→motion model" if record.task == "text" else "a MoFusion music→dance model"


def check_model(record: ModelRecord, direction: str, args: argparse.Namespace) -> None:
    """Refuse, before loading, what ``record``'s model cannot do for ``momu generate <direction>``."""
    where = f"--model {record.folder}: {describe(record)}"
    if direction in INPAINTING:
        if record.method != "mofusion":
            raise GenerateInputError(
                f"{where}; `momu generate {direction}` needs a MoFusion model (mofusion.json)"
            )
        if direction == "edit" and record.task != "text":
            raise GenerateInputError(
                f"{where}; `momu generate edit` (text-based editing) needs a MoFusion text→motion model"
            )
    elif direction == "text":
        if record.method != "mofusion" or record.task != "text":
            raise GenerateInputError(
                f"{where}; `momu generate text` needs a MoFusion text→motion model (method.task=text)"
            )
    elif record.method != "momu":
        if direction != "dance":
            raise GenerateInputError(
                f"{where} generates dance from music only; `momu generate {direction}` needs a MoMu model"
            )
        if record.task == "text":
            raise GenerateInputError(f"{where}; use `momu generate text --caption ...` with it")
    if record.method != "momu" and args.guidance is not None:
        why = "samples without classifier-free guidance" if record.method == "mofusion" else "is a GAN"
        raise GenerateInputError(f"{where} {why}; --guidance is for MoMu models only (drop --guidance)")


def check_length(record: ModelRecord, seconds: float) -> None:
    """A motion longer than the backbone's positional table (``dit.max_length``) is refused."""
    if record.max_frames is None or record.fps is None:
        return
    frames = int(round(seconds * record.fps))
    if frames > record.max_frames:
        raise GenerateInputError(
            f"--model {record.folder}: its backbone takes at most {record.max_frames} frames "
            f"({record.max_frames / record.fps:.1f} s at {record.fps:g} fps); {seconds:.1f} s asked for "
            "(pass --seconds to use the beginning)"
        )


def load_method_model(record: ModelRecord) -> Any:
    """Load a MoFusion or HarmoGAN model folder (failures: one line naming ``--model``)."""
    try:
        if record.method == "mofusion":
            from momu.methods.mofusion import MoFusionModel

            return MoFusionModel.load(record.folder)
        from momu.methods.harmogan import HarmoGANModel

        return HarmoGANModel.load(record.folder)
    except (OSError, ValueError, KeyError, TypeError) as exc:
        raise GenerateInputError(f"--model {record.folder}: cannot load: {exc}") from None


def _mofusion_seconds(model: Any, song: Song) -> float:
    """The motion length for ``song``: its duration, shortened to what its mel spectrogram covers."""
    from momu.methods.mofusion.data import MEL_FPS

    frames = int(np.floor(song.duration * model.fps + 1e-6))
    return max(1, frames) / model.fps - 0.25 / MEL_FPS  # rounds to those frames, within the mel


def generate_method_dance(record: ModelRecord, song: Song, seed: int) -> tuple[np.ndarray, float]:
    """A MoFusion or HarmoGAN dance for ``song``: ``(T, J, 3)`` and its fps."""
    if record.method == "mofusion":
        check_length(record, song.duration)
    model = load_method_model(record)
    log.info("momu generate dance: %s, %.1f s of music", describe(record), song.duration)
    return method_dance(record, model, song, seed)


def method_dance(record: ModelRecord, model: Any, song: Song, seed: int) -> tuple[np.ndarray, float]:
    """A dance for ``song`` from an already loaded MoFusion or HarmoGAN ``model`` (``record``'s)."""
    try:
        if record.method == "mofusion":
            (motion,) = model.music_to_dance(
                [(song.audio, song.sample_rate)], [_mofusion_seconds(model, song)], [seed]
            )
        else:
            motion = model.generate(song.audio, song.sample_rate, initial_pose=None, seed=seed)
    except ValueError as exc:  # too short for HarmoGAN, past a backbone's table
        raise GenerateInputError(f"--music {song.path}: {exc}") from None
    return np.asarray(motion, dtype=np.float32), float(model.fps)


def text_seconds(record: ModelRecord, seconds: float | None) -> float:
    """``--seconds`` for ``generate text`` (checked); the default fits the model's training window."""
    if seconds is None:
        window = record.window_seconds or TEXT_SECONDS_DEFAULT
        seconds = min(TEXT_SECONDS_DEFAULT, window)
    seconds = check_seconds(seconds) or 0.0
    if record.window_seconds is not None and seconds > record.window_seconds:
        log.warning(
            "--seconds %.1f is longer than the clips the model trained on (at most %.1f s); "
            "the motion may drift past them",
            seconds,
            record.window_seconds,
        )
    check_length(record, seconds)
    return float(seconds)


def generate_text(record: ModelRecord, caption: str, seconds: float, seed: int) -> tuple[np.ndarray, float]:
    """A MoFusion text→motion sample: ``(round(seconds·fps), J, 3)`` and its fps."""
    model = load_method_model(record)
    log.info("momu generate text: %s, %.1f s for %r", describe(record), seconds, caption)
    try:
        (motion,) = model.text_to_motion([caption], [seconds], [seed])
    except ValueError as exc:
        raise GenerateInputError(f"--model {record.folder}: cannot generate {seconds:g} s: {exc}") from None
    return np.asarray(motion, dtype=np.float32), float(model.fps)
