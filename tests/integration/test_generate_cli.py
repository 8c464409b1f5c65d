"""``momu generate`` as a user runs it: a song in, a playable mp4 with the song, a BVH and an npz out.

The model is the one shipped with momu (``momu/pretrained``); where an installation has none (a fresh
checkout before ``nox -s pretrain``) a tiny 3D model trained here stands in, so the command path is
tested either way. mp4 streams are checked with imageio-ffmpeg's ffmpeg binary (the one momu encodes
with); BVH files are loaded by ``bvhio``, a reader independent of the writer (upc-pymotion).
"""

from __future__ import annotations

import re
import subprocess
from pathlib import Path

import numpy as np
import pytest
import soundfile as sf
from tests.helpers.tiny_models import tiny_3d_model

from momu.cli import main
from momu.cli.generate_io import GenerateInputError, default_model_dir

bvhio = pytest.importorskip("bvhio")
imageio_ffmpeg = pytest.importorskip("imageio_ffmpeg")


@pytest.fixture(scope="module")
def model_args(tmp_path_factory: pytest.TempPathFactory) -> list[str]:
    """``[]`` (use the shipped model) or ``["--model", DIR]`` of a tiny stand-in."""
    try:
        default_model_dir("dance")
        return []
    except GenerateInputError:
        return ["--model", str(tiny_3d_model(tmp_path_factory.mktemp("tiny")))]


def _song(seconds: float, sr: int, channels: int) -> np.ndarray:
    """A click track at 120 bpm over a quiet tone."""
    t = np.arange(int(seconds * sr)) / sr
    clicks = np.exp(-((t % 0.5) / 0.01)) * np.sin(2 * np.pi * 1000 * t)
    x = (0.4 * clicks + 0.05 * np.sin(2 * np.pi * 220 * t)).astype(np.float32)
    return np.stack([x] * channels, axis=1)


def _streams(mp4: Path) -> str:
    proc = subprocess.run(
        [imageio_ffmpeg.get_ffmpeg_exe(), "-hide_banner", "-i", str(mp4)], capture_output=True
    )
    return proc.stderr.decode(errors="replace")


def _audio_seconds(mp4: Path) -> float:
    """Duration of the mp4's audio stream, decoded by ffmpeg."""
    cmd = [
        imageio_ffmpeg.get_ffmpeg_exe(),
        "-v",
        "error",
        "-i",
        str(mp4),
        "-vn",
        "-f",
        "f32le",
        "-ac",
        "1",
        "-",
    ]
    proc = subprocess.run(cmd, capture_output=True, check=True)
    info = _streams(mp4)
    rate = int(re.search(r"Audio: .*?, (\d+) Hz", info).group(1))  # type: ignore[union-attr]
    return len(proc.stdout) / 4 / rate


def _check_dance_outputs(out: Path, seconds: float) -> None:
    mp4, bvh, npz = out / "dance.mp4", out / "dance.bvh", out / "dance.npz"
    info = _streams(mp4)
    assert "Video: h264" in info and "Audio: aac" in info
    assert _audio_seconds(mp4) == pytest.approx(seconds, abs=0.1)
    with np.load(npz, allow_pickle=False) as data:
        joints, fps, skeleton = data["joints"], float(data["fps"]), str(data["skeleton"])
        names = [str(n) for n in data["joint_names"]]
        assert "seed" in str(data["provenance"])
    assert joints.ndim == 3 and joints.shape[2] == 3  # 3D motion
    assert joints.shape[0] / fps == pytest.approx(seconds, abs=0.1)
    root = bvhio.readAsHierarchy(str(bvh))
    assert set(names) <= {j.Name for j, _, _ in root.layout()}
    assert root.getKeyframeRange()[1] + 1 == joints.shape[0]
    # the npz and the BVH hold the same rigid motion: every joint of every frame within 1 mm, and one
    # length per bone for the whole dance (the model's limbs change length from frame to frame)
    from momu.features.bones import bone_lengths
    from momu.features.skeletons import get_skeleton

    for frame in range(joints.shape[0]):
        root.loadPose(frame)
        world = {j.Name: np.array(j.PositionWorld) for j, _, _ in root.layout()}
        err = np.linalg.norm(np.stack([world[n] for n in names]) - joints[frame], axis=-1)
        assert err.max() < 1e-3, f"frame {frame}: BVH and npz differ by {err.max() * 1000:.1f} mm"
    lengths = np.asarray(bone_lengths(joints.astype(np.float64), get_skeleton(skeleton).bones))
    assert (lengths.max(axis=0) - lengths.min(axis=0)).max() < 1e-5


