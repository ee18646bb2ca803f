"""The shipped comparison gives every baseline a static part that extrapolates sanely.

The baselines are fitted on the fitting set (0.19-0.59 bar gauge) and run free up to 1.19 bar gauge. With
the settings of ``configs/compare_paper.yaml`` (``compare.options``, the same in ``configs/paper.yaml``)
each fitted baseline must answer a very slow triangle 0.2 -> 1.2 -> 0.2 bar gauge with a finite, physically
plausible angle (0-180 deg) whose rising branch increases with pressure, as the muscle's does.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from bpmid.compare import build_model, resolve_inputs
from bpmid.config import load_config
from bpmid.io.motion_logs import from_arrays, read_motion_logs

REPO = Path(__file__).resolve().parents[1]
BASELINES = ("gpi", "maxwell-slip", "three-element", "two-branch")


@pytest.fixture(scope="module")
def shipped():
    cfg = load_config(REPO / "configs" / "compare_paper.yaml")
    section = cfg.section("compare")
    train_paths, _sets, _relax = resolve_inputs(section, cfg)
    return {name: dict(opt) for name, opt in section.options.items()}, read_motion_logs(train_paths, require_angle=True)


def slow_triangle(rate_bar_s=0.005, dt=0.1):
    """Hold 0.2 bar gauge for 5 s, rise to 1.2 bar and fall back at ``rate_bar_s``; index range of the rise."""
    up = np.arange(0.2, 1.2 + 1e-9, rate_bar_s * dt)
    hold = np.full(50, 0.2)
    p = np.concatenate([hold, up, up[::-1]])
    return from_arrays("slow_triangle", np.arange(p.size) * dt, p * 1e5), hold.size, hold.size + up.size


def test_both_configs_ship_the_same_baseline_settings(shipped):
    options, _train = shipped
    assert set(BASELINES) <= set(options)
    paper = load_config(REPO / "configs" / "paper.yaml").section("compare").options
    assert {k: dict(v) for k, v in paper.items()} == options


@pytest.mark.parametrize("name", BASELINES)
def test_fitted_baseline_static_response_is_monotone_and_plausible(shipped, name):
    options, train = shipped
    model = build_model(name, options.get(name))
    res = model.fit(train)
    log, a, b = slow_triangle()
    y = model.simulate(res.params, log)
    assert np.all(np.isfinite(y))
    assert y.min() >= 0.0 and y.max() <= 180.0, (name, y.min(), y.max())
    rise = y[a:b]
    # the angle never falls while the pressure rises (fp round-off allowed) ...
    assert np.diff(rise).min() >= -1e-9, (name, np.diff(rise).min())
    # ... and bends the muscle substantially over 0.2 -> 1.2 bar gauge (it does not saturate to a flat line)
    assert rise[-1] - rise[0] > 30.0, (name, rise[0], rise[-1])
    # the fitting set itself is still fitted (a sane static part is not bought with a useless model)
    assert res.rmse < 3.0, (name, res.rmse)


def test_compare_defaults_are_the_shipped_settings_and_the_config_overrides_them(shipped):
    from bpmid.compare import DEFAULT_OPTIONS, effective_options

    options, _train = shipped
    for name in BASELINES:
        assert effective_options(name, None) == options[name]  # `bpmid compare` without a config is fair too
    assert effective_options("maxwell-slip", {"poly_degree": 2})["poly_degree"] == 2
    assert effective_options("maxwell-slip", {"poly_degree": 2})["orientation"] == DEFAULT_OPTIONS["maxwell-slip"]["orientation"]
