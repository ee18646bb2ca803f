"""bpmid export --to c: the exported C equals bpmid's own models on every shipped motion log.

Built with ``cc -std=c99 -Wall -Wextra -Werror -pedantic -O2``; skipped only where no C compiler exists
(and the skip says so).
"""
import dataclasses
import glob
import os
import subprocess

import numpy as np
import pytest
import yaml
from typer.testing import CliRunner

from bpmid.cli import app
from bpmid.control import ControlConfig, build_plant, builtin_reference, fit_ms_feedforward, simulate_loop
from bpmid.export.c import CModel, build_c, export_c, find_cc, load_vbmm_fit
from bpmid.io.motion_logs import read_motion_logs
from bpmid.io.results import dump_yaml
from bpmid.models.maxwell_slip import MaxwellSlipModel
from bpmid.models.vbmm import VBMM, Geometry, Material, vbmm_yaml_body
from bpmid.predict import predict

REPO = os.path.abspath(os.path.join(os.path.dirname(__file__), ".."))
CC = find_cc()


@pytest.fixture(autouse=True)
def _need_cc():
    if CC is None:
        pytest.skip("no C compiler (cc, gcc or clang) on this machine: the exported C cannot be built here; "
                    ".ci/run installs gcc")


@pytest.fixture(scope="module")
def logs():
    paths = sorted(glob.glob(os.path.join(REPO, "datasets", "motion", "*", "*.csv")))
    assert len(paths) >= 30
    return read_motion_logs(paths)


def write_fit(path, model: VBMM, effects=None):
    body = {"schema": "bpmid.vbmm/1", **vbmm_yaml_body(model)}
    if effects is not None:
        body["effects"] = effects
    body["metrics"] = {"rmse_deg": 0.0, "mape_pct": 0.0, "r2": 1.0}
    body["provenance"] = {"bpmid_version": "test", "command": "test"}
    path.write_text(dump_yaml(body), encoding="utf-8")
    return path


def exported(tmp_path_factory, name, fit, filter=False, **kw):
    """Export ``fit``; build the shared library (stepped through ctypes) and, with ``filter``, the stdin filter."""
    d = tmp_path_factory.mktemp(name)
    export_c(fit, d / "src", **kw)
    exe = build_c(d / "src", d / "filter") if filter else None
    lib = build_c(d / "src", d / "libmodel.so", shared=True)
    return d, exe, CModel(lib)


def run_filter(exe, t, x, inverse=False):
    text = "".join(f"{float(a)!r},{float(b)!r}\n" for a, b in zip(t, x))
    head = "time_s,angle_deg\n" if inverse else "time_s,pressure_gauge_pa\n"
    res = subprocess.run([str(exe)] + (["-i"] if inverse else []), input=head + text,
                         capture_output=True, text=True, check=True)
    return np.array(res.stdout.split(), float)


FITTED = Material(9050.0, 6.1e6, (18300.0,), (1.35e7,), (0.39,))


@pytest.fixture(scope="module")
def plain(tmp_path_factory):
    d = tmp_path_factory.mktemp("plain_fit")
    fit = write_fit(d / "VBMM.yaml", VBMM(FITTED))
    return (fit,) + exported(tmp_path_factory, "plain", fit, filter=True)


def test_forward_equals_bpmid_predict_and_inverse_gives_the_pressure_back_on_every_shipped_log(plain, logs):
    fit, _d, exe, _lib = plain
    model = load_vbmm_fit(fit).base
    preds = predict(logs, model)
    worst_fwd = worst_inv = 0.0
    for lg, pr in zip(logs, preds):
        ang = run_filter(exe, lg.time_s, lg.pressure_pa)
        worst_fwd = max(worst_fwd, float(np.max(np.abs(ang - pr.angle_pred_deg))))
        back = run_filter(exe, lg.time_s, ang, inverse=True)
        worst_inv = max(worst_inv, float(np.max(np.abs(back - lg.pressure_pa))) / 1e3)
    assert worst_fwd < 1e-9, worst_fwd  # the kernel and the C take the same steps (issue 19: same to 1e-9 deg)
    assert worst_inv < 1e-6, worst_inv  # kPa


def test_forward_equals_the_predict_command_csv(plain, tmp_path):
    fit, _d, exe, _lib = plain
    log = os.path.join(REPO, "datasets", "motion", "variable_rate", "rate_0p114_r1.csv")
    res = CliRunner().invoke(app, ["predict", log, "--params", str(fit), "--out", str(tmp_path / "pred")])
    assert res.exit_code == 0, res.output
    import pandas as pd

    df = pd.read_csv(tmp_path / "pred" / "rate_0p114_r1.csv", comment="#")
    lg = read_motion_logs([log])[0]
    ang = run_filter(exe, lg.time_s, lg.pressure_pa)
    assert np.max(np.abs(ang - df["angle_pred_deg"].to_numpy())) <= 1e-6


