"""A command's output paths: checked writable before any work, written all together at the end.

* :func:`check_writable_output` — call it before the work starts (``momu generate`` does, and
  ``momu train`` can): the nearest existing folder of the output must accept a new file (a probe file
  is created and removed: this catches read-only file systems and folders root may not write, which
  ``os.access`` does not), every name must fit the file system together with the room momu's
  temporaries add, and, when the caller knows roughly how much it will write, that much space must be
  free. A problem raises :class:`OutputPathError` (a ``ValueError``): one line naming the option.
* :class:`StagedOutputs` — write each output to a temporary beside its final name
  (``.<stem>.momu-partial-<pid><suffix>``) and move them all into place together when every one is
  complete; on failure (an error, Ctrl-C, SIGTERM: :func:`momu.cli.interrupts.exit_on_sigterm`) the
  temporaries and the folders it created are removed, so nothing is left half-written.
* :func:`remove_stale_partials` — a run killed with SIGKILL cannot clean up; the next run removes its
  temporaries (their process is gone, or they are older than an hour).
"""

from __future__ import annotations

import os
import re
import shutil
import time
from pathlib import Path
from types import TracebackType

from momu.io import STALE_TEMPORARY_S, probe_writable

__all__ = [
    "OutputPathError",
    "check_writable_output",
    "StagedOutputs",
    "partial_path",
    "remove_stale_partials",
    "PARTIAL_TAG",
    "TEMPORARY_NAME_ROOM",
]

PARTIAL_TAG = "momu-partial"
"""Marks the temporaries of :class:`StagedOutputs` (``.<stem>.momu-partial-<pid><suffix>``)."""
TEMPORARY_NAME_ROOM = 48
"""Bytes a file name may grow by in momu's temporaries (the partial tag, a pid, an atomic-write suffix)."""
_FALLBACK_NAME_MAX = 255
_FALLBACK_PATH_MAX = 4096


class OutputPathError(ValueError):
    """An output path that cannot be written: one line naming the option and what is wrong."""


def _nearest_existing(path: Path) -> Path:
    probe = path
    while not os.path.lexists(probe) and probe != probe.parent:
        probe = probe.parent
    return probe


def _limit(folder: Path, name: str, fallback: int) -> int:
    try:
        value = os.pathconf(folder, name)
    except (OSError, ValueError):
        return fallback
    return int(value) if value and value > 0 else fallback


def _check_names(path: Path, flag: str, folder: Path, ancestor: Path, is_file: bool) -> None:
    name_max = _limit(ancestor, "PC_NAME_MAX", _FALLBACK_NAME_MAX)
    path_max = _limit(ancestor, "PC_PATH_MAX", _FALLBACK_PATH_MAX)
    new_parts = folder.absolute().relative_to(ancestor.absolute()).parts if folder != ancestor else ()
    for part in new_parts:
        if len(os.fsencode(part)) > name_max:
            raise OutputPathError(
                f"{flag} {path}: folder name too long ({len(os.fsencode(part))} bytes; this file system "
                f"allows {name_max})"
            )
    if is_file:
        size = len(os.fsencode(path.name))
        if size + TEMPORARY_NAME_ROOM > name_max:
            raise OutputPathError(
                f"{flag} {path}: file name too long ({size} bytes; at most {name_max - TEMPORARY_NAME_ROOM} "
                f"here: the file system allows {name_max} and momu's temporary files add up to "
                f"{TEMPORARY_NAME_ROOM})"
            )
    total = len(os.fsencode(str(path.absolute())))
    if total + TEMPORARY_NAME_ROOM > path_max:
        raise OutputPathError(
            f"{flag} {path}: path too long ({total} bytes; this file system allows {path_max})"
        )


def _probe(path: Path, flag: str, ancestor: Path) -> None:
    try:
        probe_writable(ancestor)
    except OSError as exc:
        raise OutputPathError(f"{flag} {path}: cannot write in {ancestor} ({exc.strerror or exc})") from None