def _dance(song: Path, out: Path, model_args: list[str]) -> int:
    return main(["generate", "dance", "--music", str(song), "--out", str(out), "--quiet", *model_args])


def test_dance_for_a_20_s_wav_song(tmp_path: Path, model_args: list[str]) -> None:
    song = tmp_path / "song.wav"
    sf.write(str(song), _song(20.0, 22050, 1), 22050)
    assert _dance(song, tmp_path / "out", model_args) == 0
    _check_dance_outputs(tmp_path / "out", 20.0)


def test_dance_for_a_10_s_stereo_44k_mp3(tmp_path: Path, model_args: list[str]) -> None:
    song = tmp_path / "song.mp3"
    sf.write(str(song), _song(10.0, 44100, 2), 44100, format="MP3")  # libsndfile >= 1.1 writes MP3
    assert sf.info(str(song)).channels == 2
    assert _dance(song, tmp_path / "out", model_args) == 0
    _check_dance_outputs(tmp_path / "out", 10.0)
    # music for the dance momu just wrote, from its BVH
    out = tmp_path / "music"
    bvh = tmp_path / "out" / "dance.bvh"
    assert main(["generate", "music", "--motion", str(bvh), "--out", str(out), "--quiet", *model_args]) == 0
    wav = sf.info(str(out / "music.wav"))
    assert wav.duration == pytest.approx(10.0, abs=0.15)
    assert "Audio: aac" in _streams(out / "music.mp4")


def test_music_for_a_dance_with_melody_dance(
    tmp_path: Path, shared_data: Path, model_args: list[str]
) -> None:
    folder = shared_data / "dance_with_melody" / "DANCE_W_1"
    if not folder.is_dir():
        pytest.skip(f"{folder} not found")
    out = tmp_path / "music.wav"
    args = ["generate", "music", "--motion", str(folder), "--seconds", "8", "--out", str(out), "--quiet"]
    assert main([*args, *model_args]) == 0
    assert sf.info(str(out)).duration == pytest.approx(8.0, abs=0.15)


def test_one_file_output_and_format_subsets(tmp_path: Path, model_args: list[str]) -> None:
    song = tmp_path / "s.flac"
    sf.write(str(song), _song(3.0, 48000, 2), 48000)
    assert (
        main(
            [
                "generate",
                "dance",
                "--music",
                str(song),
                "--out",
                str(tmp_path / "d.bvh"),
                "--quiet",
                *model_args,
            ]
        )
        == 0
    )
    assert (tmp_path / "d.bvh").read_text().startswith("HIERARCHY")
    out = tmp_path / "sub"
    assert (
        main(["generate", "dance", "--music", str(song), "--out", str(out), "--format", "npz", *model_args])
        == 0
    )
    assert sorted(p.name for p in out.iterdir()) == ["dance.npz"]


@pytest.fixture
def unloadable_model(tmp_path: Path, model_args: list[str]) -> list[str]:
    """A model folder whose record is fine but whose weights are missing: any error that is reported
    instead of the load failure was found before the model was loaded."""
    import shutil

    src = Path(model_args[1]) if model_args else default_model_dir("dance")
    folder = tmp_path / "record_only"
    folder.mkdir()
    shutil.copy(src / "momu.json", folder / "momu.json")
    return ["--model", str(folder)]


