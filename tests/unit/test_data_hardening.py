"""Issue 13, data: pickle memory bombs, non-UTF-8 names, AIST++ music folders, synth writes, file errors."""

from __future__ import annotations

import multiprocessing
import os
import pickle
import shutil
import time
from pathlib import Path

import numpy as np
import pytest
from tests.fixtures import layouts

from momu.cli import main
from momu.data.common import DataFileError, hash_split, load_npy, read_lines
from momu.data.safe_pickle import UnsafePickleError, safe_load, safe_loads
from momu.data.synth import SynthConfig, write_dataset
from momu.data.synth.store import load_written
from momu.io import FolderBusyError, staged_dir
from momu.registry import DATASETS

_core = getattr(np, "_core", None) or np.core


class _Reduce:
    def __init__(self, func: object, args: tuple, state: object = None) -> None:
        self.func, self.args, self.state = func, args, state

    def __reduce__(self) -> tuple:
        return (self.func, self.args) if self.state is None else (self.func, self.args, self.state)


BOMBS = {
    "bytes(N)": _Reduce(bytes, (10**10,)),
    "bytearray(N)": _Reduce(bytearray, (10**10,)),
    "ndarray(shape) constructor": _Reduce(np.ndarray, ((10**9,),)),
    "object dtype": np.array([1, "a"], dtype=object),
    "state declaring more data than it holds": _Reduce(
        _core.multiarray._reconstruct,
        (np.ndarray, (0,), b"b"),
        (1, (10**9,), np.dtype("f8"), False, b"\0" * 8),
    ),
    "_reconstruct of a non-empty shape": _Reduce(_core.multiarray._reconstruct, (np.ndarray, (10**9,), b"b")),
    "frombuffer of a zero-filled bytearray": _Reduce(
        _core.numeric._frombuffer, (_Reduce(bytearray, (2 * 10**9,)), np.dtype("u1"), (2 * 10**9,), "C")
    ),
}


@pytest.mark.parametrize("name", list(BOMBS))
@pytest.mark.parametrize("protocol", [2, 4, 5])
def test_memory_bombs_are_refused_before_allocating(name: str, protocol: int) -> None:
    payload = pickle.dumps(BOMBS[name], protocol=protocol)
    assert len(payload) < 400  # a few bytes that would become gigabytes
    with pytest.raises(UnsafePickleError, match="refusing"):
        safe_loads(payload, source="bomb.pkl")


