"""Output paths checked before the work (a probe file, name lengths, free space) and written together."""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

from momu.cli.output_paths import (
    TEMPORARY_NAME_ROOM,
    OutputPathError,
    StagedOutputs,
    check_writable_output,
    partial_path,
    remove_stale_partials,
)


def _listing(root: Path) -> list[str]:
    return sorted(str(p.relative_to(root)) for p in root.rglob("*"))


@pytest.mark.skipif(not Path("/proc/self").is_dir(), reason="needs /proc, where nobody may create files")
def test_a_folder_no_one_can_write_is_refused_by_a_probe_even_for_root() -> None:
    # os.access says yes for root on any folder; creating a file is the real test
    with pytest.raises(OutputPathError, match=r"--out /proc/momu-out/o: cannot write in /proc"):
        check_writable_output("/proc/momu-out/o", "--out")


def test_names_too_long_for_the_file_system_or_momus_temporaries(tmp_path: Path) -> None:
    with pytest.raises(OutputPathError, match=r"folder name too long \(300 bytes"):
        check_writable_output(tmp_path / ("d" * 300) / "o", "--out")
    name = "f" * (256 - TEMPORARY_NAME_ROOM) + ".mp4"
    with pytest.raises(OutputPathError, match="file name too long"):
        check_writable_output(tmp_path / name, "--out", is_file=True)
    ok = tmp_path / ("f" * (255 - TEMPORARY_NAME_ROOM - 4) + ".mp4")
    assert check_writable_output(ok, "--out", is_file=True) == ok
    assert _listing(tmp_path) == []  # the probe is gone, nothing was created


def test_files_folders_links_and_space(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    (tmp_path / "afile").write_text("x")
    with pytest.raises(OutputPathError, match="exists and is a file"):
        check_writable_output(tmp_path / "afile", "--out")
    with pytest.raises(OutputPathError, match="afile is a file, not a folder"):
        check_writable_output(tmp_path / "afile" / "o", "--out")
    with pytest.raises(OutputPathError, match="is a folder; give a file name"):
        check_writable_output(tmp_path, "--out", is_file=True)
    (tmp_path / "dangling").symlink_to(tmp_path / "nowhere")
    with pytest.raises(OutputPathError, match="broken symbolic link"):
        check_writable_output(tmp_path / "dangling", "--run-dir")
    usage = shutil.disk_usage(tmp_path)
    monkeypatch.setattr(shutil, "disk_usage", lambda p: type(usage)(usage.total, usage.total, 5_000_000))
    with pytest.raises(OutputPathError, match=r"only 5.0 MB free in .*; about 8.0 MB will be written"):
        check_writable_output(tmp_path / "new" / "o", "--out", need_bytes=8_000_000)
    check_writable_output(tmp_path / "new" / "o", "--out", need_bytes=1_000_000)
    assert _listing(tmp_path) == ["afile", "dangling"]


def test_staged_outputs_appear_together_or_not_at_all(tmp_path: Path) -> None:
    out = tmp_path / "a" / "b"
    finals = {"x": out / "one.txt", "y": out / "two.bin"}
    with StagedOutputs(finals) as staged:
        staged.path("x").write_text("1")
        assert not finals["x"].exists()  # nothing under its final name until every file is written
        staged.path("y").write_bytes(b"2")
        assert staged.commit() == [finals["x"], finals["y"]]
    assert _listing(tmp_path) == ["a", "a/b", "a/b/one.txt", "a/b/two.bin"]
    with pytest.raises(OSError, match="disk full"):
        with StagedOutputs({"x": tmp_path / "new" / "x.txt", "z": out / "one.txt"}) as staged:
            staged.path("z").write_text("replaced?")
            (staged.path("x").parent / f".{staged.path('x').stem}.abc123.txt").write_text("an atomic temp")
            raise OSError("disk full")
    assert _listing(tmp_path) == ["a", "a/b", "a/b/one.txt", "a/b/two.bin"]  # folders it made are gone
    assert finals["x"].read_text() == "1"


def test_temporaries_of_killed_runs_are_removed_by_the_next(tmp_path: Path) -> None:
    dead = subprocess.Popen([sys.executable, "-c", "pass"])
    dead.wait()
    stale = tmp_path / f".dance.momu-partial-{dead.pid}.mp4"
    inner = tmp_path / f"..dance.momu-partial-{dead.pid}.k2j3.mp4"  # an atomic write inside it
    mine = partial_path(tmp_path / "dance.bvh")
    alive = tmp_path / ".dance.momu-partial-1.npz"  # pid 1 is always running
    for path in (stale, inner, mine, alive, tmp_path / "dance.mp4"):
        path.write_text("x")
    assert remove_stale_partials(tmp_path) == 2
    assert _listing(tmp_path) == sorted([mine.name, alive.name, "dance.mp4"])
    old = os.stat(alive).st_mtime - 7200
    os.utime(alive, (old, old))  # a pid may be reused: an hour-old temporary is stale anyway
    assert remove_stale_partials(tmp_path) == 1 and not alive.exists()


def test_a_trailing_separator_makes_out_a_folder_whatever_dots_its_name_has(tmp_path: Path) -> None:
    from momu.cli.generate_errors import GenerateInputError
    from momu.cli.generate_io import resolve_outputs

    allowed = ("mp4", "bvh", "npz")
    for name in ("take_1.5", "song.wav"):
        outputs = resolve_outputs(f"{tmp_path / name}{os.sep}", None, allowed, "dance")
        assert outputs == {f: tmp_path / name / f"dance.{f}" for f in allowed}
    assert resolve_outputs(str(tmp_path / "d.bvh"), None, allowed, "dance") == {"bvh": tmp_path / "d.bvh"}
    with pytest.raises(GenerateInputError, match=r"unknown output type '\.5'"):
        resolve_outputs(str(tmp_path / "take_1.5"), None, allowed, "dance")
    assert not any(tmp_path.iterdir())