def test_bad_inputs_fail_in_one_line_before_the_model_loads(
    tmp_path: Path, unloadable_model: list[str], capsys: pytest.CaptureFixture[str]
) -> None:
    song = tmp_path / "song.wav"
    sf.write(str(song), _song(3.0, 16000, 1), 16000)
    junk = tmp_path / "junk.mp3"
    junk.write_bytes(b"this is not audio" * 100)
    a_file = tmp_path / "taken"
    a_file.write_text("x")
    np.save(tmp_path / "pose2d.npy", np.zeros((50, 14, 2), dtype=np.float32))
    cases = [
        (["dance", "--music", str(junk), "--out", str(tmp_path / "o")], "cannot read audio"),
        (["dance", "--music", str(tmp_path / "nope.wav"), "--out", str(tmp_path / "o")], "file not found"),
        (["dance", "--music", str(song), "--out", str(a_file)], "is a file"),
        (["dance", "--music", str(song), "--out", str(tmp_path / "x.mov")], "unknown output type '.mov'"),
        (["dance", "--music", str(song), "--out", str(tmp_path / "o"), "--format", "gif"], "--format"),
        (["music", "--motion", str(tmp_path / "pose2d.npy"), "--out", str(tmp_path / "o")], "cannot convert"),
    ]
    for argv, message in cases:
        code = main(["generate", *argv, *unloadable_model])
        err = capsys.readouterr().err
        assert code == 2, argv
        assert message in err and err.count("\n") == 1, err
    assert not (tmp_path / "o").exists() and not (tmp_path / "x.mov").exists()
    # the same folder does fail to load once every input is fine
    assert (
        main(["generate", "dance", "--music", str(song), "--out", str(tmp_path / "o"), *unloadable_model])
        == 2
    )
    assert "cannot load" in capsys.readouterr().err


def test_short_silent_and_odd_rate_songs_warn(tmp_path: Path, caplog: pytest.LogCaptureFixture) -> None:
    from momu.cli.generate_io import read_song, song_warnings

    quiet = tmp_path / "quiet.wav"
    sf.write(str(quiet), np.zeros((4000, 1), dtype=np.float32), 4000)
    with caplog.at_level("WARNING"):
        lines = song_warnings(read_song(quiet))
    assert any("only 1.00 s" in w for w in lines)
    assert any("silent" in w for w in lines)
    assert any("4000 Hz" in w for w in lines)
    assert len(caplog.records) == 3
    loud = tmp_path / "loud.wav"
    sf.write(str(loud), _song(3.0, 16000, 1), 16000)
    assert song_warnings(read_song(loud)) == []


# ---------------------------------------------------------------- MoFusion and HarmoGAN model folders


