"""Run small dense linear algebra on one BLAS thread.

The variable-projection fit does thousands of QR/SVD factorisations of matrices of a few hundred by
a few dozen entries. Multi-threaded OpenBLAS is 10-20x *slower* on such sizes when the cores are
shared, so the fit runs inside :func:`single_thread_blas`. This finds the OpenBLAS libraries numpy
and scipy loaded (from ``/proc/self/maps``) and sets their thread count with ctypes, restoring it on
exit; where that is not possible it does nothing.
"""
from __future__ import annotations

import contextlib
import ctypes
from typing import Iterator

_SETTERS = ("scipy_openblas_set_num_threads64_", "scipy_openblas_set_num_threads", "openblas_set_num_threads64_",
            "openblas_set_num_threads")
_GETTERS = ("scipy_openblas_get_num_threads64_", "scipy_openblas_get_num_threads", "openblas_get_num_threads64_",
            "openblas_get_num_threads")


def _openblas_libs() -> list[tuple[object, object]]:
    try:
        with open("/proc/self/maps") as fh:
            paths = sorted({ln.split()[-1] for ln in fh
                            if "openblas" in ln.split()[-1] and ".so" in ln.split()[-1]})
    except OSError:
        return []
    out = []
    for p in paths:
        try:
            lib = ctypes.CDLL(p)
        except OSError:
            continue
        get = next((getattr(lib, n) for n in _GETTERS if hasattr(lib, n)), None)
        set_ = next((getattr(lib, n) for n in _SETTERS if hasattr(lib, n)), None)
        if get is not None and set_ is not None:
            out.append((get, set_))
    return out


@contextlib.contextmanager
def single_thread_blas() -> Iterator[None]:
    """Context in which OpenBLAS uses one thread (no-op when OpenBLAS is not found)."""
    libs = _openblas_libs()
    old = []
    for get, set_ in libs:
        try:
            old.append((set_, int(get())))
            set_(1)
        except Exception:  # pragma: no cover - exotic builds
            pass
    try:
        yield
    finally:
        for set_, n in old:
            set_(n)
