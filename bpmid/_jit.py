"""``lazy_njit``: numba's ``njit`` applied on a kernel's first call, so that importing a module that defines
compiled kernels does not import numba (0.2 s) unless a kernel actually runs."""
from __future__ import annotations

import functools


def lazy_njit(fn=None, **options):
    """Like ``numba.njit(**options)(fn)``, but numba is imported and the kernel compiled (or read from the
    cache) on the first call. ``kernel.compiled()`` gives the numba dispatcher (for use inside other kernels)."""
    if fn is None:
        return lambda f: lazy_njit(f, **options)

    state = {}

    def compiled():
        if "d" not in state:
            import numba

            state["d"] = numba.njit(**options)(fn)
        return state["d"]

    @functools.wraps(fn)
    def call(*args):
        return compiled()(*args)

    call.compiled = compiled
    call.py_func = fn
    return call