def test_header_carries_provenance_and_the_code_only_math_h(plain):
    import hashlib

    fit, d, _exe, lib = plain
    h = (d / "src" / "bpmid_model.h").read_text()
    c = (d / "src" / "bpmid_model.c").read_text()
    assert hashlib.sha256(fit.read_bytes()).hexdigest() in h
    from bpmid import __version__

    assert f"bpmid {__version__}" in h
    includes = [ln for ln in (h + c).splitlines() if ln.startswith("#include")]
    assert includes == ["#include <math.h>", '#include "bpmid_model.h"']
    assert "malloc" not in c
    # no global state: every static is a function or a constant table
    for ln in c.splitlines():
        if "static " in ln:
            assert "(" in ln or "const" in ln, ln
    assert 0 < lib.state_bytes < 256


def test_branches_split_tau_consistent_closure_and_a_float_build(tmp_path_factory, logs):
    mat = Material(9000.0, 6.0e6, (15000.0, 4000.0), (1.2e7, 3.0e6), (0.3, 6.0), (0.25, 9.0))
    model = VBMM(mat, Geometry(), closure="consistent")
    d = tmp_path_factory.mktemp("split_fit")
    fit = write_fit(d / "VBMM.yaml", model)
    dd, _exe, lib = exported(tmp_path_factory, "split", fit)
    single = CModel(build_c(dd / "src", dd / "libfloat.so", shared=True, single=True))
    worst = worst_float = 0.0
    for lg in logs[::4]:
        ref = model.forward_deg(lg.time_s, lg.pressure_pa)
        worst = max(worst, float(np.max(np.abs(lib.run_forward(lg.time_s, lg.pressure_pa) - ref))))
        worst_float = max(worst_float, float(np.max(np.abs(single.run_forward(lg.time_s, lg.pressure_pa) - ref))))
    assert worst < 1e-9
    assert worst_float < 0.05  # single precision: measured and stated in the README


EFFECTS = [
    {"id": "pressure_lag", "parameters": {"tau": {"value": 0.2, "stderr": None, "unit": "s"}}},
    {"id": "braid_friction", "settings": {"elements": 3}, "parameters": {"braid_friction.r": {"value": 3000.0, "unit": "Pa"}}},
    {"id": "second_relaxation", "parameters": {"weight": 0.3, "tau": 8.0}},
    {"id": "strain_stiffening", "parameters": {"c": 5.0}},
    {"id": "thermal_softening", "parameters": {"amount": 0.1, "T": 100.0}},
    {"id": "angle_offset", "parameters": {"offset": {"value": 1.5, "unit": "deg"}}},
]


def test_a_float_build_compiles_under_double_promotion_and_conversion_warnings(tmp_path_factory):
    """-Wdouble-promotion, which projects on a single-precision FPU use, said 5 warnings in the float build (the
    input bounds as float literals against the double arguments, a float step against its cached double); with
    every effect of the catalogue (two lags, general friction, asymmetric relaxation) the model builds warning-free
    in both precisions under -Wdouble-promotion -Wconversion -Wshadow."""
    from bpmid.export.c import STRICT_FLAGS

    fx = [{"id": "pressure_lag", "parameters": {"tau": 0.2, "share": 0.3}},
          {"id": "braid_friction", "settings": {"elements": 3}, "parameters": {"r": 1500.0, "mu": 0.02, "slip": 8000.0}},
          {"id": "asymmetric_relaxation", "parameters": {"fall_ratio": 1.5}}] + EFFECTS[2:]
    d = tmp_path_factory.mktemp("warn_fit")
    mat = Material(9000.0, 6.0e6, (15000.0, 4000.0), (1.2e7, 3.0e6), (0.3, 6.0), (0.25, 9.0))
    for name, fit in (("plain", write_fit(d / "VBMM.yaml", VBMM(FITTED))),
                      ("effects", write_fit(d / "VBMM_fx.yaml", VBMM(mat, Geometry(), closure="consistent"), fx))):
        src = d / f"src_{name}"
        export_c(fit, src)
        for single in (False, True):
            build_c(src, d / f"{name}_{single}", single=single,
                    flags=STRICT_FLAGS + ("-Wdouble-promotion", "-Wconversion", "-Wshadow"))


