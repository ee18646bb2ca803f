"""The one home of the identifiability rules (bpmid.identifiability), as every fit applies them."""
import numpy as np

from bpmid import identifiability as I
from bpmid.fitting import fit_least_squares
from bpmid.params import Param, ParamSet


def test_rules_one_to_four_in_order():
    names = ["a", "b", "c", "d"]
    values = [1.0, 2.0, 3.0, 4.0]
    se = np.array([np.inf, 1.5, 0.1, 0.1])
    corr = np.eye(4)
    x = np.array(values)
    lo = np.array([-np.inf, -np.inf, 3.0, -np.inf])
    hi = np.full(4, np.inf)
    bad = I.judge_fit(names, values, se, corr, x, lo, hi, rel_se_max=0.5, corr_max=0.995)
    assert bad == {"a": I.SINGULAR, "b": "relative standard error 75% > 50%", "c": I.ON_BOUND}
    # a huge relative error is capped in the nonlinear fit's message, printed in full on request
    assert I.judge(50.0, 50.0, rel_se_max=0.5) == "relative standard error >1000% > 50%"
    assert I.judge(50.0, 50.0, rel_se_max=0.5, cap=None) == "relative standard error 5000% > 50%"
    # rule 4 only once 1-3 pass: of the strongest pair, the one with the larger relative error goes
    corr = np.array([[1.0, 0.999, 0.1], [0.999, 1.0, 0.2], [0.1, 0.2, 1.0]])
    se = np.array([0.1, 0.4, 0.1])
    bad = I.judge_fit(["p", "q", "r"], [1.0, 1.0, 1.0], se, corr, np.ones(3), np.full(3, -np.inf),
                      np.full(3, np.inf), rel_se_max=0.5, corr_max=0.995)
    assert bad == {"q": "correlated with p (r = +0.999)"}
    assert I.worst({"p": "correlated with q", "r": I.ON_BOUND}, ["p", "q", "r"], [1, 1, 1], se) == "r"


def test_fit_holds_a_parameter_the_data_do_not_determine():
    t = np.linspace(0.0, 1.0, 50)
    y = 2.0 * t + 0.5
    # y = a t + b + c: b and c enter only as their sum, so one of them is held at its prior
    ps = ParamSet([Param("a", 1.0), Param("b", 0.2), Param("c", 0.1)])
    res = fit_least_squares(lambda p: p.value("a") * t + p.value("b") + p.value("c") - y, ps)
    assert len(res.held) == 1
    (held, why), = res.held.items()
    assert held in ("b", "c") and ("correlated" in why or "singular" in why or "relative" in why)
    assert res.params[held].identifiable is False and res.params[held].value == ps[held].value
    assert abs(res.params.value("a") - 2.0) < 1e-8


def test_an_estimate_beside_a_held_correlated_parameter_says_its_error_is_conditional():
    """y = a t + (b + 0.05 c) with c held: b's standard error assumes c's prior value; the fit says so on b (and
    only on b), leaving the value and standard error as they are."""
    rng = np.random.default_rng(7)
    t = np.linspace(0.0, 1.0, 200)
    y = 2.0 * t + 0.5 + 0.01 * rng.standard_normal(t.size)
    ps = ParamSet([Param("a", 1.0), Param("b", 0.2), Param("c", 0.1)])
    res = fit_least_squares(lambda p: p.value("a") * t + p.value("b") + 0.05 * p.value("c") - y, ps)
    (held,) = res.held
    other = "b" if held == "c" else "c"
    assert "conditional on the held " + held in res.params[other].note
    assert res.params[other].stderr is not None and res.params[other].identifiable
    assert "conditional" not in res.params["a"].note
    assert other in res.conditional[held] and abs(res.conditional[held][other]) >= 0.9


def _quadratic_with_a_poor_start():
    """y = a x + q x^2 with q small beside its error (not identifiable), started far off as an equation-error
    start on other data could put it (seeded noise)."""
    rng = np.random.default_rng(5)
    x = np.linspace(0.0, 1.0, 400)
    y = 3.0 * x + 0.002 * x**2 + rng.normal(0.0, 0.05, x.size)
    start = ParamSet([Param("a", 1.0), Param("q", -0.4, lower=-0.45, upper=0.45)])
    return (lambda p: p.value("a") * x + p.value("q") * x**2 - y), start


def test_a_hold_at_a_start_the_data_reject_is_made_where_the_free_fit_left_it():
    """A baseline's start is an equation-error fit of the same data, not knowledge: holding a parameter there
    took a two-branch rational fit from 0.5 to 7 deg. With ``prior_from_data`` the data's rejection of the hold
    (likelihood ratio above chi2(1) at p = 0.001) holds it where the free fit left it, and the note says so; a
    prior that is knowledge (the VBMM's) is held as before."""
    fn, start = _quadratic_with_a_poor_start()
    free = fit_least_squares(fn, start, check_identifiability=False)
    rms_free = float(np.sqrt(np.mean(free.residual**2)))
    at_prior = fit_least_squares(fn, start)
    assert "q" in at_prior.held and at_prior.params.value("q") == -0.4
    assert np.sqrt(np.mean(at_prior.residual**2)) > 1.3 * rms_free        # the hold at the start costs the fit
    res = fit_least_squares(fn, start, prior_from_data=True)
    assert "q" in res.held and res.params["q"].identifiable is False
    assert res.params.value("q") == free.params.value("q")                 # held where the free fit left it
    assert np.sqrt(np.mean(res.residual**2)) < 1.001 * rms_free
    note = res.params["q"].note
    assert "held where the fit with it free left it" in note and "held at prior value" not in note
    assert "which the data reject" in note
    # a hold the data accept stays at the start
    ok = fit_least_squares(fn, start.replace("q", value=0.01), prior_from_data=True)
    assert ok.params.value("q") == 0.01 and "held at prior value" in ok.params["q"].note
