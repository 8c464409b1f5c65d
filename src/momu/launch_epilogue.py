"""``python -m momu.launch_epilogue PID LINE [CLAIM]``: print ``LINE`` on stderr once process ``PID`` exits.

Started (detached) by :func:`momu.errors.fail` when a recipe fails under ``accelerate launch``: the
launcher prints its own traceback or failure summary *after* its child exits, so the child's
one-line reason would be buried. This process waits for the launcher to finish (a zombie counts
as finished: its parent may be waiting for our stderr to close before reaping it), then repeats the
reason so it is the last line, and removes the ``CLAIM`` file :func:`momu.errors.fail` made. It
gives up silently after :data:`MAX_WAIT_S`.
"""

from __future__ import annotations

import sys
import time
from pathlib import Path

MAX_WAIT_S = 120.0
POLL_S = 0.02


def _finished(pid: int) -> bool:
    import psutil

    try:
        return psutil.Process(pid).status() == psutil.STATUS_ZOMBIE
    except psutil.NoSuchProcess:
        return True
    except psutil.Error:
        return False


def main(argv: list[str]) -> int:
    if len(argv) not in (2, 3) or not argv[0].isdigit():
        return 2
    pid, line = int(argv[0]), argv[1]
    try:
        deadline = time.monotonic() + MAX_WAIT_S
        while not _finished(pid):
            if time.monotonic() > deadline:
                return 1
            time.sleep(POLL_S)
        sys.stderr.write(line + "\n")
        sys.stderr.flush()
        return 0
    finally:
        if len(argv) == 3:
            Path(argv[2]).unlink(missing_ok=True)


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