def test_effects_forward_equals_the_augmented_model_and_inverse_is_a_right_inverse(tmp_path_factory, logs):
    d = tmp_path_factory.mktemp("fx_fit")
    fit = write_fit(d / "VBMM.yaml", VBMM(FITTED), EFFECTS)
    _dd, _exe, lib = exported(tmp_path_factory, "fx", fit)
    aug = load_vbmm_fit(fit)
    assert [e.id for e in aug.effects] == [e["id"] for e in EFFECTS]
    # the same effects without the lag: the feedforward is their exact inverse there
    fit_nl = write_fit(d / "VBMM_nolag.yaml", VBMM(FITTED), EFFECTS[1:])
    _dd, _exe, lib_nl = exported(tmp_path_factory, "fx_nolag", fit_nl)
    for lg in logs[::6]:
        ref = aug.simulate_deg(lg.time_s, lg.pressure_pa)
        ang = lib.run_forward(lg.time_s, lg.pressure_pa)
        assert np.max(np.abs(ang - ref)) < 1e-6
        # the inverse: the pressure it returns gives the wanted angle back (friction makes the pressure
        # inside a dead band free, so the pressure itself is not unique)
        p_inv = lib.run_inverse(lg.time_s, ang)
        assert np.max(np.abs(lib.run_forward(lg.time_s, p_inv) - ang)) < 1e-6
        # the feedforward: the command that, held over each step, drives the lag to the pressure the rest of the
        # model needs (the rest inverted exactly: the lag-free model's inverse)
        p_cmd = lib.run_feedforward(lg.time_s, ang)
        p_rest = lib_nl.run_inverse(lg.time_s, ang)
        tau = EFFECTS[0]["parameters"]["tau"]["value"]
        assert np.max(np.abs(held_lag(lg.time_s, p_cmd, tau) - p_rest)) < 1e-6 * np.max(np.abs(p_rest))
        assert np.array_equal(lib_nl.run_feedforward(lg.time_s, ang), p_rest)   # no lag: the two are one


def held_lag(t, u, tau):
    """A first-order lag driven by a command held over each step (the output at sample k after the
    command u_k was held over (t_(k-1), t_k]): y_k = a y_(k-1) + (1 - a) u_k, y_0 = u_0."""
    y = np.empty(len(u))
    y[0] = u[0]
    for k in range(1, len(u)):
        a = np.exp(-(t[k] - t[k - 1]) / tau)
        y[k] = a * y[k - 1] + (1.0 - a) * u[k]
    return y


@pytest.mark.parametrize("mu, slip", [(0.02, 8000.0), (0.03, 0.0)])
def test_general_friction_forward_equals_the_augmented_model_and_inverse_is_a_right_inverse(
        tmp_path_factory, logs, mu, slip):
    # the friction discovery names: a sliding level growing with the pressure (mu) and an elastic stick (slip),
    # or a rigid stick whose dead band grows with the pressure (slip = 0); alone (a lag in front of it makes
    # the feedforward a held command, tested with the other effects)
    fx = [{"id": "braid_friction", "settings": {"elements": 3}, "parameters": {"r": 1500.0, "mu": mu, "slip": slip}}]
    d = tmp_path_factory.mktemp("gen_friction_fit")
    fit = write_fit(d / "VBMM.yaml", VBMM(FITTED), fx)
    dd, _exe, lib = exported(tmp_path_factory, "gen_friction", fit)
    src = (dd / "src" / "bpmid_model.c").read_text()
    assert "friction_inverse" in src and "mean of 3 friction operator(s)" in src
    aug = load_vbmm_fit(fit)
    assert not aug.effects[0].is_play(aug.params)
    for lg in logs[::8]:
        ref = aug.simulate_deg(lg.time_s, lg.pressure_pa)
        ang = lib.run_forward(lg.time_s, lg.pressure_pa)
        assert np.max(np.abs(ang - ref)) < 1e-6
        # mu and slip change the loop: the exported model is not the play form under another name
        play = dataclasses.replace(aug, params=aug.params.with_values({"braid_friction.mu": 0.0,
                                                                        "braid_friction.slip": 0.0}))
        assert np.max(np.abs(ang - play.simulate_deg(lg.time_s, lg.pressure_pa))) > 1e-2
        p_ff = lib.run_inverse(lg.time_s, ang)
        assert np.all(np.isfinite(p_ff))
        assert np.max(np.abs(lib.run_forward(lg.time_s, p_ff) - ang)) < 1e-6
    if slip > 0:
        # single precision: the friction operators and their bisection at float resolution
        lib_f = CModel(build_c(dd / "src", dd / "libf.so", shared=True, single=True))
        lg = logs[0]
        ang = lib.run_forward(lg.time_s, lg.pressure_pa)
        assert np.max(np.abs(lib_f.run_forward(lg.time_s, lg.pressure_pa) - ang)) < 1e-2
        p_f = lib_f.run_inverse(lg.time_s, ang)
        assert np.max(np.abs(lib.run_forward(lg.time_s, p_f) - ang)) < 1e-2


