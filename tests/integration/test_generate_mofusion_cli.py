"""``momu generate forecast | inbetween | edit``: MoFusion's inpainting tasks as a user runs them.

Tiny random-weight MoFusion models (``tests/helpers/tiny_models.py``; their motion means nothing) run
each command end to end; what the commands promise is checked on the arrays written: the seed frames,
the keyframes and everything outside an edit are the input motion — converted to the model's skeleton
and 20 fps — bit for bit; the rest is generated and depends on ``--seed``. The refusals use model
folders that hold only their record (no weights), so each one is shown to come before any load.
"""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import numpy as np
import pytest
import soundfile as sf
from tests.helpers.tiny_models import tiny_mofusion_model

from momu.cli import main
from momu.data.motion_files import read_motion_file
from momu.export import write_bvh, write_motion_npz
from momu.features.convert import convert_motion
from momu.methods.mofusion.data import resample_motion

imageio_ffmpeg = pytest.importorskip("imageio_ffmpeg")


@pytest.fixture(scope="module")
def models(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    root = tmp_path_factory.mktemp("mofusion")
    return {task: tiny_mofusion_model(root / task, task) for task in ("music", "text")}


def _motion(frames: int, joints: int, fps: float, shift: float = 3.0) -> np.ndarray:
    """A smooth float32 motion standing ~1 m up, ``shift`` metres off the origin (a user's coordinates)."""
    t = np.arange(frames)[:, None, None] / fps
    base = np.random.default_rng(joints).normal(0.0, 0.3, (1, joints, 3))
    x = base + 0.1 * np.sin(2 * np.pi * t + np.arange(3)) + np.array([shift, 1.0, -shift])
    return x.astype(np.float32)


def _song(path: Path, seconds: float, sr: int = 22050) -> Path:
    t = np.arange(int(seconds * sr)) / sr
    clicks = np.exp(-((t % 0.5) / 0.01)) * np.sin(2 * np.pi * 1000 * t)
    sf.write(str(path), (0.4 * clicks + 0.05 * np.sin(2 * np.pi * 220 * t)).astype(np.float32), sr)
    return path


def _npz(path: Path, motion: np.ndarray, fps: float, skeleton: str) -> Path:
    return write_motion_npz(path, motion, fps, skeleton)


def _joints(path: Path) -> tuple[np.ndarray, dict]:
    with np.load(path, allow_pickle=False) as data:
        assert float(data["fps"]) == 20.0
        return data["joints"], json.loads(str(data["provenance"]))


def _run(*argv: object) -> int:
    return main(["generate", *map(str, argv), "--quiet"])


def test_forecast_keeps_the_seed_and_continues_for_the_song(tmp_path: Path, models: dict[str, Path]) -> None:
    seed_motion = _motion(50, 24, 20.0)  # 2.5 s at the model's rate and skeleton: compared to the file
    motion = _npz(tmp_path / "seed.npz", seed_motion, 20.0, "smpl24")
    song = _song(tmp_path / "song.wav", 6.0)
    out = tmp_path / "out"
    assert (
        _run("forecast", "--model", models["music"], "--motion", motion, "--music", song, "--out", out) == 0
    )
    assert sorted(p.name for p in out.iterdir()) == ["forecast.bvh", "forecast.mp4", "forecast.npz"]
    joints, prov = _joints(out / "forecast.npz")
    assert joints.shape == (120, 24, 3) and np.isfinite(joints).all()  # as long as the song
    np.testing.assert_array_equal(joints[:40], seed_motion[:40])  # §4.4: S = 40 frames = 2 s, exactly
    assert not np.allclose(joints[40:50], seed_motion[40:50], atol=1e-3)  # the rest is generated
    assert prov["kept"]["seed_frames"] == 40 and prov["music"]["path"] == str(song)
    # the model saw the seed on the floor and centred; its forecast is moved back beside the seed (3 m off
    # the origin), not left at the origin
    assert abs(joints[40:, 0, 0].mean() - seed_motion[:40, 0, 0].mean()) < 1.0
    assert "Audio: aac" in _streams(out / "forecast.mp4")
    # per-item seeds: the same seed, the same forecast; another seed, another forecast, the same seed frames
    again, other = tmp_path / "again.npz", tmp_path / "other.npz"
    args = ("forecast", "--model", models["music"], "--motion", motion, "--music", song)
    assert _run(*args, "--out", again) == 0 and _run(*args, "--seed", 5, "--out", other) == 0
    np.testing.assert_array_equal(_joints(again)[0], joints)
    changed = _joints(other)[0]
    np.testing.assert_array_equal(changed[:40], seed_motion[:40])
    assert not np.allclose(changed[40:], joints[40:], atol=1e-4)


def test_forecast_with_a_caption_converts_the_seed_to_the_model(
    tmp_path: Path, models: dict[str, Path]
) -> None:
    """A Dance with Melody-layout (dwm21) seed at 25 fps, root-centred with its trajectory apart, for a
    humanml22 text model: the kept frames are the converted motion at 20 fps."""
    dwm = _motion(60, 21, 25.0, shift=0.0)
    trajectory = np.stack([np.linspace(1.0, 2.0, 60), np.zeros(60), np.zeros(60)], axis=1)
    seed = write_motion_npz(tmp_path / "dwm.npz", dwm, 25.0, "dwm21", trajectory=trajectory)
    out = tmp_path / "f.npz"
    argv = ("--motion", seed, "--caption", "a person  jumps", "--seed-seconds", 1.5, "--seconds", 3)
    assert _run("forecast", "--model", models["text"], *argv, "--out", out) == 0
    joints, prov = _joints(out)
    given = read_motion_file(seed)
    expect = resample_motion(
        convert_motion(given.motion, "dwm21", "humanml22", trajectory=given.trajectory), 25.0, 20.0
    )
    assert joints.shape == (60, 22, 3) and prov["caption"] == "a person jumps"
    np.testing.assert_array_equal(joints[:30], expect[:30].astype(np.float32))


def test_inbetween_keeps_the_keyframes(tmp_path: Path, models: dict[str, Path]) -> None:
    dance = _motion(243, 24, 60.0)  # 4.03 s at 60 fps: 81 frames at the model's 20 fps (odd)
    bvh = write_bvh(tmp_path / "dance.bvh", dance, 60.0, "smpl24")
    song = _song(tmp_path / "song.wav", 4.1)
    out = tmp_path / "out"
    argv = ("--motion", bvh, "--keyframes", "0,1.5,every:2,end", "--music", song, "--format", "npz,mp4")
    assert _run("inbetween", "--model", models["music"], *argv, "--out", out) == 0
    joints, prov = _joints(out / "inbetween.npz")
    read = read_motion_file(bvh)
    expect = resample_motion(read.motion, read.fps, 20.0).astype(np.float32)
    keys = [0, 30, 40, 80]
    assert joints.shape == (81, 24, 3) and prov["kept"]["keyframes"] == keys
    np.testing.assert_array_equal(joints[keys], expect[keys])
    between = np.setdiff1d(np.arange(81), keys)
    assert not np.isclose(joints[between], expect[between], atol=1e-3).all(axis=(1, 2)).any()
    # a text model in-betweens for a caption
    text = tmp_path / "t.npz"
    npz = _npz(tmp_path / "m22.npz", _motion(41, 22, 20.0), 20.0, "humanml22")
    argv = ("--motion", npz, "--keyframes", "0,end", "--caption", "a person walks")
    assert _run("inbetween", "--model", models["text"], *argv, "--out", text) == 0
    np.testing.assert_array_equal(_joints(text)[0][[0, 40]], _motion(41, 22, 20.0)[[0, 40]])


def test_edit_changes_only_the_region(tmp_path: Path, models: dict[str, Path]) -> None:
    motion = _motion(81, 22, 20.0)
    npz = _npz(tmp_path / "walk.npz", motion, 20.0, "humanml22")
    base = ("edit", "--model", models["text"], "--motion", npz, "--caption", "a person waves")
    out = tmp_path / "arm.npz"
    assert _run(*base, "--time", "1:2.5", "--joints", "r_shoulder+", "--out", out) == 0
    joints, prov = _joints(out)
    region = np.zeros((81, 22), dtype=bool)
    region[20:50, [17, 19, 21]] = True  # r_shoulder+: r_shoulder, r_elbow, r_wrist (humanml22 order)
    np.testing.assert_array_equal(joints[~region], motion[~region])  # outside the edit: unchanged exactly
    assert not np.isclose(joints[region], motion[region], atol=1e-3).all(axis=-1).any()
    assert prov["regenerated"] == {"frames": [[20, 50]], "joints": ["r_shoulder", "r_elbow", "r_wrist"]}
    assert prov["not_evaluated_by_the_paper"] is True
    # two stretches, every joint
    out = tmp_path / "spans.npz"
    assert _run(*base, "--time", ":0.5,3.5:", "--out", out) == 0
    joints = _joints(out)[0]
    np.testing.assert_array_equal(joints[10:70], motion[10:70])
    assert not np.isclose(joints[:10], motion[:10], atol=1e-3).all()
    # regenerating the root (the pelvis: the pose vector's translation) moves the kept joints with it:
    # they keep their place relative to the root exactly (up to one float32 rounding)
    out = tmp_path / "root.npz"
    assert _run(*base, "--time", "1:2", "--joints", "pelvis", "--out", out) == 0
    joints = _joints(out)[0]
    np.testing.assert_array_equal(joints[:20], motion[:20])
    np.testing.assert_array_equal(joints[40:], motion[40:])
    rel, rel_in = joints[20:40, 1:] - joints[20:40, :1], motion[20:40, 1:] - motion[20:40, :1]
    np.testing.assert_allclose(rel, rel_in, atol=2e-6)
    assert not np.allclose(joints[20:40, 0], motion[20:40, 0], atol=1e-3)


def _streams(mp4: Path) -> str:
    import subprocess

    proc = subprocess.run(
        [imageio_ffmpeg.get_ffmpeg_exe(), "-hide_banner", "-i", str(mp4)], capture_output=True
    )
    return proc.stderr.decode(errors="replace")


def _record_only(folder: Path, src: Path) -> Path:
    folder.mkdir(parents=True)
    shutil.copy(src / "mofusion.json", folder / "mofusion.json")
    return folder


def test_bad_inputs_fail_in_one_line_before_the_model_loads(
    tmp_path: Path, models: dict[str, Path], capsys: pytest.CaptureFixture[str]
) -> None:
    """Each case exits 2 with one line naming the option or file, writes nothing, and comes before the
    model loads (the folders hold only their record: a load would fail with 'cannot load')."""
    music = _record_only(tmp_path / "mf", models["music"])
    text = _record_only(tmp_path / "mt", models["text"])
    gan = tmp_path / "hg"
    gan.mkdir()
    (gan / "harmogan.json").write_text(json.dumps({"format": 1, "method": "harmogan", "skeleton": "dwm21"}))
    momu = tmp_path / "mm"
    momu.mkdir()
    (momu / "momu.json").write_text(json.dumps({"method": "momu", "skeleton": "dwm21"}))
    m24 = _npz(tmp_path / "m24.npz", _motion(60, 24, 20.0), 20.0, "smpl24")  # 3 s
    short = _npz(tmp_path / "short.npz", _motion(6, 24, 20.0), 20.0, "smpl24")  # 0.3 s
    np.save(tmp_path / "pose2d.npy", np.zeros((50, 14, 2), dtype=np.float32))
    (tmp_path / "junk.npz").write_bytes(b"not a zip" * 10)
    song = _song(tmp_path / "song.wav", 2.0)
    o = ("--out", tmp_path / "o")
    fm = ("forecast", "--model", music, "--motion", m24, *o)
    ft = ("forecast", "--model", text, "--motion", m24, *o)
    im = ("inbetween", "--model", music, "--motion", m24, *o)
    et = ("edit", "--model", text, "--motion", m24, "--caption", "a person waves", *o)
    cases = [
        # what the model folder cannot do
        (
            (*fm[:2], momu, *fm[3:], "--music", song),
            f"--model {momu}: a MoMu model; `momu generate forecast`",
        ),
        ((*im[:2], gan, *im[3:], "--keyframes", "0", "--music", song), "needs a MoFusion model"),
        ((*et[:2], music, *et[3:], "--time", "1:2"), "`momu generate edit` (text-based editing) needs"),
        (("forecast", "--motion", m24, "--music", song, *o), "--model DIR is needed"),
        # the condition must match the model's
        ((*fm, "--caption", "a person jumps"), "--caption: --model"),
        ((*ft, "--music", song), "--music: --model"),
        (fm, "--music SONG is needed"),
        (ft, "--caption TEXT is needed"),
        ((*ft, "--caption", "  "), "--caption is empty"),
        # the motion
        (("forecast", "--model", music, "--motion", tmp_path / "nope.npz", "--music", song, *o), "nope.npz"),
        (("forecast", "--model", music, "--motion", tmp_path / "junk.npz", "--music", song, *o), "junk.npz"),
        (("forecast", "--model", music, "--motion", tmp_path / "pose2d.npy", "--music", song, *o), "convert"),
        (
            ("inbetween", "--model", music, "--motion", short, "--keyframes", "0", "--music", song, *o),
            "too short",
        ),
        # forecasting lengths
        ((*ft, "--caption", "x", "--seed-seconds", "4"), "shorter than the --seed-seconds 4 seed"),
        ((*ft, "--caption", "x", "--seconds", "2"), "--seconds: 2.00 s leaves nothing to forecast"),
        ((*ft, "--caption", "x", "--seed-seconds", "0"), "--seed-seconds must be > 0"),
        ((*fm, "--music", song, "--seconds", "5"), f"--music {song}: 2.00 s of music for 5.00 s"),
        # keyframes, stretches, joints
        ((*im, "--music", song, "--keyframes", "abc"), "--keyframes: keyframe 'abc' is not a time"),
        ((*im, "--music", song, "--keyframes", "0,9"), "--keyframes: 9 s is past the end"),
        ((*im, "--music", song, "--keyframes", "0,,1"), "--keyframes '0,,1': an empty item"),
        ((*im, "--music", song, "--keyframes", "every:0.01"), "a step under one frame"),
        ((*im, "--music", song, "--keyframes", "every:0.05"), "every frame is a keyframe"),
        ((*im, "--music", song, "--keyframes", "0"), f"--music {song}: 2.00 s of music for 3.00 s of motion"),
        ((*et, "--time", "2:1"), "--time 2:1: covers no frame"),
        ((*et, "--time", "1-2"), "--time 1-2: expected START:END"),
        ((*et, "--time", "0:9"), "--time 0:9: 9 s is past the end"),
        ((*et, "--joints", "l_arm"), "--joints: humanml22 has no joint 'l_arm'"),
        (et, "--time START:END and/or --joints NAMES is needed"),
        ((*et, "--time", "0:"), "nothing would be kept"),
    ]
    for argv, message in cases:
        assert _run(*argv) == 2, argv
        err = capsys.readouterr().err
        assert err.count("\n") == 1 and err.startswith("momu generate: error: "), (argv, err)
        assert message in err, (argv, err)
    assert not (tmp_path / "o").exists()
    # once every input is fine, the missing weights are what fails
    assert _run(*ft, "--caption", "a person jumps") == 2
    assert f"--model {text}: cannot load" in capsys.readouterr().err
    assert not (tmp_path / "o").exists()


def test_forecast_a_dance_with_melody_dance_with_its_song(
    tmp_path: Path, models: dict[str, Path], shared_data: Path
) -> None:
    """A real dance (dwm21, 25 fps, root-centred with its trajectory) seeds a smpl24 music model."""
    folder = shared_data / "dance_with_melody" / "DANCE_W_1"
    if not folder.is_dir():
        pytest.skip(f"{folder} not found")
    out = tmp_path / "f.npz"
    argv = ("--motion", folder, "--music", folder / "audio.mp3", "--seconds", 5)
    assert _run("forecast", "--model", models["music"], *argv, "--out", out) == 0
    joints, prov = _joints(out)
    given = read_motion_file(folder)
    expect = resample_motion(
        convert_motion(given.motion, "dwm21", "smpl24", trajectory=given.trajectory), given.fps, 20.0
    )
    assert joints.shape == (100, 24, 3) and given.fps == 25.0
    np.testing.assert_array_equal(joints[:40], expect[:40].astype(np.float32))
    assert prov["music"]["path"].endswith("audio.mp3")
