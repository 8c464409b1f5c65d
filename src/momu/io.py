"""Atomic file writes and safe readers shared by every module that writes to disk.

Nothing momu writes is ever half-written: data goes to a temporary file in the target's
folder and is renamed into place only when complete.
"""

from __future__ import annotations

import contextlib
import json
import os
import shutil
import tempfile
from collections.abc import Iterator
from pathlib import Path
from typing import Any

__all__ = [
    "atomic_path",
    "atomic_write_bytes",
    "atomic_write_text",
    "write_json",
    "read_json",
    "check_output_dir",
    "check_output_file",
    "probe_writable",
    "staged_dir",
    "FolderBusyError",
    "remove_stale_temporaries",
]

STALE_TEMPORARY_S = 3600.0
"""A temporary file of :func:`atomic_path` untouched this long (s) belongs to a killed writer."""


@contextlib.contextmanager
def atomic_path(path: str | Path) -> Iterator[Path]:
    """Yield a temporary path beside ``path``; rename it onto ``path`` if the block succeeds.

    The temporary keeps ``path``'s suffix so writers that infer the format from it still work.
    """
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp_name = tempfile.mkstemp(prefix=f".{path.stem}.", suffix=path.suffix, dir=path.parent)
    os.close(fd)
    tmp = Path(tmp_name)
    try:
        yield tmp
        # mkstemp creates 0600 files; give the result the permissions a plain open() would.
        umask = os.umask(0)
        os.umask(umask)
        os.chmod(tmp, 0o666 & ~umask)
        os.replace(tmp, path)
    finally:
        tmp.unlink(missing_ok=True)


def remove_stale_temporaries(directory: str | Path, suffix: str, max_age_s: float = STALE_TEMPORARY_S) -> int:
    """Delete :func:`atomic_path` temporaries (``.<stem>.<random><suffix>``) older than ``max_age_s``.

    A writer killed mid-write leaves its temporary behind; a live writer's is younger than
    ``max_age_s``. Returns the number removed.
    """
    import time

    folder = Path(directory)
    if not folder.is_dir():
        return 0
    now = time.time()
    removed = 0
    for tmp in folder.glob(f".*{suffix}"):
        try:
            if tmp.is_file() and now - tmp.stat().st_mtime > max_age_s:
                tmp.unlink()
                removed += 1
        except OSError:
            continue
    return removed


def atomic_write_bytes(path: str | Path, data: bytes) -> Path:
    """Write ``data`` to ``path`` atomically."""
    with atomic_path(path) as tmp:
        tmp.write_bytes(data)
    return Path(path)


def atomic_write_text(path: str | Path, text: str) -> Path:
    """Write ``text`` (UTF-8) to ``path`` atomically."""
    return atomic_write_bytes(path, text.encode("utf-8"))


def write_json(path: str | Path, obj: Any) -> Path:
    """Write ``obj`` as indented JSON, atomically."""
    return atomic_write_text(path, json.dumps(obj, indent=2, sort_keys=False, default=str) + "\n")


def read_json(path: str | Path) -> Any:
    """Read JSON; errors name the file and what is wrong."""
    path = Path(path)
    try:
        text = path.read_text(encoding="utf-8")
    except OSError as exc:
        raise OSError(f"{path}: cannot read: {exc.strerror or exc}") from None
    try:
        return json.loads(text)
    except json.JSONDecodeError as exc:
        raise ValueError(f"{path}: invalid JSON at line {exc.lineno} column {exc.colno}: {exc.msg}") from None


def _first_existing(path: Path) -> Path:
    probe = path
    while not probe.exists() and probe != probe.parent:
        probe = probe.parent
    return probe


PROBE_PREFIX = ".momu-probe-"
"""The name prefix of the file :func:`probe_writable` creates and removes."""


def probe_writable(folder: Path) -> None:
    """Create and remove a file in ``folder``; raises the ``OSError`` that creating it gave.

    ``os.access`` cannot answer "may I write here": it is always true for root, also on a read-only
    file system or in ``/proc``, so the only reliable check is to try.
    """
    fd, name = tempfile.mkstemp(prefix=PROBE_PREFIX, dir=folder)
    os.close(fd)
    os.unlink(name)


def _probe_or_fail(path: Path, flag: str, folder: Path) -> None:
    try:
        probe_writable(folder)
    except OSError as exc:
        raise ValueError(f"{flag} {path}: cannot write in {folder} ({exc.strerror or exc})") from None


def _check_creatable(path: Path, flag: str) -> None:
    """``path`` does not exist yet: its nearest existing ancestor must be a folder that takes a new file."""
    ancestor = _first_existing(path.parent if path.parent != path else path)
    if not ancestor.is_dir():
        raise ValueError(f"{flag} {path}: cannot create it, {ancestor} is a file, not a folder")
    _probe_or_fail(path, flag, ancestor)


