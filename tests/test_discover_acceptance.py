"""Acceptance of bpmid discover on data with a hidden effect (DISCOVER.md): each catalogue id named first, none on
null data, the held-out gap at least halved. The effects are hidden in the twin's variants where the catalogue has
one (friction from 4 slip elements where the model uses one play operator; lag plus dead time where the model has
a lag), on seeds the thresholds were not calibrated on, with the committed (calibrated) thresholds."""
from __future__ import annotations

import pytest

from bpmid.discover.calibrate import paper_sized_set, start_model
from bpmid.discover.workflow import DiscoverConfig, discover
from bpmid.effects import CATALOGUE, get_effect

TWIN = {"braid_friction": {"elements": 4}, "pressure_lag": {"dead_time": 0.1}}
SEEDS = (21, 22)


#: every catalogue id once, the seeds alternating over them (two seeds per id cost 27 s of the 100 s test budget;
#: discovery on many seeds and forms is the out-of-family benchmark's job, docs/validation.md)
CASES = [(eid, SEEDS[k % len(SEEDS)]) for k, eid in enumerate(CATALOGUE)]


@pytest.mark.slow
@pytest.mark.parametrize("effect_id, seed", CASES)
def test_hidden_effect_is_named_first_and_the_gap_halves(effect_id, seed):
    fit, ho = paper_sized_set(get_effect(effect_id, **TWIN.get(effect_id, {})), seed=seed, noise_deg=0.15)
    # one round: what is asserted is the first name and the gap it closes (a second round cost 30 % of the test)
    res = discover(fit, start_model(), holdout=ho, cfg=DiscoverConfig(max_effects=1))
    floor = res.noise_floor_deg
    assert res.heldout_before >= 1.8 * floor          # moderate size: at least about twice the floor
    assert res.named_effects and res.named_effects[0] == effect_id, res.verdict
    assert res.heldout_after - floor <= 0.5 * (res.heldout_before - floor)
    # the gap is scored as the round was, before and after alike: its numbers are the named candidate's own
    won = next(c for c in res.rounds[0].confirmations if c.effect_id == effect_id)
    assert res.heldout_before == pytest.approx(won.heldout_rmse_before, rel=1e-12)
    assert res.heldout_after == pytest.approx(won.heldout_rmse_after, rel=1e-9)
    assert effect_id in res.verdict and "held-out error from" in res.verdict


@pytest.mark.slow
@pytest.mark.parametrize("seed", SEEDS[:1])   # each seed costs 3-4 s of the 100 s budget; nulls by the hundred: the
def test_null_data_gets_no_effect(seed):      # out-of-family draws (1 named on 481 held-out nulls, docs/validation.md)
    fit, ho = paper_sized_set(None, seed=seed, noise_deg=0.15)
    res = discover(fit, start_model(), holdout=ho)
    assert res.named_effects == [], res.verdict
    assert "no missing effect found" in res.verdict
    assert not res.unexplained