def test_lag_inverse_gives_the_pressure_back_and_the_feedforward_never_rings(tmp_path_factory, logs):
    d = tmp_path_factory.mktemp("lag_fit")
    fit = write_fit(d / "VBMM.yaml", VBMM(FITTED), [EFFECTS[0], EFFECTS[-1]])
    _dd, _exe, lib = exported(tmp_path_factory, "lag", fit)
    lg = logs[0]
    ang = lib.run_forward(lg.time_s, lg.pressure_pa)
    assert np.max(np.abs(lib.run_inverse(lg.time_s, ang) - lg.pressure_pa)) < 1e-3  # Pa
    for lg in logs[::5]:
        ang = lib.run_forward(lg.time_s, lg.pressure_pa)
        back = lib.run_feedforward(lg.time_s, ang)
        # the forward reads a logged pressure as linear between samples, the feedforward returns a held command:
        # they differ by about half of each step's change, never more than the whole change of two steps
        dp = np.abs(np.diff(lg.pressure_pa))
        bound = np.concatenate([[0.0], np.maximum(dp, np.concatenate([[0.0], dp[:-1]]))]) + 1e-6
        assert np.all(np.abs(back - lg.pressure_pa) <= bound)
    # a step in the wanted angle (a reference the model did not make): the feedforward asks one sample above the
    # new level, then the level; no sample-to-sample ringing. The exact inverse of the interpolated lag rings at
    # the Nyquist rate with a slowly decaying swing (a pole near -1); where that swing goes below vacuum it says so
    for hz in (10.0, 100.0):
        t = np.arange(0.0, 4.0, 1.0 / hz)
        want = np.where(t < 2.0, 30.0, 40.0)
        p = lib.run_feedforward(t, want)
        k = int(np.flatnonzero(t >= 2.0)[0])
        after = p[k + 1:]
        assert p[k] > after.max()
        assert np.all(np.diff(after) <= 1e-9)      # settles from above, monotone (the creep the model holds)
        assert after.min() > p[:k].max()
        assert lib.status == 0
        ring = lib.run_inverse(t, want)
        flips = np.sum(np.diff(np.sign(np.diff(ring[k - 1:k + 12]))) != 0)
        assert flips >= 8
    statuses = []
    lib.reset()
    for a, b in zip(t, want):
        lib.inverse(float(a), float(b))
        statuses.append(lib.status)
    assert 1 in statuses


def test_asymmetric_relaxation_inverse_is_a_right_inverse_of_the_forward_through_reversals(tmp_path_factory, logs):
    """The inverse reads the forward's rule for the rate backwards: the pressure it returns brings the forward, from
    the direction it last took, to the angle asked, through every reversal (the rule of bpmid's vectorised
    inverse, the sign of each angle step, does not: after a peak the forward keeps the rising rate while the angle
    starts to fall, and a pressure from the falling rate then sends the two histories apart)."""
    d = tmp_path_factory.mktemp("asym_fit")
    fx = [{"id": "asymmetric_relaxation", "parameters": {"fall_ratio": 0.5}}]
    fit = write_fit(d / "VBMM.yaml", VBMM(FITTED), fx)
    _dd, _exe, lib = exported(tmp_path_factory, "asym", fit)
    aug = load_vbmm_fit(fit)
    worst = 0.0
    for lg in logs[::4]:
        ang = lib.run_forward(lg.time_s, lg.pressure_pa)
        assert np.max(np.abs(ang - aug.simulate_deg(lg.time_s, lg.pressure_pa))) < 1e-6
        p_ff = lib.run_inverse(lg.time_s, ang)
        worst = max(worst, float(np.max(np.abs(lib.run_forward(lg.time_s, p_ff) - ang))))
        # where the forward is one to one (away from reversals) the pressure itself comes back (to a fraction of a Pa:
        # a reversal where two pressures give one angle leaves a difference that fades with the memory)
        moving = np.abs(np.diff(ang, prepend=ang[0])) > 0.05
        assert np.median(np.abs(p_ff - lg.pressure_pa)[moving]) < 1.0
    assert worst < 1e-8