def check_output_dir(path: str | Path, flag: str = "--out") -> Path:
    """Fail (``ValueError`` naming ``flag`` and ``path``) unless ``path`` is or can become a writable folder.

    Checks only; creates nothing that stays (a probe file is created and removed in the nearest
    existing folder), so a command can check every output before doing any work.
    """
    path = Path(path)
    try:
        if path.is_symlink() and not path.exists():
            raise ValueError(f"{flag} {path}: a broken symbolic link (or a link loop)")
        if path.exists():
            if not path.is_dir():
                raise ValueError(f"{flag} {path}: exists and is a file, not a folder")
            _probe_or_fail(path, flag, path)
            return path
        _check_creatable(path, flag)
    except OSError as exc:  # ELOOP, ENAMETOOLONG ...
        raise ValueError(f"{flag} {path}: {exc.strerror or exc}") from None
    return path


def check_output_file(path: str | Path, flag: str = "--out") -> Path:
    """Fail (``ValueError`` naming ``flag`` and ``path``) unless ``path`` can be written as a file."""
    path = Path(path)
    try:
        if path.is_symlink() and not path.exists():
            raise ValueError(f"{flag} {path}: a broken symbolic link (or a link loop)")
        if path.exists():
            if path.is_dir():
                raise ValueError(f"{flag} {path}: is a folder; give a file name")
            _probe_or_fail(path, flag, path.parent)
            return path
        _check_creatable(path, flag)
    except OSError as exc:
        raise ValueError(f"{flag} {path}: {exc.strerror or exc}") from None
    return path


class FolderBusyError(RuntimeError):
    """Another process is writing the same output folder."""


@contextlib.contextmanager
def _exclusive(lock_path: Path, target: Path) -> Iterator[None]:
    """Hold an exclusive, non-blocking ``flock`` on ``lock_path`` (released if the process dies)."""
    try:
        import fcntl
    except ImportError:  # pragma: no cover - not POSIX: staging + rename still keeps folders whole
        yield
        return
    fd = os.open(lock_path, os.O_CREAT | os.O_RDWR, 0o666)
    try:
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            raise FolderBusyError(f"{target}: another process is writing this folder") from None
        try:
            yield
        finally:
            lock_path.unlink(missing_ok=True)
    finally:
        os.close(fd)


def _finish_interrupted_swap(path: Path) -> Path | None:
    """Clean up after a :func:`staged_dir` writer killed mid-swap (call with the lock held).

    A backup ``.<name>.old-*`` beside a ``path`` that exists is a finished swap's: removed. A backup
    with no ``path`` is the previous copy of a writer killed between its two renames: renamed back to
    ``path`` (the newest, if several) and returned.
    """
    backups = sorted(path.parent.glob(f".{path.name}.old-*"), key=lambda p: p.stat().st_mtime)
    restored = None
    if backups and not path.exists():
        restored = backups.pop()
        os.rename(restored, path)
    for leftover in backups:
        shutil.rmtree(leftover, ignore_errors=True)
    return restored


@contextlib.contextmanager
def staged_dir(path: str | Path, *, overwrite: bool = False) -> Iterator[Path]:
    """Build a folder under a staging name and swap it into ``path`` when the block succeeds.

    The staging folder and a lock file live beside ``path`` (``.<name>.staging-<pid>``,
    ``.<name>.lock``), so readers of ``path`` see the old folder or the new one, never a mix, and a
    second writer fails at once with :class:`FolderBusyError`. The swap is two renames: the old folder
    to a backup ``.<name>.old-<pid>``, the new one to ``path``; then the backup is removed. Leftover
    staging folders of killed writers are removed by the next writer; a backup left with no ``path``
    (a writer killed between its two renames) is renamed back to ``path``, never deleted. A non-empty
    ``path`` is replaced only with ``overwrite``.

    Raises:
        NotADirectoryError: ``path`` is a file.
        FileExistsError: ``path`` is a non-empty folder and ``overwrite`` is false.
        FolderBusyError: another writer holds the lock.
    """
    path = Path(path)
    if path.exists() and not path.is_dir():
        raise NotADirectoryError(f"{path}: exists and is a file, not a folder")
    if path.is_dir() and any(path.iterdir()) and not overwrite:
        raise FileExistsError(f"{path}: folder is not empty (pass --overwrite to replace it)")
    path.parent.mkdir(parents=True, exist_ok=True)
    with _exclusive(path.parent / f".{path.name}.lock", path):
        for leftover in path.parent.glob(f".{path.name}.staging-*"):  # writers that were killed
            shutil.rmtree(leftover, ignore_errors=True)
        restored = _finish_interrupted_swap(path)
        if restored is not None and any(path.iterdir()) and not overwrite:
            raise FileExistsError(
                f"{path}: restored the previous copy from {restored.name} (a writer was stopped between "
                "its two renames); folder is not empty (pass --overwrite to replace it)"
            )
        staging = path.parent / f".{path.name}.staging-{os.getpid()}"
        staging.mkdir()
        try:
            yield staging
            old = path.parent / f".{path.name}.old-{os.getpid()}"
            if path.exists():
                os.rename(path, old)  # an interrupted swap leaves the old folder under .old-*
            os.rename(staging, path)
            shutil.rmtree(old, ignore_errors=True)
        finally:
            shutil.rmtree(staging, ignore_errors=True)
