"""A folder held by another process, as a second bpmid command holds it (imported as ``_holders``; pytest puts
tests/ on sys.path)."""
from __future__ import annotations

import contextlib
import subprocess
import sys


@contextlib.contextmanager
def held_by_another_process(folder):
    """``folder`` locked (flock, exclusive) by a child process for the block, as a running bpmid command holds
    its output folder; released when the block ends."""
    holder = subprocess.Popen([sys.executable, "-c", "import fcntl, os, sys, time; fd = os.open(sys.argv[1], "
                               "os.O_RDONLY); fcntl.flock(fd, fcntl.LOCK_EX); print('held', flush=True); "
                               "time.sleep(60)", str(folder)], stdout=subprocess.PIPE, text=True)
    try:
        assert holder.stdout.readline().strip() == "held"
        yield
    finally:
        holder.kill()
        holder.wait()
