"""A newly registered effect runs in the closed loop with no edit to bpmid.control (it names no effect): the
effect declares its causal per-step form beside its whole-signal form. test_catalogue_extension.py shows the
same kind of entry in the twin and in discovery."""
from __future__ import annotations

import numpy as np
import pytest

from bpmid import effects as effects_pkg
from bpmid.control import ControlConfig, build_plant, builtin_reference, run_control
from bpmid.effects.base import Effect
from bpmid.errors import InputError
from bpmid.models.vbmm import VBMM, Material
from bpmid.params import Param, ParamSet
from bpmid.twin.sensors import Sensors

MODEL = VBMM(Material.paper_fit())


class SensorGainCausal(Effect):
    """Test-only: the angle sensor reads with a gain error, with its per-sample form declared."""

    id = "sensor_gain_causal"
    signal_order = 95
    meaning = "the angle sensor's gain is off"

    def default_params(self) -> ParamSet:
        return ParamSet([Param(f"{self.id}.gain", 1.1, "1", 0.5, 1.5)])

    def transform_angle(self, t, beta_deg, params):
        return beta_deg * params.value(f"{self.id}.gain")

    def causal_angle(self, params):
        return (params.value(f"{self.id}.gain"), 0.0)


class ValveLagCausal(Effect):
    """Test-only: a slow valve, a first-order lag on the pressure, with its per-sample form declared."""

    id = "valve_lag_causal"
    signal_order = 10
    meaning = "a slow valve"

    def default_params(self) -> ParamSet:
        return ParamSet([Param(f"{self.id}.tau", 1.5, "s", 0.0, 10.0)])

    def causal_pressure(self, params):
        return (("lag", (params.value(f"{self.id}.tau"),)),)

    def transform_pressure(self, t, p, params):
        from bpmid.effects import _kernels

        return _kernels.lag(t, p, params.value(f"{self.id}.tau"))


class NoCausalForm(Effect):
    id = "no_causal_form"
    meaning = "a sensor nonlinearity without a per-sample form"

    def default_params(self) -> ParamSet:
        return ParamSet([Param(f"{self.id}.c", 0.01, "1/deg", 0.0, 1.0)])

    def transform_angle(self, t, beta_deg, params):
        return beta_deg + params.value(f"{self.id}.c") * beta_deg ** 2


@pytest.fixture
def registered(monkeypatch):
    for cls in (SensorGainCausal, ValveLagCausal, NoCausalForm):
        monkeypatch.setitem(effects_pkg.CATALOGUE, cls.id, f"{__name__}:{cls.__name__}")


def _run(effects):
    cfg = ControlConfig(sensors=Sensors())
    plant = build_plant(MODEL, effects, cfg)
    return run_control(MODEL, plant, [builtin_reference("steps")], cfg, controllers=["pi"], measure_cost=False).runs[0]


def test_a_new_sensor_effect_is_stepped_in_the_loop(registered):
    plain, gained = _run([]), _run(["sensor_gain_causal:gain=1.1"])
    hold = slice(len(plain.time_s) - 60, len(plain.time_s) - 5)  # the end of the last step: settled
    # the loop drives the *measured* angle to the reference, so the true angle ends 1.1 times lower
    np.testing.assert_allclose(gained.angle_deg[hold], plain.angle_deg[hold], atol=0.3)
    np.testing.assert_allclose(gained.true_angle_deg[hold], plain.true_angle_deg[hold] / 1.1, rtol=0.02)


def test_a_new_pressure_effect_is_stepped_in_the_loop(registered):
    plain, lagged = _run([]), _run(["valve_lag_causal:tau=1.5"])
    e_plain = np.sqrt(np.mean((plain.angle_deg - plain.reference_deg) ** 2))
    e_lag = np.sqrt(np.mean((lagged.angle_deg - lagged.reference_deg) ** 2))
    assert e_lag > 1.05 * e_plain  # a slower plant tracks worse under the same gains
    assert not np.allclose(lagged.muscle_bar_abs, plain.muscle_bar_abs) or not np.allclose(
        lagged.true_angle_deg, plain.true_angle_deg)


def test_an_effect_without_a_causal_form_is_refused(registered):
    with pytest.raises(InputError, match="no_causal_form"):
        _run(["no_causal_form"])
