"""Issue 19 kernel items: the full history without subnormal exp() still equals the exact recursion, the
hereditary full sum skips only terms below the smallest double, and small solves run on one BLAS thread."""
import numpy as np

from bpmid.models.vbmm import VBMM, Material
from bpmid.viscoelastic import hereditary_full, hereditary_recursive


def test_full_history_with_old_terms_skipped_equals_the_recursion():
    # tau 0.2 s: every increment older than 149 s (age/tau > 745) is skipped in the full sum
    mat = Material(9050.0, 6.4e6, (18300.0, 2000.0), (1.36e7, 1.0e6), (0.2, 30.0))
    t = np.round(np.arange(0.0, 400.0, 0.1), 10)
    p = 5e4 + 4e4 * np.abs(np.sin(2 * np.pi * t / 23.0)) + 1e4 * np.sin(2 * np.pi * t / 3.1)
    full = VBMM(mat, history="full").forward_deg(t, p)
    rec = VBMM(mat, history="recursive").forward_deg(t, p)
    assert np.max(np.abs(full - rec)) < 1e-9


def test_hereditary_full_skipping_is_exact_to_the_last_bit_of_the_kernel():
    rng = np.random.default_rng(19)
    t = np.cumsum(rng.uniform(0.05, 0.15, 3000))
    x = np.cumsum(rng.normal(0, 1e-3, t.size))
    M, tau = np.array([2.0, 1.0]), np.array([0.05, 4.0])
    full = hereditary_full(t, x, 1.0, M, tau)
    # the sum written out directly with every term (numpy, no skipping), at a few late steps
    for k in (t.size - 1, t.size // 2):
        age = t[k] - t[1:k + 1]
        kern = 1.0 + np.exp(-age[:, None] / tau[None, :]) @ M
        direct = 1.0 * x[0] + np.sum(kern * np.diff(x[:k + 1]))
        assert abs(full[k] - direct) < 1e-12 * max(1.0, abs(direct))
    assert np.max(np.abs(full - hereditary_recursive(t, x, 1.0, M, tau))) < 1e-12


def test_fit_motion_and_discover_run_on_one_blas_thread():
    import bpmid.discover.workflow as W
    import bpmid.motion_fit as MF
    from bpmid.relax._blas import _openblas_libs, one_blas_thread

    assert getattr(MF.fit_motion, "__wrapped__", None) is not None
    assert getattr(W.discover, "__wrapped__", None) is not None
    libs = _openblas_libs()
    seen = []

    @one_blas_thread
    def inside():
        seen.extend(int(get()) for get, _set in libs)

    before = [int(get()) for get, _set in libs]
    try:
        for _get, set_ in libs:
            set_(2)  # as a multi-threaded BLAS would start
        inside()
        assert len(seen) == len(libs) and all(n == 1 for n in seen)
        assert all(int(get()) == 2 for get, _set in libs)  # restored on exit
    finally:
        for (_get, set_), n in zip(libs, before):
            set_(n)
