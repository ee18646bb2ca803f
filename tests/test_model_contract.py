"""The contract every registered model family meets (in the spirit of scikit-learn's check_estimator):
parametrised over bpmid.models.REGISTRY, so a family added with one registry line is checked here at once."""
import math

import numpy as np
import pytest
import yaml

import bpmid
from bpmid.errors import InputError
from bpmid.fitting import FitResult
from bpmid.io.results import dump_yaml
from bpmid.models import REGISTRY, model_class
from bpmid.models.base import ModelFamily
from bpmid.params import ParamSet


@pytest.fixture(scope="module")
def logs():
    """Two short shipped logs (training and test), 25 s each."""
    paths = bpmid.data.files("datasets/motion/fitting_set/*.csv")[:1] + \
        bpmid.data.files("datasets/motion/variable_rate/*.csv")[:1]
    out = []
    for lg in bpmid.read_motion_logs(paths, require_angle=True):
        n = int(np.searchsorted(lg.time_s, lg.time_s[0] + 25.0))
        out.append(lg.slice(0, n))
    return out


def check_family(name, logs):
    """Everything a family registered as ``name`` must do (the check_estimator of bpmid)."""
    cls = model_class(name)
    assert issubclass(cls, ModelFamily) and cls.name == name and cls.label
    model = cls()                                                   # constructor: settings only, all defaulted
    params = model.default_params()
    assert isinstance(params, ParamSet) and len(params) >= 1
    for p in params:                                                # named, unit-tagged, inside its bounds
        assert p.name and isinstance(p.unit, str) and p.unit
        assert math.isfinite(p.value) and p.lower <= p.value <= p.upper, p
    train, test = logs
    y = model.simulate(params, test)                                # free-running, deg, one value per sample
    assert y.shape == (test.n,) and np.all(np.isfinite(y))
    np.testing.assert_array_equal(y, model.simulate(params, test))  # deterministic
    assert isinstance(model.n_params(params), int) and 0 <= model.n_params(params) <= len(params)
    desc = yaml.safe_load(dump_yaml(model.describe(params)))        # plain YAML
    assert desc["model"] == name
    for pname, entry in desc["parameters"].items():
        assert {"value", "stderr", "unit"} <= set(entry), pname

    fit = model.fit([train])                                        # one shared driver, one result shape
    assert isinstance(fit, FitResult) and fit.params.names() == params.names()
    assert np.all(np.isfinite(fit.residual)) and fit.n_obs == train.n
    start = model.initial_guess([train], params)
    rmse_start = float(np.sqrt(np.mean((model.simulate(start, train) - train.angle_deg) ** 2)))
    assert fit.rmse <= rmse_start * (1 + 1e-9) + 1e-9               # never worse than where it started
    assert fit.rmse < 10.0                                          # deg: it learned the log
    for p in fit.params:                                            # no unflagged non-identifiable estimate
        if p.identifiable:
            assert p.stderr is not None and p.stderr >= 0, p
    y_test = model.simulate(fit.params, test)
    assert np.all(np.isfinite(y_test))


@pytest.mark.parametrize("name", list(REGISTRY))
def test_family_contract(name, logs):
    check_family(name, logs)


class QuadraticStatic(ModelFamily):
    """Test-only family: angle = a + b p + c p^2 (p in bar gauge), one file and one registry line away."""

    name = "quadratic-static"
    label = "quadratic static"

    def default_params(self) -> ParamSet:
        from bpmid.params import Param

        return ParamSet([Param("a", 0.0, "deg"), Param("b", 40.0, "deg/bar"), Param("c", 0.0, "deg/bar^2")])

    def simulate(self, params, log):
        p = log.pressure_pa / 1e5
        v = params.values()
        return v["a"] + v["b"] * p + v["c"] * p ** 2


def test_a_new_family_is_one_registry_line(logs, monkeypatch):
    monkeypatch.setitem(REGISTRY, "quadratic-static", f"{__name__}:QuadraticStatic")
    check_family("quadratic-static", logs)


@pytest.mark.parametrize("name", list(REGISTRY))
def test_family_refuses_unfit_logs(name, logs):
    model = model_class(name)()
    no_angle = logs[0].with_angle(np.zeros(logs[0].n))
    no_angle.angle_deg = None
    with pytest.raises(InputError, match="angle"):
        model.fit([no_angle])
    with pytest.raises(InputError, match="too few|samples"):
        model.fit([logs[0].slice(0, 5)])