def test_asymmetric_inverse_on_a_step_reference_misses_only_where_it_says_so(tmp_path_factory):
    """A hold just after a fall has no pressure that gives it (the forward takes the falling rate only for an angle
    strictly below the last): the inverse flags that sample with status 1 and keeps the forward's history, so the
    forward follows the reference everywhere else (before: a 9 deg miss for seconds, status 0)."""
    d = tmp_path_factory.mktemp("asym_step")
    fit = write_fit(d / "VBMM.yaml", VBMM(FITTED), [{"id": "asymmetric_relaxation", "parameters": {"fall_ratio": 0.4}}])
    _dd, _exe, lib = exported(tmp_path_factory, "asym_step", fit)
    for hz in (10.0, 1000.0):
        t = np.arange(0.0, 12.0, 1.0 / hz)
        ref = np.where((t // 4) % 2 == 0, 45.0, 75.0)
        lib.reset()
        p, status = [], []
        for a, b in zip(t, ref):
            p.append(lib.inverse(float(a), float(b)))
            status.append(lib.status)
        miss = np.abs(lib.run_forward(t, np.array(p)) - ref)
        flagged = np.array(status) == 1
        assert np.max(miss[~flagged]) < 1e-6 and flagged.sum() <= 3


def test_a_feedforward_beyond_the_model_and_a_huge_input_say_so(tmp_path_factory):
    d = tmp_path_factory.mktemp("lag2")
    fx = [{"id": "pressure_lag", "parameters": {"tau": 0.3}}]
    fit = write_fit(d / "VBMM.yaml", VBMM(FITTED), fx)
    _dd, _exe, lib = exported(tmp_path_factory, "lag2", fit)
    t = np.arange(0.0, 2.0, 0.001)
    want = np.where(t < 1.0, 30.0, 40.0)
    lib.reset()
    for a, b in zip(t, want):
        v = lib.feedforward(float(a), float(b))
        if abs(a - 1.0) < 5e-4:   # the step asks a command of about tau/dt times the step: beyond the model
            assert v > 1e6 and lib.status == 1
    lib.reset()
    lib.forward(0.0, 5e4)
    before = lib.forward(0.1, 5e4)
    assert lib.forward(0.2, 1e300) == before and lib.status == 3
    assert lib.inverse(0.3, 1e300) == before and lib.status == 3


def _compare_file(path, ms: MaxwellSlipModel, params):
    body = {"schema": "bpmid.compare/1", "models": {"maxwell-slip": ms.describe(params)},
            "provenance": {"bpmid_version": "test"}}
    path.write_text(dump_yaml(body), encoding="utf-8")
    return path


def test_maxwell_slip_forward_equals_python_and_its_inverse_is_a_right_inverse(tmp_path_factory, logs):
    ms = MaxwellSlipModel(4, 3, orientation="lag")
    params = ms.default_params().with_values({"loop_sign": -1.0, "s0": 3.0, "s1": 60.0, "s2": 8.0, "s3": -2.0})
    d = tmp_path_factory.mktemp("ms_fit")
    fit = _compare_file(d / "compare.yaml", ms, params)
    _dd, _exe, lib = exported(tmp_path_factory, "ms", fit, model="maxwell-slip")
    for lg in logs[::3]:
        ref = ms.simulate(params, lg)
        ang = lib.run_forward(lg.time_s, lg.pressure_pa)
        assert np.max(np.abs(ang - ref)) < 1e-9
        p = lib.run_inverse(lg.time_s, ang)
        assert np.max(np.abs(lib.run_forward(lg.time_s, p) - ang)) < 1e-9
    # no fitted range, but what no rig gives is flagged (it said status 0 to -200 kPa gauge and to -5 deg asked)
    lib.reset()
    lib.forward(0.0, 20000.0)
    assert lib.status == 0
    lib.forward(0.1, -200000.0)
    assert lib.status == 1
    lib.reset()
    lib.inverse(0.0, 20.0)
    assert lib.status == 0
    lib.inverse(0.1, -5.0)
    assert lib.status == 1


QUIET = dataclasses.replace(ControlConfig(), sensors=dataclasses.replace(ControlConfig().sensors, angle_noise_deg=0.05))


def test_control_with_the_exported_feedforward_gives_the_same_rmse(tmp_path_factory, plain):
    fit, _d, _exe, lib = plain
    model = load_vbmm_fit(fit).base
    plant = build_plant(model, ["pressure_lag:tau=0.1"], QUIET)
    ref = builtin_reference("sines")
    ms_ff = fit_ms_feedforward(model, QUIET)
    # the MS-PI feedforward as a control result file, exported
    d = tmp_path_factory.mktemp("ctl")
    ctl = d / "control.yaml"
    ctl.write_text(dump_yaml({"schema": "bpmid.control/1", "ms_feedforward": {
        "poly_bar_per_deg_j": ms_ff.poly, "k_bar_per_deg": ms_ff.k, "D_deg": ms_ff.D}}), encoding="utf-8")
    _dd, _exe2, ms_lib = exported(tmp_path_factory, "ctl_ms", ctl, model="maxwell-slip")
    for controller, clib in (("vbmm-pi", lib), ("ms-pi", ms_lib)):
        py = simulate_loop(controller, ref, model, plant, QUIET, ms_ff=ms_ff)
        clib.reset()
        c = simulate_loop(controller, ref, model, plant, QUIET, ms_ff=ms_ff, feedforward=clib.inverse)
        assert np.max(np.abs(c.feedforward_bar_abs - py.feedforward_bar_abs)) < 1e-9
        assert abs(c.metrics(QUIET)["rmse_deg"] - py.metrics(QUIET)["rmse_deg"]) < 1e-9
    # and the MS feedforward itself equals its Python form sample by sample
    b = ref.angle_deg
    assert np.max(np.abs(ms_lib.run_inverse(ref.time_s, b) - ms_ff.pressure_bar(b) * 1e5)) < 1e-6


def test_filter_refuses_bad_lines(plain):
    _fit, _d, exe, _lib = plain
    for text, what in (("0,1000\nabc,2\n", "line 2"), ("0,1000\n0,2000\n", "rise strictly"), ("0;1000\n", "line 1"),
                       ("0,50000\n0.1,nan\n", "line 2: not a finite number"), ("0,50000\ninf,1\n", "line 2"),
                       ("nan,50000\n0.1,1\n", "line 1: not a finite number")):
        res = subprocess.run([str(exe)], input=text, capture_output=True, text=True)
        assert res.returncode == 2 and what in res.stderr, res.stderr
    # a header naming other columns (a log in absolute bar, in kPa) is refused, naming what is read
    for flag, head in (([], "time_s,pressure_bar"), ([], "time_s,pressure_kpa_gauge"),
                       (["-i"], "time_s,pressure_gauge_pa")):
        res = subprocess.run([str(exe), *flag], input=f"{head}\n0,1.2\n0.1,1.3\n", capture_output=True, text=True)
        assert res.returncode == 2 and res.stdout == "", res.stderr
        assert f"line 1: the header names '{head}'" in res.stderr and "time in s" in res.stderr
    # a tab-separated header is shown with its tab (it read 'time_spressure_gauge_pa'), the comma asked for
    res = subprocess.run([str(exe)], input="time_s\tpressure_gauge_pa\n0\t1000\n", capture_output=True, text=True)
    assert res.returncode == 2 and "names 'time_s\\tpressure_gauge_pa'" in res.stderr, res.stderr
    assert "separated by a comma" in res.stderr
    # a value the model refuses (status 3) stops the filter naming the line, printing nothing for it (it printed
    # the previous angle again and went on); a hexadecimal number is refused, not read as 16 Pa
    for text, what, printed in (("0,50000\n0.1,5e10\n0.2,60000\n", "line 2: input refused", 1),
                                ("0,5e10\n", "line 1: input refused", 0),
                                ("0,0x10\n", "line 1: a hexadecimal number", 0)):
        res = subprocess.run([str(exe)], input=text, capture_output=True, text=True)
        assert res.returncode == 2 and what in res.stderr and len(res.stdout.split()) == printed, res.stderr
    res = subprocess.run([str(exe), "-i"], input="0,30\n0.1,2e6\n0.2,40\n", capture_output=True, text=True)
    assert res.returncode == 2 and "line 2: input refused" in res.stderr and len(res.stdout.split()) == 1
    # the header it reads, with spaces, quotes, CRLF or Excel's UTF-8 byte-order mark, and no header at all: read
    for text in ('"time_s", "pressure_gauge_pa"\r\n0,20000\r\n', "0,20000\n",
                 "\ufefftime_s,pressure_gauge_pa\n0,20000\n"):
        res = subprocess.run([str(exe)], input=text, capture_output=True, text=True)
        assert res.returncode == 0 and len(res.stdout.split()) == 1, res.stderr


def test_filter_feedforward_flag(plain):
    """-f runs bpmid_step_feedforward: for a model without a pressure lag, the same numbers as -i."""
    _fit, _d, exe, _lib = plain
    text = "time_s,angle_deg\n" + "".join(f"{0.1 * k:.1f},{20 + 5 * np.sin(0.3 * k):.6f}\n" for k in range(50))
    out = {f: subprocess.run([str(exe), f], input=text, capture_output=True, text=True) for f in ("-i", "-f")}
    assert out["-i"].returncode == 0 and out["-f"].returncode == 0 and out["-i"].stdout == out["-f"].stdout
    res = subprocess.run([str(exe), "-x"], input=text, capture_output=True, text=True)
    assert res.returncode == 2 and "-f" in res.stderr


def test_a_refused_input_leaves_the_state_and_says_so(plain):
    """NaN, infinite, a time not after the previous one: status 3, the previous output, the state unchanged
    (the next good sample gives what it gives without the bad one); an angle beyond the model: status 1."""
    _fit, _d, _exe, lib = plain
    t = np.arange(0.0, 3.0, 0.1)
    p = 40000.0 + 20000.0 * np.sin(t)
    clean = lib.run_forward(t, p)
    for bad_t, bad_p in ((1.05, float("nan")), (1.05, float("inf")), (float("nan"), 5e4), (0.5, 5e4), (1.0, 5e4)):
        lib.reset()
        out = []
        for k, (a, b) in enumerate(zip(t, p)):
            out.append(lib.forward(float(a), float(b)))
            assert lib.status == 0
            if k == 10:
                assert lib.forward(bad_t, bad_p) == out[-1]
                assert lib.status == 3
        assert np.array_equal(np.array(out), clean)
    lib.reset()
    assert lib.forward(0.0, float("nan")) == 0.0 and lib.status == 3
    lib.reset()
    ang = lib.run_forward(t, p)
    lib.reset()
    for a, b in zip(t[:5], ang[:5]):
        lib.inverse(float(a), float(b))
    good = lib.inverse(float(t[5]), 10.0)
    assert lib.status == 0
    assert lib.inverse(float(t[6]), float("nan")) == good and lib.status == 3
    lib.inverse(float(t[6]), -10.0)
    assert lib.status == 1
    lib.inverse(float(t[7]), 1000.0)
    assert lib.status == 1
    lib.reset()                     # a gauge pressure below vacuum, which no valve gives: answered, flagged
    lib.forward(0.0, 0.0)
    lib.forward(0.1, -200000.0)
    assert lib.status == 1
    lib.forward(0.2, -50000.0)
    assert lib.status == 0


def test_the_sample_counter_of_a_long_running_controller_never_overflows(plain, tmp_path_factory):
    """The state's sample counter (a long: 32 bits on most controllers) stops at BPMID_K_MAX instead of overflowing
    after 2^31 samples (24.9 days at 1 kHz), and the steps after it are those of any later sample."""
    import ctypes

    ms = MaxwellSlipModel(4, 3, orientation="lag")
    params = ms.default_params().with_values({"loop_sign": -1.0, "s0": 3.0, "s1": 60.0, "s2": 8.0, "s3": -2.0})
    d = tmp_path_factory.mktemp("ms_counter")
    _dd, _exe, ms_lib = exported(tmp_path_factory, "ms_counter_c", _compare_file(d / "compare.yaml", ms, params),
                                 model="maxwell-slip")
    k_max = 2147483647
    t = np.arange(0.0, 2.0, 0.1)
    p = 40000.0 + 20000.0 * np.sin(t)
    for lib in (plain[3], ms_lib):
        k = ctypes.c_long.from_buffer(lib._buf)   # the state's first field
        clean = lib.run_forward(t, p)
        lib.reset()
        out = [lib.forward(float(t[0]), float(p[0])), lib.forward(float(t[1]), float(p[1]))]
        k.value = k_max - 1
        out += [lib.forward(float(a), float(b)) for a, b in zip(t[2:], p[2:])]
        assert k.value == k_max
        assert lib.status == 0
        assert np.array_equal(np.array(out), clean)


def test_cli_export_and_refusals(plain, tmp_path):
    fit = plain[0]
    out = tmp_path / "c"
    res = CliRunner().invoke(app, ["export", str(fit), "--to", "c", "--out", str(out)])
    assert res.exit_code == 0, res.output
    assert sorted(p.name for p in out.iterdir()) == ["bpmid_model.c", "bpmid_model.h", "main.c"]
    # an effect without a causal form: refused, naming it; nothing written
    bad = yaml.safe_load(fit.read_text())
    bad["effects"] = [{"id": "pressure_lag", "settings": {"dead_time": 0.1}, "parameters": {"tau": 0.2}}]
    (tmp_path / "bad.yaml").write_text(dump_yaml(bad))
    res = CliRunner().invoke(app, ["export", str(tmp_path / "bad.yaml"), "--to", "c", "--out", str(tmp_path / "o1")])
    assert res.exit_code == 2 and "effects[0].settings.dead_time" in res.output
    assert not (tmp_path / "o1").exists()
    bad["effects"] = [{"id": "no_such_effect", "parameters": {}}]
    (tmp_path / "bad.yaml").write_text(dump_yaml(bad))
    res = CliRunner().invoke(app, ["export", str(tmp_path / "bad.yaml"), "--to", "c", "--out", str(tmp_path / "o2")])
    assert res.exit_code == 2 and "effects[0].id" in res.output
    # wrong kind of file for the target, unknown target
    res = CliRunner().invoke(app, ["export", str(fit), "--to", "c", "--model", "maxwell-slip", "--out", str(tmp_path / "o3")])
    assert res.exit_code == 2 and "--model maxwell-slip takes a comparison or control result" in res.output
    assert "export this one with --to c alone (or --model vbmm)" in " ".join(res.output.split())
    res = CliRunner().invoke(app, ["export", str(fit), "--to", "fortran", "--out", str(tmp_path / "o4")])
    assert res.exit_code == 2 and "--to" in res.output
    # a file of another kind (with or without --model, to C or to an FEA tool): told what it is and what to do
    for schema, args, what in (
            ("bpmid.compare/1", [], "--to c --model vbmm-fit, vbmm-mat or maxwell-slip"),
            ("bpmid.compare/1", ["--model", "vbmm"], "--to c --model vbmm-fit, vbmm-mat or maxwell-slip"),
            ("bpmid.control/1", [], "--to c --model maxwell-slip"),
            ("bpmid.relax/1", [], "--to abaqus, ansys or comsol"),
            ("bpmid.relax/1", ["--model", "maxwell-slip"], "--to abaqus, ansys or comsol"),
            ("bpmid.discovery/1", [], "discover/model.yaml, with --to c"),
            ("bpmid.run/1", [], "relax_fit.yaml (--to abaqus, ansys or comsol), vbmm_fit.yaml (--to c)"),
            ("bpmid.vbmm/1", ["--to", "abaqus"], "a motion fit (bpmid fit motion, or discover's model.yaml); --to "
                                                 "abaqus takes a bpmid.relax/1 file: export it with --to c")):
        (tmp_path / "other.yaml").write_text(f"schema: {schema}\n")
        to = [] if "--to" in args else ["--to", "c"]
        res = CliRunner().invoke(app, ["export", str(tmp_path / "other.yaml"), *to, *args, "--out",
                                       str(tmp_path / "o5")])
        assert res.exit_code == 2 and what in " ".join(res.output.split()) and "schema" in res.output, res.output
    assert not any((tmp_path / f"o{i}").exists() for i in (2, 3, 4, 5))
    # the target's name in any case; a folder that held other files is said, and they are left as they were
    (tmp_path / "o6").mkdir()
    (tmp_path / "o6" / "notes.txt").write_text("mine\n")
    res = CliRunner().invoke(app, ["export", str(fit), "--to", "C", "--out", str(tmp_path / "o6")])
    assert res.exit_code == 0 and (tmp_path / "o6" / "bpmid_model.c").is_file(), res.output
    assert "already held 1 other file (notes.txt), left as they were" in res.output
    assert (tmp_path / "o6" / "notes.txt").read_text() == "mine\n"


def test_vbmm_model_of_a_comparison_equals_its_simulate(tmp_path_factory, logs):
    from bpmid.models.vbmm_family import VBMMMatModel

    fam = VBMMMatModel()
    params = fam.default_params()
    d = tmp_path_factory.mktemp("cmp_vbmm")
    fit = d / "compare.yaml"
    fit.write_text(dump_yaml({"schema": "bpmid.compare/1", "models": {"vbmm-mat": fam.describe(params)},
                              "provenance": {"bpmid_version": "test"}}), encoding="utf-8")
    _dd, _exe, lib = exported(tmp_path_factory, "cmp_vbmm_c", fit, model="vbmm-mat")
    for lg in logs[::11]:
        assert np.max(np.abs(lib.run_forward(lg.time_s, lg.pressure_pa) - fam.simulate(params, lg))) < 1e-9
    res = CliRunner().invoke(app, ["export", str(fit), "--to", "c", "--model", "vbmm-fit", "--out", str(d / "x")])
    assert res.exit_code == 2 and "models.vbmm-fit" in res.output


def test_a_fit_made_with_a_short_history_window_is_refused_by_export_and_flagged_by_predict(tmp_path, logs):
    """Constants fitted with a 1 s window (2.6 times the 0.39 s branch) belong to a model that forgets the past
    after 1 s; the C runs the exact history, so export refuses; predict says which history it ran."""
    short = write_fit(tmp_path / "win1.yaml", VBMM(FITTED, history="window", window_s=1.0))
    long = write_fit(tmp_path / "win20.yaml", VBMM(FITTED, history="window", window_s=20.0))
    res = CliRunner().invoke(app, ["export", str(short), "--to", "c", "--out", str(tmp_path / "c1")])
    assert res.exit_code == 2
    assert "model.history" in res.output and "1 s history window" in res.output and "refit" in res.output
    assert not (tmp_path / "c1").exists()
    res = CliRunner().invoke(app, ["export", str(long), "--to", "c", "--out", str(tmp_path / "c20")])
    assert res.exit_code == 0, res.output
    log = logs[0].path
    res = CliRunner().invoke(app, ["predict", str(log), "--params", str(short), "--out", str(tmp_path / "p1")])
    assert res.exit_code == 0, res.output
    body = yaml.safe_load((tmp_path / "p1" / "predict.yaml").read_text())
    assert any("1 s history window" in w for w in body["warnings"])
    res = CliRunner().invoke(app, ["predict", str(log), "--params", str(short), "--out", str(tmp_path / "p1s"),
                                   "--strict"])
    assert res.exit_code == 2 and not (tmp_path / "p1s").exists()
    res = CliRunner().invoke(app, ["predict", str(log), "--params", str(long), "--out", str(tmp_path / "p20")])
    body = yaml.safe_load((tmp_path / "p20" / "predict.yaml").read_text())
    assert not any("history window" in w for w in body["warnings"])


def test_header_says_what_a_real_time_and_threaded_caller_must_know(plain):
    """The header said 'no heap allocation, no global state' only: it now says that every step is bounded, that the
    code is reentrant with one state per muscle stepped from one thread at a time, and what a flagged step returns."""
    _fit, d, _exe, _lib = plain
    h = " ".join((d / "src" / "bpmid_model.h").read_text().replace("*", " ").split())
    assert "every step's work is bounded" in h and "flags status 2" in h
    assert "Threads: reentrant" in h and "one state from one thread at a time" in h
    assert "A step flagged 1 or 2 still returns the model's answer" in h
    c = (d / "src" / "bpmid_model.c").read_text()
    assert "while (" not in c.replace("while (j > 0", "")   # every loop has a fixed bound (the only while: a sort)
