"""Model folders as benchmark generators: MoMu both directions, MoFusion / HarmoGAN dance, refusals."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from tests.helpers.tiny_models import tiny_3d_model, tiny_harmogan_model, tiny_mofusion_model

from momu.cli.generate_io import GenerateInputError
from momu.following import DanceGenerator, MusicGenerator, from_model_dir


def _song(seconds: float = 3.0, sr: int = 16000) -> np.ndarray:
    t = np.arange(int(seconds * sr)) / sr
    return (0.3 * np.sin(2 * np.pi * 220 * t) * (np.sin(2 * np.pi * 2 * t) > 0)).astype(np.float32)


def test_momu_folder_generates_both_directions(tmp_path: Path) -> None:
    folder = tiny_3d_model(tmp_path)
    dance = from_model_dir(folder, "dance")
    music = from_model_dir(folder, "music")
    assert isinstance(dance, DanceGenerator) and isinstance(music, MusicGenerator)
    motion, fps = dance.generate(_song(), 16000, seed=0)
    assert motion.ndim == 3 and motion.shape[1:] == (21, 3) and fps > 0
    assert motion.shape[0] == pytest.approx(3.0 * fps, abs=2)
    audio, sr = music.generate(motion, fps, seed=0)
    assert audio.ndim == 1 and sr == 16000 and len(audio) / sr == pytest.approx(3.0, abs=0.2)


def test_beats_per_movement_needs_music_conditioned_on_beats(tmp_path: Path) -> None:
    """The tiny model's music is conditioned on the dance's latent alone: nothing to split."""
    folder = tiny_3d_model(tmp_path)
    with pytest.raises(GenerateInputError, match="is not conditioned on the dance's beats"):
        from_model_dir(folder, "music", beats_per_movement="ballroom")
    assert isinstance(from_model_dir(folder, "dance", beats_per_movement="ballroom"), DanceGenerator)


@pytest.mark.parametrize("make", [tiny_mofusion_model, tiny_harmogan_model])
def test_dance_only_methods_generate_dance_and_refuse_music(tmp_path: Path, make) -> None:  # type: ignore[no-untyped-def]
    folder = make(tmp_path / "m")
    motion, fps = from_model_dir(folder, "dance").generate(_song(6.0), 16000, seed=0)  # type: ignore[call-arg]
    assert motion.ndim == 3 and fps > 0
    with pytest.raises(GenerateInputError, match="cannot generate music"):
        from_model_dir(folder, "music")


def test_not_a_model_folder_is_one_line(tmp_path: Path) -> None:
    with pytest.raises(GenerateInputError, match="not a saved momu model"):
        from_model_dir(tmp_path)