@pytest.fixture(scope="module")
def method_models(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    """Tiny random-weight MoFusion (music, text) and HarmoGAN model folders (built, not trained)."""
    from tests.helpers.tiny_models import tiny_harmogan_model, tiny_mofusion_model

    root = tmp_path_factory.mktemp("methods")
    return {
        "mofusion": tiny_mofusion_model(root / "mofusion-music", "music"),
        "mofusion-text": tiny_mofusion_model(root / "mofusion-text", "text"),
        "harmogan": tiny_harmogan_model(root / "harmogan"),
    }


@pytest.mark.parametrize(
    ("method", "seconds", "joints", "fps", "skeleton"),
    [("mofusion", 12.0, 24, 20.0, "smpl24"), ("harmogan", 25.0, 21, 15.0, "dwm21")],
)
def test_dance_from_a_mofusion_or_harmogan_model(
    tmp_path: Path,
    method_models: dict[str, Path],
    method: str,
    seconds: float,
    joints: int,
    fps: float,
    skeleton: str,
) -> None:
    song = tmp_path / "song.wav"
    sf.write(str(song), _song(seconds, 22050, 1), 22050)
    out = tmp_path / "out"
    argv = ["--model", str(method_models[method]), "--seed", "3"]
    assert _dance(song, out, argv) == 0
    _check_dance_outputs(out, seconds)
    with np.load(out / "dance.npz", allow_pickle=False) as data:
        assert data["joints"].shape[1:] == (joints, 3) and np.isfinite(data["joints"]).all()
        assert float(data["fps"]) == fps and str(data["skeleton"]) == skeleton
        first = data["joints"].copy()
        assert f'"method": "{method}"' in str(data["provenance"])
    assert _dance(song, tmp_path / "again", argv) == 0  # the same seed gives the same dance
    with np.load(tmp_path / "again" / "dance.npz", allow_pickle=False) as data:
        np.testing.assert_array_equal(data["joints"], first)


def test_text_to_motion_from_a_mofusion_text_model(tmp_path: Path, method_models: dict[str, Path]) -> None:
    out = tmp_path / "out"
    argv = ["generate", "text", "--caption", "a person walks forward", "--seconds", "3"]
    assert main([*argv, "--model", str(method_models["mofusion-text"]), "--out", str(out), "--quiet"]) == 0
    assert sorted(p.name for p in out.iterdir()) == ["motion.bvh", "motion.mp4", "motion.npz"]
    info = _streams(out / "motion.mp4")
    assert "Video: h264" in info and "Audio:" not in info  # no sound for a caption
    with np.load(out / "motion.npz", allow_pickle=False) as data:
        joints = data["joints"]
        assert joints.shape == (60, 22, 3) and float(data["fps"]) == 20.0
        assert str(data["skeleton"]) == "humanml22" and "a person walks forward" in str(data["provenance"])
    root = bvhio.readAsHierarchy(str(out / "motion.bvh"))
    assert root.getKeyframeRange()[1] + 1 == joints.shape[0]
    one = tmp_path / "m.bvh"
    assert main([*argv, "--model", str(method_models["mofusion-text"]), "--out", str(one)]) == 0
    assert one.read_text().startswith("HIERARCHY")


def _record_only(folder: Path, src: Path, name: str) -> Path:
    import shutil

    folder.mkdir(parents=True)
    shutil.copy(src / name, folder / name)
    return folder


def test_what_a_method_cannot_do_fails_before_loading(
    tmp_path: Path, method_models: dict[str, Path], capsys: pytest.CaptureFixture[str]
) -> None:
    """Each model folder holds only its record (no weights): every refusal comes before any load."""
    music = _record_only(tmp_path / "mf", method_models["mofusion"], "mofusion.json")
    text = _record_only(tmp_path / "mt", method_models["mofusion-text"], "mofusion.json")
    gan = _record_only(tmp_path / "hg", method_models["harmogan"], "harmogan.json")
    song = tmp_path / "song.wav"
    sf.write(str(song), _song(3.3, 16000, 1), 16000)
    out = ["--out", str(tmp_path / "o")]
    dance = ["dance", "--music", str(song), *out]
    np.save(tmp_path / "dance.npy", np.zeros((30, 21, 3), dtype=np.float32))
    cases = [
        (
            [
                "music",
                "--motion",
                str(tmp_path / "dance.npy"),
                "--skeleton",
                "dwm21",
                "--model",
                str(gan),
                *out,
            ],
            gan,
            "`momu generate music` needs a MoMu model",
        ),
        (["joint", "--model", str(music), *out], music, "`momu generate joint` needs a MoMu model"),
        (["text", "--caption", "a person jumps", "--model", str(music), *out], music, "MoFusion text→motion"),
        (["text", "--caption", "a person jumps", "--model", str(gan), *out], gan, "MoFusion text→motion"),
        ([*dance, "--model", str(text)], text, "use `momu generate text"),
        ([*dance, "--model", str(music), "--guidance", "2"], music, "without classifier-free guidance"),
        ([*dance, "--model", str(gan), "--guidance", "2"], gan, "--guidance is for MoMu models only"),
    ]
    for argv, folder, message in cases:
        assert main(["generate", *argv]) == 2, argv
        err = capsys.readouterr().err
        assert err.count("\n") == 1 and err.startswith(f"momu generate: error: --model {folder}: "), err
        assert message in err, err
    assert main(["generate", "text", "--caption", "a person jumps", *out]) == 2  # no shipped text model
    err = capsys.readouterr().err
    assert err.startswith("momu generate: error: --model DIR is needed") and err.count("\n") == 1, err
    # a dit backbone's positional table bounds the length (read from the part's config, not loaded)
    (music / "backbone").mkdir()
    (music / "backbone" / "config.json").write_text(
        '{"kind": "backbones", "name": "dit", "config": {"max_length": 40}}'
    )
    assert main(["generate", *dance, "--model", str(music)]) == 2
    err = capsys.readouterr().err
    assert "at most 40 frames (2.0 s at 20 fps)" in err and err.count("\n") == 1, err
    # once every input is fine, the missing weights are what fails
    assert main(["generate", *dance, "--model", str(gan)]) == 2
    assert f"--model {gan}: cannot load" in capsys.readouterr().err
    assert not (tmp_path / "o").exists()


def test_a_training_output_folder_finds_its_model(tmp_path: Path, method_models: dict[str, Path]) -> None:
    import shutil

    shutil.copytree(method_models["harmogan"], tmp_path / "run" / "models" / "harmogan-abc")
    song = tmp_path / "song.wav"
    sf.write(str(song), _song(2.5, 16000, 1), 16000)
    out = tmp_path / "d.npz"
    assert _dance(song, out, ["--model", str(tmp_path / "run")]) == 0
    with np.load(out, allow_pickle=False) as data:
        assert str(data["skeleton"]) == "dwm21"
