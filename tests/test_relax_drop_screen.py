"""The screened term drop of the Prony path (one QR for all candidates) picks what evaluating every candidate
exactly picks, ties included, and the fit it leads to is the same to the bit."""
from __future__ import annotations

import numpy as np
import pytest

from bpmid.relax import varpro as RV
from bpmid.relax.bases import StepBasis
from bpmid.varpro import evaluate


def _exhaustive(basis, y, sol):
    best, best_sse = None, np.inf
    for j in range(sol.m):
        th = np.delete(sol.theta, j)
        s = evaluate(basis, y, th).sse
        if s < best_sse:
            best, best_sse = th, s
    return best


def _curve(seed, m=7, n=400):
    rng = np.random.default_rng(seed)
    t = np.logspace(-3, 3, n)
    tau = np.logspace(-2, 2, m) * np.exp(rng.normal(0, 0.2, m))
    E = rng.uniform(5, 50, m)
    y = 10 + np.exp(-t[:, None] / tau[None, :]) @ E + rng.normal(0, 0.05, n)
    return StepBasis(t), y


@pytest.mark.parametrize("seed", range(6))
def test_screened_drop_equals_exhaustive(seed):
    basis, y = _curve(seed)
    theta = np.sort(np.log(np.logspace(-3, 3, 12)) + np.random.default_rng(seed + 100).normal(0, 0.1, 12))
    sol = evaluate(basis, y, theta)
    assert RV._screen_drops(basis, y, sol.theta) is not None  # the screened route is the one tested
    for _ in range(8):  # walk down the path, comparing every step
        a, b = RV.drop_one(basis, y, sol), _exhaustive(basis, y, sol)
        assert np.array_equal(a, b)
        sol = evaluate(basis, y, a)


def test_exact_ties_keep_the_first_candidate():
    basis, y = _curve(3)
    theta = np.log(np.array([0.01, 0.3, 0.3, 5.0, 5.0, 60.0]))  # dropping either twin gives the same SSE
    sol = evaluate(basis, y, theta)
    assert np.array_equal(RV.drop_one(basis, y, sol), _exhaustive(basis, y, sol))


def test_short_design_falls_back_to_exact_evaluation():
    basis, y = _curve(1, n=30)
    sol = evaluate(basis, y, np.log(np.logspace(-2, 2, 9)))
    assert RV._screen_drops(basis, y, sol.theta) is None
    assert np.array_equal(RV.drop_one(basis, y, sol), _exhaustive(basis, y, sol))


def test_the_path_is_the_same_as_with_exhaustive_drops(monkeypatch):
    basis, y = _curve(5)
    bounds = (np.log(1e-4), np.log(1e4))
    kw = dict(per_decade=8, m_min=1, m_max=6)
    fast = RV.model_path(basis, y, bounds, **kw)
    monkeypatch.setattr(RV, "drop_one", _exhaustive)
    slow = RV.model_path(basis, y, bounds, **kw)
    assert sorted(fast) == sorted(slow)
    for m in fast:
        assert np.array_equal(fast[m].theta, slow[m].theta) and np.array_equal(fast[m].coef, slow[m].coef)
