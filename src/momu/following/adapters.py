"""Generators the benchmark can run, and adapters that make any saved model one.

The two protocols are all a model needs to offer (a plugin's model included):

* :class:`DanceGenerator` — ``generate(audio, sample_rate, seed) -> (motion (T, J, 3), fps)``
  (music → dance);
* :class:`MusicGenerator` — ``generate(motion (T, J, 3), fps, seed) -> (audio, sample_rate)``
  (dance → music; ``motion`` is global joint positions of the data's skeleton).

:func:`from_model_dir` wraps a folder saved by ``momu train`` or a recipe (MoMu: both directions;
MoFusion and HarmoGAN: music → dance only), loading it once, the way ``momu generate --model DIR`` does
(:mod:`momu.cli.generate_io`, :mod:`momu.cli.generate_methods`); :func:`shipped` is the model shipped
with momu. Errors about the folder are :class:`~momu.cli.generate_io.GenerateInputError` lines.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any, Protocol, runtime_checkable

import numpy as np

from momu.cli.generate_io import GenerateInputError, ModelRecord, Song, default_model_dir, model_record

__all__ = ["DanceGenerator", "MusicGenerator", "from_model_dir", "shipped", "model_name"]


@runtime_checkable
class DanceGenerator(Protocol):
    """Music → dance: ``generate(audio (S,), sample_rate, seed) -> (motion (T, J, 3), fps)``."""

    def generate(self, audio: np.ndarray, sample_rate: int, seed: int) -> tuple[np.ndarray, float]: ...


@runtime_checkable
class MusicGenerator(Protocol):
    """Dance → music: ``generate(motion (T, J, 3), fps, seed) -> (audio (S,), sample_rate)``."""

    def generate(self, motion: np.ndarray, fps: float, seed: int) -> tuple[np.ndarray, int]: ...


class _MoMuDance:
    def __init__(self, model: Any) -> None:
        self.model = model

    def generate(self, audio: np.ndarray, sample_rate: int, seed: int) -> tuple[np.ndarray, float]:
        from momu.generation.momu_long import music_to_motion_long

        (motion,) = music_to_motion_long(self.model, [np.asarray(audio, np.float32)], sample_rate, [seed])
        return np.asarray(motion), float(self.model.rates.motion_fps)


class _MoMuMusic:
    """MoMu dance → music; the motion is mapped to the model's skeleton (by its joint count) and stood on
    the floor like ``momu generate music`` does."""

    def __init__(self, model: Any, skeleton: str, beats_per_movement: int | str = "auto") -> None:
        self.model = model
        self.skeleton = skeleton
        self.beats_per_movement = beats_per_movement

    def generate(self, motion: np.ndarray, fps: float, seed: int) -> tuple[np.ndarray, int]:
        from momu.cli.eval_inputs import _SKELETONS
        from momu.features.convert import convert_motion, stand_on_floor
        from momu.features.skeletons import get_skeleton
        from momu.generation.momu_long import motion_to_music_long

        x = np.asarray(motion, dtype=np.float64)
        target = get_skeleton(self.skeleton)
        if x.shape[1:] != (target.num_joints, target.dims):
            source = _SKELETONS.get((x.shape[1], x.shape[2]))
            if source is None:
                raise ValueError(f"motion of {x.shape[1:]} joints × dims does not convert to {self.skeleton}")
            x = convert_motion(x, source, self.skeleton)
        if target.dims == 3:
            x = stand_on_floor(x, target.root)
        if self.beats_per_movement != 1:
            from momu.features.ballroom_metre import beats_for

            self.model.use_beats_per_movement(beats_for(self.beats_per_movement, x, fps, self.skeleton))
        (audio,) = motion_to_music_long(self.model, [x.astype(np.float32)], fps, [seed])
        return np.asarray(audio), int(self.model.rates.sample_rate)


class _MethodDance:
    """A MoFusion or HarmoGAN music → dance model (:func:`momu.cli.generate_methods.method_dance`)."""

    def __init__(self, record: ModelRecord, model: Any) -> None:
        self.record = record
        self.model = model

    def generate(self, audio: np.ndarray, sample_rate: int, seed: int) -> tuple[np.ndarray, float]:
        from momu.cli.generate_methods import method_dance

        y = np.asarray(audio, dtype=np.float32)
        duration = len(y) / sample_rate
        song = Song(y, int(sample_rate), 1, duration, duration, Path("<benchmark input>"))
        return method_dance(self.record, self.model, song, seed)


def model_name(folder: Path) -> str:
    """A row name for a model folder: ``<method>:<folder name>``."""
    return f"{model_record(Path(folder)).method}:{Path(folder).name}"


def from_model_dir(
    folder: str | Path, direction: str = "dance", beats_per_movement: int | str = "auto"
) -> DanceGenerator | MusicGenerator:
    """The generator of ``direction`` (``"dance"``: music → dance, ``"music"``: dance → music) of a saved
    model folder (``momu.json``, ``mofusion.json`` or ``harmogan.json``), loaded once.
    ``beats_per_movement`` (MoMu's music only): N, ``"ballroom"`` or ``"auto"``, as ``momu generate
    music --beats-per-movement`` (:mod:`momu.features.ballroom_metre`; ``"auto"``, the default, is 1 for
    a model whose music is not conditioned on the dance's beats).

    Raises:
        GenerateInputError: not a model folder, a model that cannot generate ``direction`` (MoFusion and
            HarmoGAN generate dance only; a MoFusion text model neither), or a folder that fails to load.
    """
    record = model_record(Path(folder))
    if direction not in ("dance", "music"):
        raise ValueError(f"direction: expected 'dance' or 'music', got {direction!r}")
    if record.method == "momu":
        from momu.methods.momu import MoMuModel

        try:
            model = MoMuModel.load(record.folder)
        except (OSError, ValueError, KeyError) as exc:
            raise GenerateInputError(f"--model {record.folder}: cannot load: {exc}") from None
        if beats_per_movement == "auto" and not model.conditions.reads_dance_beats:
            beats_per_movement = 1
        if direction == "music" and beats_per_movement != 1:
            try:
                model.conditions.with_beats_per_movement(2)  # its music has beats to split (a check)
            except ValueError as exc:
                raise GenerateInputError(f"--beats-per-movement: --model {record.folder}: {exc}") from None
        if direction == "dance":
            return _MoMuDance(model)
        return _MoMuMusic(model, model.skeleton, beats_per_movement)
    from momu.cli.generate_methods import describe, load_method_model

    if direction != "dance" or record.task != "music":
        raise GenerateInputError(
            f"--model {record.folder}: {describe(record)} cannot generate "
            f"{'music from a dance' if direction == 'music' else 'dance from music'}"
        )
    return _MethodDance(record, load_method_model(record))


def shipped(direction: str = "dance") -> DanceGenerator | MusicGenerator:
    """The model shipped with momu for ``direction`` (``momu/pretrained/index.json``)."""
    return from_model_dir(default_model_dir(direction), direction)