def check_writable_output(
    path: str | Path, flag: str = "--out", *, is_file: bool = False, need_bytes: int = 0
) -> Path:
    """Fail unless ``path`` (a folder, or a file with ``is_file``) can be created and written now.

    Creates nothing that stays: a probe file is created and removed in the nearest existing folder.
    ``need_bytes``: the space the command will write (roughly); less free space is refused.

    Raises:
        OutputPathError: ``path`` (or a folder above it) is a file, a broken link, not writable, its
            name is too long, or the file system has less than ``need_bytes`` free.
    """
    path = Path(path)
    try:
        folder = path.parent if is_file else path
        ancestor = _nearest_existing(folder)
        if ancestor.is_dir():
            _check_names(path, flag, folder, ancestor, is_file)
        if path.is_symlink() and not path.exists():
            raise OutputPathError(f"{flag} {path}: a broken symbolic link (or a link loop)")
        if path.exists():
            if is_file and path.is_dir():
                raise OutputPathError(f"{flag} {path}: is a folder; give a file name")
            if not is_file and not path.is_dir():
                raise OutputPathError(f"{flag} {path}: exists and is a file, not a folder")
        if not ancestor.is_dir():
            raise OutputPathError(f"{flag} {path}: cannot create it, {ancestor} is a file, not a folder")
        _probe(path, flag, ancestor)
        if need_bytes > 0:
            free = shutil.disk_usage(ancestor).free
            if free < need_bytes:
                raise OutputPathError(
                    f"{flag} {path}: only {free / 1e6:.1f} MB free in {ancestor}; about "
                    f"{need_bytes / 1e6:.1f} MB will be written"
                )
    except OSError as exc:  # ENAMETOOLONG, ELOOP, EACCES while looking
        raise OutputPathError(f"{flag} {path}: {exc.strerror or exc}") from None
    return path


def partial_path(final: Path) -> Path:
    """The temporary beside ``final`` that :class:`StagedOutputs` writes first."""
    return final.parent / f".{final.stem}.{PARTIAL_TAG}-{os.getpid()}{final.suffix}"


def _alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        return True
    return True


def remove_stale_partials(folder: str | Path, max_age_s: float = STALE_TEMPORARY_S) -> int:
    """Remove the temporaries of :class:`StagedOutputs` left in ``folder`` by runs that were killed.

    A temporary is stale when the process named in it is gone, or it is older than ``max_age_s`` (a
    process id may have been reused). Returns how many were removed.
    """
    folder = Path(folder)
    if not folder.is_dir():
        return 0
    removed, now = 0, time.time()
    pattern = re.compile(rf"\.{PARTIAL_TAG}-(\d+)")
    for entry in folder.glob(f".*{PARTIAL_TAG}-*"):
        match = pattern.search(entry.name)
        if match is None:
            continue
        pid = int(match.group(1))
        try:
            old = now - entry.lstat().st_mtime > max_age_s
            if (pid != os.getpid() and not _alive(pid)) or old:
                if entry.is_dir() and not entry.is_symlink():
                    shutil.rmtree(entry)
                else:
                    entry.unlink()
                removed += 1
        except OSError:
            continue
    return removed


class StagedOutputs:
    """Several output files written as one (module docstring).

    ``with StagedOutputs({"mp4": out / "dance.mp4", ...}) as staged:`` — write each to
    ``staged.path(key)``, then ``staged.commit()`` moves them all to their final names. Leaving the
    block without committing (an exception) removes every temporary and the folders it created.
    """

    def __init__(self, finals: dict[str, Path]) -> None:
        self.finals = {k: Path(v) for k, v in finals.items()}
        self.temps = {k: partial_path(v) for k, v in self.finals.items()}
        self._created: list[Path] = []
        self._committed = False

    def __enter__(self) -> StagedOutputs:
        for folder in sorted({p.parent for p in self.finals.values()}, key=lambda p: len(p.parts)):
            missing = []
            probe = folder
            while not probe.exists() and probe != probe.parent:
                missing.append(probe)
                probe = probe.parent
            for part in reversed(missing):
                part.mkdir()
                self._created.append(part)
        for folder in {p.parent for p in self.finals.values()}:
            remove_stale_partials(folder)
        return self

    def path(self, key: str) -> Path:
        """Where to write ``key``'s output (its temporary)."""
        return self.temps[key]

    def commit(self) -> list[Path]:
        """Move every temporary to its final name (all were written); returns the final paths."""
        for key, final in self.finals.items():
            os.replace(self.temps[key], final)
        self._committed = True
        return list(self.finals.values())

    def __exit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        tb: TracebackType | None,
    ) -> None:
        for tmp in self.temps.values():
            for leftover in [tmp, *tmp.parent.glob(f".{tmp.stem}.*{tmp.suffix}")]:
                try:
                    leftover.unlink(missing_ok=True)
                except OSError:
                    continue
        if not self._committed:
            for folder in reversed(self._created):
                try:
                    folder.rmdir()  # only when empty
                except OSError:
                    break
