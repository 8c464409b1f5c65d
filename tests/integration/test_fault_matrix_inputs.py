"""Nothing lost, nothing hangs (issue 34): bad or hostile inputs and faults while writing, per command.

Each case builds its inputs under ``tmp_path``, snapshots the folder and the momu temporaries in the
system's temporary folder, runs ``momu ...`` in-process (:func:`momu.cli.main`) and checks

* the exit status (2: a bad input or output path, found before any work; 1: writing failed after the
  work; 0: the input was mended with a warning);
* one ``error:`` line naming the file or option and what is wrong (status 0: the warning's words);
* that nothing was created or changed under ``tmp_path`` (status 0: exactly the outputs), and no
  ``momu-render-*`` / ``*momu-partial*`` / ``.momu-probe-*`` temporary was left anywhere.

Cases marked ``model="empty"`` pass ``--model`` an empty folder: an error about anything but the model
shows the input was checked before the model. ``model="record"`` passes a folder with the shipped
model's record but no weights (the checks that need the record pass, loading fails); ``model="real"``
runs the shipped model (a 2-second song: a few seconds), for faults that happen after generating.
"""

from __future__ import annotations

import errno
import os
import re
import shutil
import signal
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import soundfile as sf
from tests.helpers.bad_inputs import (
    Setup,
    bvh,
    complex_npy,
    dance,
    eval_complex,
    float_wav,
    generate,
    long_npy,
    motion_npz,
    mp3,
    music,
    npy_long_header,
    npz,
    short_npz,
    short_wav,
    song,
    text_as_mp3,
    zip_bomb,
)
from tests.integration.test_bad_input_matrix import _method_model, _swing, _wav
from tests.unit.test_metrics_beats_audio import SR

from momu.cli import main
from momu.cli.generate_io import GenerateInputError, default_model_dir
from momu.export import write_motion_npz

Patch = Callable[[pytest.MonkeyPatch, Path], None]


@dataclass
class Case:
    id: str
    setup: Setup  # builds the inputs under the folder, returns argv (without --model)
    words: str  # in the one error line (status 0: in the warning)
    status: int = 2
    model: str = "empty"  # "empty", "record", "real" (module docstring) or "none" (no --model)
    patch: Patch | None = None
    outputs: tuple[str, ...] = field(default=("dance.bvh", "dance.mp4", "dance.npz"))


# ---------------------------------------------------------------- faults (monkeypatched)


def _little_space(monkeypatch: pytest.MonkeyPatch, root: Path) -> None:
    usage = shutil.disk_usage(root)
    monkeypatch.setattr(shutil, "disk_usage", lambda path: type(usage)(usage.total, usage.total, 200_000))


def _disk_fills_writing_bvh(monkeypatch: pytest.MonkeyPatch, root: Path) -> None:
    import momu.export

    def full(path: Path, *args: Any, **kwargs: Any) -> Path:
        Path(path).write_bytes(b"HIERARCHY\n")  # what got out before the disk filled
        raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC), str(path))

    monkeypatch.setattr(momu.export, "write_bvh", full)


def _ffmpeg_hangs(monkeypatch: pytest.MonkeyPatch, root: Path) -> None:
    """An "ffmpeg" that never reads its input nor exits; writes its pid beside the test's folder."""
    import imageio_ffmpeg

    import momu.render.ffmpeg as ff

    aux = root.parent / f"{root.name}-aux"
    aux.mkdir(exist_ok=True)
    script = aux / "ffmpeg"
    script.write_text(f'#!/bin/sh\necho $$ >> "{aux / "pids"}"\nexec sleep 120\n')
    script.chmod(0o755)
    monkeypatch.setattr(imageio_ffmpeg, "get_ffmpeg_exe", lambda: str(script))
    monkeypatch.setattr(ff, "WALL_BASE_S", 1.0, raising=False)
    monkeypatch.setattr(ff, "WALL_PER_FRAME_S", 0.0, raising=False)


# ---------------------------------------------------------------- the table

_O = ("--out", "ROOT/o")

