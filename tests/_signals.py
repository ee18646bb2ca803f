"""Test signals shared by several test files (imported as ``_signals``; pytest puts tests/ on sys.path)."""
from __future__ import annotations

import numpy as np


def triangle_with_holds(rate, lo=1.2, hi=1.8, cycles=2, hold=5.0, dt=0.1):
    """Absolute pressure (bar) and time (s): hold, triangles lo-hi at +-rate (bar/s) with holds at the top, hold."""
    seg = [np.full(int(hold / dt), lo)]
    up, down = np.arange(lo, hi, rate * dt), np.arange(hi, lo, -rate * dt)
    for _ in range(cycles):
        seg += [up, np.full(int(hold / dt), hi), down]
    seg.append(np.full(int(hold / dt), lo))
    p = np.concatenate(seg)
    return np.arange(p.size) * dt, p
