"""Progress on stderr for long work: shown only when stderr is a terminal and --quiet was not given (:func:`line`,
for a sweep's one line per case: unless --quiet, also when stderr goes to a file)."""
from __future__ import annotations

import sys
import time

_QUIET = False


def set_quiet(quiet: bool) -> None:
    global _QUIET
    _QUIET = bool(quiet)


def enabled() -> bool:
    return not _QUIET and hasattr(sys.stderr, "isatty") and sys.stderr.isatty()


def note(message: str) -> None:
    """One line of progress (a stage starting or ending)."""
    if enabled():
        print(f"[bpmid] {message}", file=sys.stderr, flush=True)


def line(message: str) -> None:
    """One line of progress of long work that is often run with stderr sent to a file (a sweep of hundreds of
    cases, ``bpmid calibrate ... 2> sweep.log``): shown unless --quiet, on a terminal or not, one whole line each."""
    if not _QUIET:
        print(f"[bpmid] {message}", file=sys.stderr, flush=True)


class Progress:
    """``with Progress(total, "fitting") as pr: ... pr.advance()``: a one-line counter with elapsed time."""

    def __init__(self, total: int, label: str):
        self.total = max(int(total), 1)
        self.label = label
        self.done = 0
        self.t0 = time.perf_counter()

    def __enter__(self):
        self._draw()
        return self

    def advance(self, n: int = 1, detail: str = "") -> None:
        self.done += n
        self._draw(detail)

    def _draw(self, detail: str = "") -> None:
        if enabled():
            el = time.perf_counter() - self.t0
            sys.stderr.write(f"\r[bpmid] {self.label}: {self.done}/{self.total} ({el:.1f} s) {detail[:40]:<40}")
            sys.stderr.flush()

    def __exit__(self, *exc):
        if enabled():
            sys.stderr.write("\n")
            sys.stderr.flush()
        return False
