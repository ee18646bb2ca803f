"""Run small dense linear algebra on one BLAS thread: the one place bpmid sets the BLAS thread count.

The variable-projection fit does thousands of QR/SVD factorisations of matrices of a few hundred by
a few dozen entries, and the motion fit and discovery a sequence of small least-squares solves between
runs of the compiled forward model. Multi-threaded BLAS is 10-20x *slower* on such sizes when the cores
are shared (and its spinning threads double the kernel's cost per step), so this work runs inside
:func:`single_thread_blas` (or a function decorated with :func:`one_blas_thread`): the relaxation fit,
``fit motion`` and ``discover``. With threadpoolctl installed it sets every BLAS it knows; otherwise this
finds the OpenBLAS libraries numpy and scipy loaded (from ``/proc/self/maps``) and sets their thread
count with ctypes, restoring it on exit; where neither is possible it does nothing.
"""
from __future__ import annotations

import contextlib
import ctypes
import functools
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
    """Context in which BLAS uses one thread (no-op when no BLAS library can be set)."""
    try:
        from threadpoolctl import threadpool_limits
    except ImportError:
        threadpool_limits = None
    if threadpool_limits is not None:
        with threadpool_limits(limits=1, user_api="blas"):
            yield
        return
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


def one_blas_thread(fn):
    """Decorator: run ``fn`` inside :func:`single_thread_blas` (for entry points made of many small solves)."""

    @functools.wraps(fn)
    def wrapper(*args, **kwargs):
        with single_thread_blas():
            return fn(*args, **kwargs)

    return wrapper
