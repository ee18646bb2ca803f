"""Adding an effect to the catalogue is one class plus one registry line: the twin, the controller's plant
and discovery take it with no other edit (spec DISCOVER.md)."""
from __future__ import annotations

import io

import numpy as np
import pandas as pd
import pytest

from bpmid import effects as effects_pkg
from bpmid.effects.base import Effect
from bpmid.params import Param, ParamSet


class SensorGain(Effect):
    """A test-only effect: the angle sensor reads with a gain error (1 = exact)."""

    id = "sensor_gain"
    signal_order = 95
    meaning = "the angle sensor's gain is off"
    where_it_shows = "residual proportional to the angle"

    def default_params(self) -> ParamSet:
        return ParamSet([Param(f"{self.id}.gain", 1.05, "1", 0.5, 1.5)])

    def null_values(self):
        return {f"{self.id}.gain": 1.0}

    def transform_angle(self, t, beta_deg, params):
        return beta_deg * params.value(f"{self.id}.gain")

    def signature_columns(self, log, base_angle_deg):
        return base_angle_deg[:, None]


@pytest.fixture
def registered(monkeypatch):
    monkeypatch.setitem(effects_pkg.CATALOGUE, "sensor_gain", f"{__name__}:SensorGain")
    return "sensor_gain"


def _angles(sim) -> np.ndarray:
    name = sorted(n for n in sim.files if n.endswith(".csv"))[0]
    text = sim.files[name].decode()
    return pd.read_csv(io.StringIO(text), comment="#")["angle_deg"].to_numpy()


def test_new_effect_runs_in_the_twin_with_no_other_edit(registered, repo_root):
    from bpmid.twin.simulate import simulate

    proto = f"{repo_root}/configs/datasets/fitting_set.yaml"
    plain = simulate(proto, seed=3, timestamp=False)
    gained = simulate(proto, effects=["sensor_gain:gain=1.1"], seed=3, timestamp=False)
    a, b = _angles(plain), _angles(gained)
    big = np.abs(a) > 5
    # same seed, same noise: the injected gain shows as a 10 % larger angle (up to the sensor's quantisation)
    assert np.median(b[big] / a[big]) == pytest.approx(1.1, abs=0.01)
    assert "sensor_gain" in str(gained.manifest) and "sensor_gain" not in str(plain.manifest)


def test_new_effect_is_a_discovery_candidate_with_no_other_edit(registered):
    from bpmid.discover.calibrate import paper_sized_set, start_model
    from bpmid.discover.workflow import DiscoverConfig, discover

    fit, ho = paper_sized_set(SensorGain(), size=1.0, seed=1, noise_deg=0.15)
    res = discover(fit, start_model(), holdout=ho, cfg=DiscoverConfig(candidates=("sensor_gain", "angle_offset")))
    screened = {s.effect_id for s in res.rounds[0].ranking}
    assert screened == {"sensor_gain", "angle_offset"}