CASES = [
    # songs: `generate dance --music`
    Case("song-text-renamed-mp3", dance(text_as_mp3), "not a decodable audio file"),
    Case("song-truncated-mp3", dance(lambda r: mp3(r, "truncated")), "corrupt or truncated"),
    Case("song-zeroed-mp3", dance(lambda r: mp3(r, "zeroed")), "corrupt or truncated"),
    Case("song-shorter-than-the-minimum", dance(short_wav), "too short"),
    Case("seconds-1e-9", dance(short_wav, "--seconds", "1e-9"), "--seconds 1e-09 is shorter than the 0.5 s"),
    Case(
        "seconds-past-the-cap",
        dance(lambda r: _wav(r / "s.wav"), "--seconds", "700"),
        "600 s (10-minute) limit",
    ),
    Case(
        "seconds-inf",
        dance(lambda r: _wav(r / "s.wav"), "--seconds", "inf"),
        "--seconds must be a finite number",
    ),
    Case("float-wav-at-1e6-is-scaled", float_wav(1e6), "scaled down", status=0, model="real"),
    Case("float-wav-at-1e30-is-scaled", float_wav(1e30), "scaled down", status=0, model="real"),
    # motions: `generate music --motion`
    Case("bvh-declares-1000000-frames", music(lambda r: bvh(r, frames=1_000_000)), "declares 1000000 frames"),
    Case("bvh-declares-100000-frames", music(lambda r: bvh(r, frames=100_000)), "holds 20 rows"),
    Case(
        "bvh-longer-than-600-s",
        music(lambda r: bvh(r, frame_time=1.0, rows=610)),
        "longer than the 600 s limit",
    ),
    Case("bvh-a-million-fps", music(lambda r: bvh(r, frame_time=1e-6)), "outside 1-1000 fps"),
    Case("npz-zip-bomb", music(zip_bomb), "more than the 268435456-byte limit"),
    Case(
        "npz-fps-is-a-big-array",
        music(lambda r: npz(r, joints=_swing(40, 24), fps=np.zeros(20_000))),
        "'fps'",
    ),
    Case(
        "npz-complex-joints",
        music(lambda r: npz(r, joints=_swing(40, 24) * (1 + 1j), fps=20.0)),
        "holds complex numbers",
    ),
    Case("npz-a-million-fps", music(lambda r: npz(r, joints=_swing(40, 24), fps=1e6)), "outside 1-1000 fps"),
    Case(
        "npz-longer-than-600-s",
        music(lambda r: npz(r, joints=np.broadcast_to(_swing(1, 24), (6_020, 24, 3)), fps=10.0)),
        "longer than the 600 s limit",
    ),  # fmt: skip
    Case("npy-header-declares-288-gb", music(npy_long_header), "truncated or corrupt"),
    Case("npy-complex", music(complex_npy, "--fps", "20"), "holds complex numbers"),
    Case("npy-longer-than-600-s", music(long_npy, "--fps", "20"), "longer than the 600 s limit"),
    Case("motion-shorter-than-the-minimum", music(short_npz), "too short"),
    Case("music-seconds-past-the-cap", music(motion_npz, "--seconds", "700"), "600 s (10-minute) limit"),
    Case("joint-seconds-past-the-cap", generate("joint", "--seconds", "700", *_O), "600 s (10-minute) limit"),
    Case("joint-seconds-under-the-minimum", generate("joint", "--seconds", "0.01", *_O), "0.5 s minimum"),
    Case(
        "inbetween-seconds-past-the-cap",
        generate("inbetween", "--motion", "ROOT/motion.npz", "--keyframes", "0", "--seconds", "700", *_O),
        "600 s (10-minute) limit",
    ),
    Case(
        "text-seconds-past-the-cap",
        _method_model("mofusion", "text", "text", "--caption", "a person jumps", "--seconds", "700", *_O),
        "600 s (10-minute) limit",
        model="none",
    ),
    # outputs: checked before any work
    Case(
        "out-on-a-read-only-file-system",
        dance(lambda r: _wav(r / "s.wav"), "--out", "/proc/momu-out/o"),
        "cannot write in /proc",
    ),  # fmt: skip
    Case("out-folder-name-too-long", dance(lambda r: _wav(r / "s.wav"), "--out", "x" * 300), "name too long"),
    Case(
        "out-file-name-too-long",
        dance(lambda r: _wav(r / "s.wav"), "--out", "x" * 230 + ".mp4"),
        "file name too long",
    ),  # fmt: skip
    Case(
        "out-without-space",
        generate("dance", "--music", "ROOT/song.wav", *_O),
        "MB free",
        model="record",
        patch=_little_space,
    ),  # fmt: skip
    # faults after the work: one line, status 1, nothing half-written
    Case(
        "disk-fills-while-writing",
        generate("dance", "--music", "ROOT/song.wav", *_O),
        "No space left on device",
        status=1,
        model="real",
        patch=_disk_fills_writing_bvh,
    ),  # fmt: skip
    Case(
        "ffmpeg-hangs",
        generate("dance", "--music", "ROOT/song.wav", *_O),
        "took longer than 1 s",
        status=1,
        model="real",
        patch=_ffmpeg_hangs,
    ),  # fmt: skip
    # eval reads motions the same way
    Case("eval-complex-motion", eval_complex, "real numbers", model="none"),
]