def _array_state(raw: bytes) -> _Reduce:
    return _Reduce(
        _core.multiarray._reconstruct,
        (np.ndarray, (0,), b"b"),
        (1, (len(raw) // 8,), np.dtype("f8"), False, raw),
    )


def test_the_size_limit_is_configurable_and_counts_every_array() -> None:
    payload = pickle.dumps({"a": np.zeros(1000), "b": np.ones(1000)}, protocol=4)
    assert len(safe_loads(payload, max_bytes=17_000)) == 2
    with pytest.raises(UnsafePickleError, match="limit"):
        safe_loads(payload, max_bytes=10_000)
    raw = b"\0" * 8000  # stored once (memo), declared as the data of 20 arrays: 160 kB from 8 kB
    amplified = pickle.dumps([_array_state(raw) for _ in range(20)], protocol=4)
    assert len(amplified) < 9000
    with pytest.raises(UnsafePickleError, match="limit of array data"):
        safe_loads(amplified, max_bytes=100_000)
    assert len(safe_loads(amplified, max_bytes=200_000)) == 20


def test_aistpp_max_pickle_mb_reaches_the_unpickler(tmp_path: Path) -> None:
    layouts.write_aistpp(tmp_path)
    small = DATASETS.build("aistpp", {"root": str(tmp_path), "load_audio": False, "max_pickle_mb": 0.001})
    with pytest.raises(DataFileError, match="limit"):
        small[0]
    assert DATASETS.build("aistpp", {"root": str(tmp_path), "load_audio": False})[0].motion is not None


def test_a_non_utf8_file_name_does_not_make_the_dataset_unopenable(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    layouts.write_ballroom(tmp_path)
    name = os.fsdecode(b"Media-\xff\xfe")  # not UTF-8: os.listdir hands it back with surrogates
    shutil.copy(tmp_path / "Waltz" / "Media-105901.wav", tmp_path / "Waltz" / f"{name}.wav")
    shutil.copy(tmp_path / "beats" / "Media-105901.beats", tmp_path / "beats" / f"{name}.beats")
    # hashed as the name's bytes: sha256(b"0:Media-\xff\xfe") puts it at u = 0.4308, inside this val band
    assert hash_split(name, (0.43, 0.001, 0.569)) == "val"
    status = main(["data", "check", "ballroom", "--root", str(tmp_path), "--no-progress"])
    out = capsys.readouterr().out
    assert status == 0 and "items: 4 (4 ok, 0 bad)" in out


def _aist_without_music(root: Path, folder: str | None) -> None:
    layouts.write_aistpp(root)
    if folder is None:
        shutil.rmtree(root / "wavs")
    elif folder != "wavs":
        (root / "wavs").rename(root / folder)


@pytest.mark.parametrize("folder", ["wavs", "all_musics", "music"])
def test_aistpp_finds_the_music_in_any_published_layout(tmp_path: Path, folder: str) -> None:
    _aist_without_music(tmp_path, folder)
    dataset = DATASETS.build("aistpp", {"root": str(tmp_path)})
    assert dataset.music_dir == tmp_path / folder and dataset[0].audio is not None


def test_aistpp_without_music_names_music_dir(tmp_path: Path) -> None:
    _aist_without_music(tmp_path, None)
    with pytest.raises(FileNotFoundError, match=r"wavs/, all_musics/, music/.*music_dir="):
        DATASETS.build("aistpp", {"root": str(tmp_path)})
    with pytest.raises(FileNotFoundError, match=r"music_dir=elsewhere"):
        DATASETS.build("aistpp", {"root": str(tmp_path), "music_dir": "elsewhere"})
    assert len(DATASETS.build("aistpp", {"root": str(tmp_path), "load_audio": False})) == 2


def test_a_corrupt_npy_is_not_a_valid_npy_file(tmp_path: Path) -> None:
    path = tmp_path / "m.npy"
    np.save(path, np.zeros((4, 3), np.float32))
    data = path.read_bytes()
    path.write_bytes(data[:6] + b"\x09\x00" + data[8:])
    with pytest.raises(DataFileError, match=r"m.npy: not a valid .npy file") as err:
        load_npy(path)
    assert "we only support" not in str(err.value)
    header = data.index(b"(4, 3)")  # a header declaring a huge shape: refused before allocating
    path.write_bytes(data[:header] + b"(900000, 900000)" + data[header + 6 :])
    with pytest.raises(DataFileError, match="truncated or corrupt"):
        load_npy(path)


def test_a_symlink_loop_is_not_reported_as_file_not_found(tmp_path: Path) -> None:
    loop = tmp_path / "loop.txt"
    os.symlink(loop, loop)
    with pytest.raises(DataFileError, match="symbolic link loop"):
        read_lines(loop)
    dangling = tmp_path / "gone.txt"
    os.symlink(tmp_path / "missing", dangling)
    with pytest.raises(DataFileError, match="broken symbolic link"):
        read_lines(dangling)


def test_data_check_names_a_memory_error_without_text(capsys: pytest.CaptureFixture[str]) -> None:
    from momu.cli.data_check import check_dataset

    class Exploding:
        items: list = []

        def __len__(self) -> int:
            return 1

        def __getitem__(self, index: int) -> object:
            raise MemoryError()

    report = check_dataset(Exploding())
    assert report.bad == [("item 0", "out of memory reading it (does a header declare a huge size?)")]


SMALL = SynthConfig(num_clips=2, min_seconds=1.0, max_seconds=1.0, styles=["hiphop"])


def test_synth_refuses_a_non_empty_folder_unless_overwriting(tmp_path: Path) -> None:
    out = tmp_path / "d"
    write_dataset(out, SMALL)
    with pytest.raises(FileExistsError, match="--overwrite"):
        write_dataset(out, SMALL)
    write_dataset(
        out, SynthConfig(num_clips=3, min_seconds=1.0, max_seconds=1.0, styles=["hiphop"]), overwrite=True
    )
    assert len(load_written(out)) == 3 and not list(tmp_path.glob(".d.*"))


def test_an_interrupted_overwrite_leaves_the_old_dataset_whole(tmp_path: Path) -> None:
    out = tmp_path / "d"
    write_dataset(out, SMALL)
    before = {p.name: p.read_bytes() for p in out.rglob("*") if p.is_file()}
    calls = {"n": 0}

    def killed(_: int) -> None:
        calls["n"] += 1
        if calls["n"] == 2:
            raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        write_dataset(
            out,
            SynthConfig(num_clips=4, min_seconds=1.0, max_seconds=1.0, styles=["hiphop"]),
            overwrite=True,
            progress=killed,
        )
    assert {p.name: p.read_bytes() for p in out.rglob("*") if p.is_file()} == before
    assert main(["data", "check", "synth_dance", "--root", str(out), "--no-progress"]) == 0


def test_a_writer_killed_between_its_two_renames_loses_nothing(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """The swap renames the old copy to a backup, then the new one into place: a kill in between left
    only the backup, which the next writer deleted (issue 34). Now it is restored."""
    out = tmp_path / "d"
    write_dataset(out, SMALL)
    before = {p.relative_to(out): p.read_bytes() for p in out.rglob("*") if p.is_file()}
    real_rename = os.rename

    def killed_before_the_second(src: object, dst: object) -> None:
        if Path(str(src)).name.startswith(".d.staging-"):
            raise KeyboardInterrupt  # the backup is made, the new copy not yet in place
        real_rename(src, dst)  # type: ignore[arg-type]

    monkeypatch.setattr("momu.io.os.rename", killed_before_the_second)
    bigger = SynthConfig(num_clips=3, min_seconds=1.0, max_seconds=1.0, styles=["hiphop"])
    with pytest.raises(KeyboardInterrupt):
        write_dataset(out, bigger, overwrite=True)
    monkeypatch.undo()
    assert not out.exists() and len(list(tmp_path.glob(".d.old-*"))) == 1
    # the next writer restores the previous copy instead of deleting it, and does not overwrite it
    with pytest.raises(FileExistsError, match="restored the previous copy"):
        write_dataset(out, bigger)
    assert {p.relative_to(out): p.read_bytes() for p in out.rglob("*") if p.is_file()} == before
    assert not list(tmp_path.glob(".d.*"))
    write_dataset(out, bigger, overwrite=True)
    assert len(load_written(out)) == 3 and not list(tmp_path.glob(".d.*"))


def test_data_synth_refuses_a_dataset_larger_than_the_free_space(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    from momu.data.synth.store import check_room, estimated_bytes

    usage = shutil.disk_usage(tmp_path)
    monkeypatch.setattr("momu.data.synth.store.shutil.disk_usage", lambda _: usage._replace(free=5_000_000))
    argv = ["data", "synth", "--out", str(tmp_path / "d"), *"--clips 40 --seconds 10 --no-progress".split()]
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "--clips 40: the dataset needs up to" in err and "0.01 GB free" in err
    assert list(tmp_path.iterdir()) == []
    # the estimate is an upper bound of what is written, and not a loose one
    cfg = SynthConfig(num_clips=3, min_seconds=2.0, max_seconds=2.0, root_centred=True)
    monkeypatch.undo()
    write_dataset(tmp_path / "small", cfg)
    written = sum(p.stat().st_size for p in (tmp_path / "small").rglob("*") if p.is_file())
    assert written <= estimated_bytes(cfg) <= 2 * written + 20_000
    check_room(tmp_path / "new", cfg)  # fits


def test_float_wavs_carry_no_time_stamp(tmp_path: Path) -> None:
    """libsndfile stamps a float wav's PEAK chunk with the time of writing: the same clip written a
    second later gave different bytes."""
    write_dataset(tmp_path / "d", SMALL, subtype="FLOAT")
    wav = (tmp_path / "d" / "audio").glob("*.wav").__next__().read_bytes()
    at = wav.find(b"PEAK")
    assert at > 0 and wav[at + 12 : at + 16] == bytes(4)


def _hold(path: str, ready: object, release: object) -> None:
    with staged_dir(Path(path)):
        ready.set()  # type: ignore[attr-defined]
        release.wait(30)  # type: ignore[attr-defined]


def test_a_concurrent_writer_of_the_same_folder_fails_at_once(tmp_path: Path) -> None:
    ctx = multiprocessing.get_context("spawn")
    ready, release = ctx.Event(), ctx.Event()
    holder = ctx.Process(target=_hold, args=(str(tmp_path / "d"), ready, release))
    holder.start()
    try:
        assert ready.wait(60)
        start = time.monotonic()
        with pytest.raises(FolderBusyError, match="another process is writing"):
            write_dataset(tmp_path / "d", SMALL)
        assert time.monotonic() - start < 10
    finally:
        release.set()
        holder.join(30)
    write_dataset(tmp_path / "d", SMALL, overwrite=True)  # the lock is gone with its holder


def test_data_synth_into_a_file_is_a_usage_error(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    (tmp_path / "f").write_text("x")
    assert main(["data", "synth", "--out", str(tmp_path / "f"), "--no-progress"]) == 2
    assert "momu data synth: error: --out" in capsys.readouterr().err
    assert safe_load  # (the module's file reader is exercised in test_safe_pickle)
