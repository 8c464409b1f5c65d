"""``momu generate music --beats-per-movement N``: music with N beats per movement of the dance.

θ_a reads a dance's beats at the dominant period of its movements; a waltz dancer who sways once per
bar gives the bar. ``--beats-per-movement 3`` splits each of those beats into three
(``motion_rhythm``'s ``subdivide``), so the music's condition says "a beat every third of a movement".
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from tests.helpers.tiny_models import tiny_3d_model

from momu.cli import main
from momu.cli.generate_io import GenerateInputError, default_model_dir
from momu.data.synth.dataset import SynthConfig, generate_clip
from momu.export import write_motion_npz


@pytest.fixture(scope="module")
def dance(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, np.ndarray, float]:
    clip = generate_clip(SynthConfig(num_clips=1, min_seconds=8.0, max_seconds=8.0, skeleton="dwm21"), 0)
    motion = np.asarray(clip.motion, dtype=np.float64)
    if clip.trajectory is not None:
        motion = motion + clip.trajectory[:, None]
    path = write_motion_npz(tmp_path_factory.mktemp("dance") / "dance.npz", motion, clip.fps, "dwm21")
    return path, motion, clip.fps


def test_the_music_condition_gets_n_beats_per_movement(dance: tuple[Path, np.ndarray, float]) -> None:
    try:
        folder = default_model_dir("music")
    except GenerateInputError:
        pytest.skip("no shipped model in this installation")
    from momu.methods.momu import MoMuModel

    model = MoMuModel.load(folder)
    _, motion, fps = dance
    tempo = model.conditions.from_motion.channels.index("log2_tempo")
    plain = model.condition_from_motion(motion, fps).numpy()
    model.use_beats_per_movement(3)
    split = model.condition_from_motion(motion, fps).numpy()
    # three times the tempo (log2 3 more), the dance's own envelope unchanged
    assert np.median(split[:, tempo] - plain[:, tempo]) == pytest.approx(np.log2(3.0), abs=0.02)
    np.testing.assert_array_equal(split[:, -1], plain[:, -1])
    model.use_beats_per_movement(1)
    np.testing.assert_array_equal(model.condition_from_motion(motion, fps).numpy(), plain)


def test_bad_beats_per_movement_fail_in_one_line_writing_nothing(
    dance: tuple[Path, np.ndarray, float], tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    path, _, _ = dance
    out = tmp_path / "o"
    base = ["generate", "music", "--motion", str(path), "--out", str(out)]
    for bad in ("0", "9", "waltz"):
        assert main([*base, "--beats-per-movement", bad]) == 2
        err = capsys.readouterr().err
        assert (
            f"--beats-per-movement: must be 1 to 8, ballroom or auto, got '{bad}'" in err
            and err.count("\n") == 1
        )
    # a model whose music is conditioned on the dance's latent alone has no beats to split
    tiny = tiny_3d_model(tmp_path / "tiny")
    assert main([*base, "--beats-per-movement", "3", "--model", str(tiny), "--quiet"]) == 2
    err = capsys.readouterr().err
    assert "is not conditioned on the dance's beats" in err and err.count("\n") == 1
    assert not out.exists()


def _music_said(
    caplog: pytest.LogCaptureFixture, motion: Path, out: Path, rule: str, *options: str
) -> list[str]:
    """``momu generate music --motion motion --out out *options`` (it must write ``out``): the INFO lines
    that say what ``rule`` (``auto`` / ``ballroom``) read."""
    caplog.clear()
    with caplog.at_level("INFO"):
        assert main(["generate", "music", "--motion", str(motion), "--out", str(out), *options]) == 0
    assert out.is_file()
    return [r.getMessage() for r in caplog.records if r.getMessage().startswith(f"{rule}:")]


def test_ballroom_reads_the_beats_per_movement_from_the_dance(
    dance: tuple[Path, np.ndarray, float], tmp_path: Path, caplog: pytest.LogCaptureFixture
) -> None:
    try:
        default_model_dir("music")
    except GenerateInputError:
        pytest.skip("no shipped model in this installation")
    path, _, _ = dance
    said = _music_said(caplog, path, tmp_path / "music.wav", "ballroom", "--beats-per-movement", "ballroom")
    assert len(said) == 1 and said[0].endswith(("2 beats per movement", "3 beats per movement")), said


def test_auto_is_the_default_and_says_what_it_read(
    dance: tuple[Path, np.ndarray, float], tmp_path: Path, caplog: pytest.LogCaptureFixture
) -> None:
    """``momu generate music`` reads the beats per movement (``auto``) unless told; a model whose music
    does not read the dance's beats is left as it is, silently."""
    path, motion, fps = dance
    tiny = tiny_3d_model(tmp_path / "tiny")
    assert not _music_said(caplog, path, tmp_path / "a.wav", "auto", "--model", str(tiny), "--quiet")
    try:
        default_model_dir("music")
    except GenerateInputError:
        pytest.skip("no shipped model in this installation")
    said = _music_said(caplog, path, tmp_path / "b.wav", "auto", "--quiet")
    from momu.features.ballroom_metre import beats_for

    n = beats_for("auto", motion, fps, "dwm21")
    assert len(said) == 1 and said[0].endswith(f"{n} beat{'s' if n > 1 else ''} per movement"), said


def test_the_benchmark_adapter_reads_ballroom_beats_per_dance(dance: tuple[Path, np.ndarray, float]) -> None:
    """``recipes/music_following.py --beats-per-movement ballroom``: each dance the generator is given is
    read anew (the benchmark hands it dances of different styles)."""
    try:
        folder = default_model_dir("music")
    except GenerateInputError:
        pytest.skip("no shipped model in this installation")
    from momu.features.ballroom_metre import ballroom_beats_per_movement
    from momu.following import from_model_dir

    _, motion, fps = dance
    generator = from_model_dir(folder, "music", beats_per_movement="ballroom")
    audio, _ = generator.generate(motion[: int(4 * fps)], fps, seed=0)
    assert audio.ndim == 1
    expected = ballroom_beats_per_movement(motion[: int(4 * fps)], fps, "dwm21")
    assert generator.model.conditions.from_motion.cfg.subdivide == expected  # type: ignore[attr-defined]