def _fix_relative(argv: list[str], root: Path) -> list[str]:
    """``--out x...`` names without a folder are made relative to ``root`` (the test's folder)."""
    out = list(argv)
    for i, a in enumerate(out[:-1]):
        if a == "--out" and not os.path.isabs(out[i + 1]):
            out[i + 1] = str(root / out[i + 1])
    return out


def _snapshot(root: Path) -> dict[str, tuple[int, int]]:
    return {
        str(p.relative_to(root)): (p.lstat().st_size, p.lstat().st_mtime_ns)
        for p in root.rglob("*")
        if p.name != "__pycache__"
    }


def _momu_temporaries() -> set[str]:
    tmp = Path(tempfile.gettempdir())
    return {
        p.name
        for p in tmp.iterdir()
        if p.name.startswith(("momu-render-", ".momu-probe-")) or "momu-partial" in p.name
    }


@pytest.fixture(scope="module")
def real_model(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The shipped model (a tiny stand-in where an installation has none)."""
    try:
        return default_model_dir("dance")
    except GenerateInputError:
        from tests.helpers.tiny_models import tiny_3d_model

        return tiny_3d_model(tmp_path_factory.mktemp("tiny"))


def _model_args(case: Case, root: Path, real: Path) -> list[str]:
    if case.model == "none":
        return []
    if case.model == "real":
        return ["--model", str(real)]
    folder = root / "model"
    folder.mkdir()
    if case.model == "record":
        shutil.copy(real / "momu.json", folder / "momu.json")
    return ["--model", str(folder)]


@pytest.mark.parametrize("case", CASES, ids=[c.id for c in CASES])
def test_fault(
    case: Case,
    tmp_path: Path,
    real_model: Path,
    capsys: pytest.CaptureFixture[str],
    caplog: pytest.LogCaptureFixture,
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    argv = _fix_relative(case.setup(tmp_path), tmp_path)
    argv += _model_args(case, tmp_path, real_model) if argv[0] == "generate" else []
    if case.patch is not None:
        case.patch(monkeypatch, tmp_path)
    before, temporaries = _snapshot(tmp_path), _momu_temporaries()
    with caplog.at_level("WARNING"):
        code = main(argv)
    out, err = capsys.readouterr()
    assert code == case.status, err
    assert _momu_temporaries() <= temporaries
    if case.status == 0:
        assert case.words in caplog.text, caplog.text
        assert out.count("\n") == 1 and out.startswith("momu generate dance: wrote "), out
        assert sorted(p.name for p in (tmp_path / "o").iterdir()) == sorted(case.outputs)
        return
    assert err.count("\n") == 1 and " error: " in err, err
    assert case.words in err, err
    assert _snapshot(tmp_path) == before
    aux = tmp_path.parent / f"{tmp_path.name}-aux"
    if (aux / "pids").is_file():  # the hanging "ffmpeg" was killed
        for pid in map(int, (aux / "pids").read_text().split()):
            with pytest.raises(ProcessLookupError):
                os.kill(pid, 0)


# ---------------------------------------------------------------- process-level: signals, what is printed


def _env() -> dict[str, str]:
    return {**os.environ, "OMP_NUM_THREADS": "1", "PYTHONUNBUFFERED": "1"}


def _momu(*argv: str) -> list[str]:
    return [
        sys.executable,
        "-c",
        "import sys; from momu.cli import main; sys.exit(main(sys.argv[1:]))",
        *argv,
    ]


def _children_writing(folder: Path) -> list[int]:
    """Processes (ffmpeg) whose command line names a file in ``folder``."""
    pids = []
    for proc in Path("/proc").iterdir():
        if not proc.name.isdigit():
            continue
        try:
            cmdline = (proc / "cmdline").read_bytes().decode(errors="replace")
        except OSError:
            continue
        if str(folder) + "/" in cmdline and "ffmpeg" in cmdline:
            pids.append(int(proc.name))
    return pids


def _gone(pids: list[int], seconds: float) -> bool:
    deadline = time.monotonic() + seconds
    while time.monotonic() < deadline:
        if not any(Path(f"/proc/{pid}").exists() for pid in pids):
            return True
        time.sleep(0.05)
    return False


def _stop_while_writing_the_mp4(
    tmp_path: Path, model: Path, sig: int
) -> tuple[subprocess.Popen[str], list[int]]:
    """Start ``momu generate dance`` on a 12 s song; send ``sig`` once ffmpeg is writing the mp4."""
    sf.write(tmp_path / "song.wav", song(12.0), SR)
    out = tmp_path / "o"
    proc = subprocess.Popen(
        _momu(
            "generate",
            "dance",
            "--music",
            str(tmp_path / "song.wav"),
            "--out",
            str(out),
            "--model",
            str(model),
        ),
        env=_env(),
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    deadline = time.monotonic() + 120
    writers: list[int] = []
    while time.monotonic() < deadline and proc.poll() is None and not writers:
        writers = _children_writing(out)
        time.sleep(0.02)
    assert writers, f"ffmpeg never started: {proc.communicate()}"
    time.sleep(0.2)
    proc.send_signal(sig)
    proc.wait(timeout=60)
    return proc, writers


@pytest.mark.skipif(not Path("/proc/self/cmdline").exists(), reason="needs /proc to find ffmpeg")
def test_sigterm_while_writing_the_mp4_leaves_nothing(tmp_path: Path, real_model: Path) -> None:
    temporaries = _momu_temporaries()
    proc, writers = _stop_while_writing_the_mp4(tmp_path, real_model, signal.SIGTERM)
    err = proc.stderr.read() if proc.stderr else ""
    assert proc.returncode == 143, err
    assert err.strip().splitlines()[-1] == "momu generate: stopped by SIGTERM; nothing was written"
    assert not (tmp_path / "o").exists()  # the folder it created, and every temporary in it
    assert _gone(writers, 5.0), "ffmpeg outlived momu"
    assert _momu_temporaries() <= temporaries


@pytest.mark.skipif(not Path("/proc/self/cmdline").exists(), reason="needs /proc to find ffmpeg")
def test_sigkill_while_writing_the_mp4_the_next_run_cleans_up(tmp_path: Path, real_model: Path) -> None:
    from momu.cli.output_paths import remove_stale_partials

    temporaries = _momu_temporaries()
    proc, writers = _stop_while_writing_the_mp4(tmp_path, real_model, signal.SIGKILL)
    assert proc.returncode == -signal.SIGKILL
    assert _gone(writers, 30.0), "ffmpeg outlived momu"  # its input ends with momu; -timelimit bounds it
    left = sorted(p.name for p in (tmp_path / "o").iterdir())
    assert left and all("momu-partial" in name for name in left), left  # only temporaries, never dance.*
    assert _momu_temporaries() <= temporaries  # no copy of the song anywhere
    assert remove_stale_partials(tmp_path / "o") == len(left)  # what the next run does first
    assert list((tmp_path / "o").iterdir()) == []


def test_without_a_terminal_it_logs_progress_and_ends_with_one_line_naming_the_files(
    tmp_path: Path, real_model: Path
) -> None:
    """Stereo stays stereo in the mp4, as 192 kb/s AAC; INFO lines say what is being written."""
    import imageio_ffmpeg

    sf.write(tmp_path / "song.wav", song(3.0, sr=44100), 44100)
    out = tmp_path / "o"
    argv = [
        "generate",
        "dance",
        "--music",
        str(tmp_path / "song.wav"),
        "--out",
        str(out),
        "--model",
        str(real_model),
    ]
    done = subprocess.run(_momu(*argv), env=_env(), capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stderr
    files = ", ".join(str(out / f"dance.{f}") for f in ("mp4", "bvh", "npz"))
    assert done.stdout == f"momu generate dance: wrote {files}\n"
    assert f"writing {out / 'dance.mp4'}" in done.stderr
    assert "writing dance.mp4: 100% (75 of 75 frames" in done.stderr
    info = subprocess.run(
        [imageio_ffmpeg.get_ffmpeg_exe(), "-hide_banner", "-i", str(out / "dance.mp4")],
        capture_output=True,
        text=True,
    ).stderr
    audio = next(line for line in info.splitlines() if "Audio:" in line)
    assert "44100 Hz, stereo" in audio, audio
    assert int(re.search(r"(\d+) kb/s", audio).group(1)) >= 150, audio  # type: ignore[union-attr]
    assert sorted(p.name for p in out.iterdir()) == ["dance.bvh", "dance.mp4", "dance.npz"]


def test_a_static_motion_gets_a_warning(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], caplog: pytest.LogCaptureFixture
) -> None:
    still = write_motion_npz(tmp_path / "still.npz", np.repeat(_swing(1, 24), 60, axis=0), 20.0, "smpl24")
    (tmp_path / "model").mkdir()
    with caplog.at_level("WARNING"):
        code = main(
            [
                "generate",
                "music",
                "--motion",
                str(still),
                "--out",
                str(tmp_path / "o"),
                "--model",
                str(tmp_path / "model"),
            ]
        )
    assert (
        code == 2 and "--model" in capsys.readouterr().err
    )  # the warning comes first, the model is refused after
    assert "the motion is static" in caplog.text
    moving = write_motion_npz(tmp_path / "moving.npz", _swing(60, 24), 20.0, "smpl24")
    caplog.clear()
    with caplog.at_level("WARNING"):
        main(
            [
                "generate",
                "music",
                "--motion",
                str(moving),
                "--out",
                str(tmp_path / "o"),
                "--model",
                str(tmp_path / "model"),
            ]
        )
    assert "static" not in caplog.text
