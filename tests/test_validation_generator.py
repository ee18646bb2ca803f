"""The out-of-family generator (bpmid.validation): independent base muscle, physical forms, files, splits."""
import dataclasses
import math
from pathlib import Path

import numpy as np
import pytest

from bpmid.validation import (FORMS, GEOMETRIES, case_paths, make_cases, realize, simulate_spec, split_of,
                              write_answers, write_case)
from bpmid.validation import physics
from bpmid.validation.forms import empty_spec, merge

SMALL = {"n_cases": 8, "duration_scale": 0.08, "sampling_hz": [10.0], "max_step_s": 0.01}

# VBMM.md section 8, forward trace (t s, beta deg)
TRACE = [(0, 14.4704), (2, 36.3049), (4, 63.0009), (5, 59.9460), (8, 22.2985), (12, 63.0352), (16, 69.5207)]


def test_independent_base_muscle_reproduces_the_golden_trace():
    """Integrated at the log rate (VBMM.md's discretisation) the generator's own muscle gives the golden angles."""
    geo = GEOMETRIES["paper"].si()
    t = np.arange(161) * 0.1
    p_abs = np.where(t <= 4, 1.2 + 0.2 * t, np.where(t <= 8, 2.0 - 0.2 * (t - 4),
                                                      np.where(t <= 12, 1.2 + 0.2 * (t - 8), 2.0)))
    beta, _ = physics.simulate_fine(t, p_abs * 1e5 - 101325.0, np.ones_like(t), geo, 9050.0, 6.434e6,
                                    np.array([18300.0]), np.array([13.645e6]), np.array([0.213]), 1.0, 0,
                                    np.zeros(1), 0, 0, 0.0, 1.0, 0.0, 1.0, 0.0, 0.0, 0.0)
    for ts, ref in TRACE:
        assert math.degrees(beta[int(round(ts * 10))]) == pytest.approx(ref, abs=1e-3)
    p = physics.equilibrium_pressure(np.radians([30.0, 90.0]), geo, 9050.0, 6.434e6)
    assert p == pytest.approx([39784.019, 132122.161], abs=1e-2)


def _case(**over):
    cfg = dict(SMALL, n_cases=1, mix={"null": 1.0}, geometries=["paper"], variation=[0.0, 0.0])
    cfg.update(over)
    return make_cases(cfg, seed=3)[0]


def _spec(effect, form, s, **shape):
    f = next(x for x in FORMS[effect] if x.name == form)
    sh = f.draw(np.random.default_rng(0))
    sh.update(shape)
    return merge([f.spec(s, sh)])


def _mid_loop_width(t, p, ang):
    """Angle on the way up minus on the way down at mid pressure (deg), averaged over cycles."""
    mid = 0.5 * (p.min() + p.max())
    dp = np.gradient(p)
    up = np.abs(p - mid) < 0.02 * (p.max() - p.min())
    return float(np.mean(ang[up & (dp < 0)]) - np.mean(ang[up & (dp > 0)]))


def test_generator_is_deterministic_and_labelled(tmp_path):
    a = make_cases(SMALL, seed=5)
    b = make_cases(SMALL, seed=5)
    assert [c.id for c in a] == [c.id for c in b] and [c.truth for c in a] == [c.truth for c in b]
    assert [c.seed for c in make_cases(SMALL, seed=6)] != [c.seed for c in a]
    d1, d2 = realize(a[0]), realize(b[0])
    for x, y in zip(d1.logs, d2.logs):
        np.testing.assert_array_equal(x.angle_deg, y.angle_deg)
    write_case(d1, tmp_path)
    text = (tmp_path / a[0].id / "fit" / "fit_cyclic.csv").read_text()
    assert "# synthetic: true" in text and "# generator: bpmid.validation/1" in text
    assert f"# seed: {a[0].seed}" in text and f"# case: {a[0].id}" in text
    assert "# generator_config: sha256:" in text
    assert "synthetic" in (tmp_path / a[0].id / "case.yaml").read_text()


def test_friction_loop_does_not_shrink_at_slow_rates():
    case = _case()
    protos = [("slow", "fit", [(1.0, 0.05), (0.0, 0.05)] * 2), ("fast", "fit", [(1.0, 0.4), (0.0, 0.4)] * 2)]
    base = simulate_spec(case, None, protos)
    for form in ("dahl", "bouc_wen", "jenkins4", "jenkins2"):
        fr = simulate_spec(case, _spec("braid_friction", form, 3.0), protos)
        extra = [_mid_loop_width(*f) - _mid_loop_width(*b) for f, b in zip(fr, base)]
        assert extra[0] > 0.3, form
        assert extra[0] >= 0.8 * extra[1], form  # rate-independent: the slow loop is as wide as the fast one
    # the viscoelastic loop of the base muscle itself does shrink at slow rates
    assert _mid_loop_width(*base[0]) < 0.6 * _mid_loop_width(*base[1])


def test_bouc_wen_step_is_exact_and_bounded_for_any_increment():
    """The Bouc-Wen state over one strain increment equals a fine explicit integration, and stays within its
    saturation A / (b + g) for increments of any size: the step solver tries beta = 0 every step, an increment of
    the whole bend, where the explicit update it replaced went unstable."""
    A, z_max = 1.0, 0.003
    rng = np.random.default_rng(5)
    for share in (0.3, 0.5, 0.7):
        b, g = share / z_max, (1.0 - share) / z_max

        def fine(z, de, n=20000):
            d = de / n
            for _ in range(n):
                z += (A - (b * (1.0 if z * d > 0 else -1.0) + g) * abs(z)) * d
            return z

        for z0, de in [(0.0, 0.004), (0.002, -0.006), (-0.0029, 0.0005), (0.001, 0.0001), (-0.002, -0.001)]:
            assert physics.bouc_wen_step(z0, de, A, b, g) == pytest.approx(fine(z0, de), abs=2e-7)
        for _ in range(200):
            z0, de = rng.uniform(-z_max, z_max), rng.choice([-1.0, 1.0]) * 10 ** rng.uniform(-6, 0)
            z1 = physics.bouc_wen_step(z0, de, A, b, g)
            assert abs(z1) <= z_max * (1 + 1e-12) and math.isfinite(z1)
        assert physics.bouc_wen_step(0.9 * z_max, -0.5, A, b, g) == pytest.approx(-z_max, rel=1e-12)


def test_bouc_wen_case_that_collapsed_keeps_its_bend(repo_root):
    """Draw 14's case 0083 (Bouc-Wen friction, slim muscle, 50 Hz), its hold log with the sized friction of its
    answers: with the explicit update the angle fell from 56 deg to 0 at the start of unloading and stayed there,
    so the case's fitting logs were no muscle at all. Now the angle moves smoothly and comes back near its start."""
    from bpmid.validation.generator import _protocols
    from bpmid.validation.sweep import load_sweep

    cfg = load_sweep(Path(repo_root) / "configs" / "sweeps" / "draw14.yaml")
    case = next(c for c in make_cases(cfg.effective_generator, cfg.sweep.seed, prefix="draw14")
                if c.id == "draw14-0083")
    assert case.effects[0].form == "bouc_wen"
    spec = merge([{"friction": {"kind": "bouc_wen", "par": [123950256.75913928, 1.0, 683.5407132569237,
                                                             303.74951475961564]}}])
    hold = [p for p in _protocols(case.config.duration_scale) if p[0] == "fit_hold"]
    (t, p, a), = simulate_spec(case, spec, hold)
    assert np.max(np.abs(np.diff(a))) < 5.0                     # deg per sample at 50 Hz: no jump
    assert a.max() > 50.0 and a[-200:].min() > 0.5 * a[0], (a.max(), a[-200:].min(), a[0])


def _crossing_time(t, ang, level):
    return float(t[np.argmax(ang > level)])


def test_pressure_lag_forms_shift_the_response_later():
    case = _case(sampling_hz=[100.0], max_step_s=0.002)
    protos = [("ramp", "fit", [(1.0, 0.5), (1.0, -3.0)])]
    (t, p, a0), = simulate_spec(case, None, protos)
    level = 0.5 * (a0.min() + a0.max())
    for form in ("cascade", "delay_lag"):
        (_, _, a1), = simulate_spec(case, _spec("pressure_lag", form, 1.0), protos)
        shift = _crossing_time(t, a1, level) - _crossing_time(t, a0, level)
        assert 0.03 < shift < 0.5, form
        assert a1[-1] == pytest.approx(a0[-1], abs=0.05)  # same end point after the hold


def test_offset_is_constant_and_other_forms_act_where_expected():
    case = _case()
    protos = [("tri", "fit", [(1.0, 0.2), (1.0, -20.0), (0.0, 0.2), (0.6, 0.2), (0.0, 0.2)])]
    (t, p, a0), = simulate_spec(case, None, protos)
    (_, _, ao), = simulate_spec(case, _spec("angle_offset", "constant", 1.5, sign=-1.0), protos)
    np.testing.assert_allclose(ao - a0, -1.5, atol=1e-12)
    hold = (t > 5.5) & (t < 25.0)
    # second relaxation: creep continues long after the first time constant
    for form in ("one_slow", "two_slow"):
        (_, _, a), = simulate_spec(case, _spec("second_relaxation", form, 1.0), protos)
        creep, creep0 = np.ptp(a[hold]), np.ptp(a0[hold])
        assert creep > creep0 + 0.5, form
    # stiffening: the difference grows with the angle, and the muscle bends less at the top
    for form in ("exponential", "polynomial"):
        (_, _, a), = simulate_spec(case, _spec("strain_stiffening", form, 1.0), protos)
        d = a - a0
        top, low = a0 > np.percentile(a0, 90), a0 < np.percentile(a0, 20)
        assert d[top].mean() < -0.3 and abs(d[low].mean()) < 0.3 * abs(d[top].mean()), form
    # thermal: the muscle softens (bends more) as time goes on
    for form in ("exponential", "linear"):
        (_, _, a), = simulate_spec(case, _spec("thermal_softening", form, 3.0, T=20.0), protos)
        d = a - a0
        assert d[-20:].mean() > d[:20].mean() + 0.2, form
    # asymmetric relaxation acts on falling strain only: the first rise is untouched
    rise = t < 5.0
    for form in ("slow_deflation", "fast_deflation"):
        (_, _, a), = simulate_spec(case, _spec("asymmetric_relaxation", form, 1.0), protos)
        np.testing.assert_allclose(a[rise], a0[rise], atol=1e-9)
        assert np.max(np.abs(a - a0)[t > 25.5]) > 0.3, form


def test_out_of_catalogue_forms():
    case = _case(sampling_hz=[50.0], max_step_s=0.002)
    protos = [("step", "fit", [(0.8, 1.0), (0.8, -4.0)])]
    (t, p, a0), = simulate_spec(case, None, protos)
    (_, _, a), = simulate_spec(case, _spec("payload_inertia", "ringing", 4.0, zeta=0.03), protos)
    d = (a - a0)[t > 0.8]
    assert np.count_nonzero(np.diff(np.sign(d - d.mean()))) >= 6  # it rings after the ramp stops
    (_, _, al), = simulate_spec(case, _spec("air_leak", "orifice", 1.0), protos)
    assert (al - a0)[-10:].mean() < -0.3  # less pressure inside: less bending at the hold
    cyc = [("cyc", "fit", [(0.9, 0.2), (0.0, 0.2), (0.6, 0.2), (0.0, 0.2)])]
    (t, p, b0), = simulate_spec(case, None, cyc)
    (_, _, bm), = simulate_spec(case, _spec("mullins", "ogden_roxburgh", 3.0), cyc)
    first = t < 4.5
    np.testing.assert_allclose(bm[first & (t < 4.4)], b0[first & (t < 4.4)], atol=1e-9)  # virgin loading
    assert (bm - b0)[(t > 10.0) & (t < 12.0)].mean() > 0.3  # reloading below the max: softer, bends more


def test_logs_read_back_through_bpmid_readers(tmp_path):
    from bpmid.config import load_config
    from bpmid.io.motion_logs import is_synthetic, read_motion_logs
    from bpmid.models.vbmm import load_vbmm

    combos = [("bar", "absolute", "s", "bpmid"), ("kpa", "gauge", "ms", "instrument"),
              ("psi", "absolute", "ms", "bpmid"), ("psi", "gauge", "s", "instrument")]
    for unit, ref, tu, style in combos:
        case = _case(pressure_units=[unit], pressure_references=[ref], time_units=[tu], header_styles=[style],
                     atmosphere_pa=[98000.0, 98000.0], geometries=["slim"], sampling_hz=[20.0],
                     mix={"single": 1.0}, effects=["strain_stiffening"])
        data = realize(case)
        write_case(data, tmp_path / unit / ref)
        paths = case_paths(tmp_path / unit / ref / case.id)
        cfg = load_config(paths["config"])
        logs = read_motion_logs(paths["fit"] + paths["holdout"], cfg.section("io"), require_angle=True)
        assert is_synthetic(logs)
        by_name = {lg.name: lg for lg in data.logs}
        for lg in logs:
            ref_log = by_name[lg.name]
            np.testing.assert_allclose(lg.time_s, ref_log.time_s, atol=2e-6)
            np.testing.assert_allclose(lg.pressure_pa, ref_log.pressure_pa, atol=1.0)  # Pa, after rounding
            np.testing.assert_allclose(lg.angle_deg, ref_log.angle_deg, atol=1e-5)
            assert lg.pressure_reference == ref and lg.pressure_unit == unit
        model = load_vbmm(paths["init"], cfg.section("model"))
        assert model.geometry.R0 == pytest.approx(GEOMETRIES["slim"].R0_mm * 1e-3)
        assert cfg.section("model").geometry.n == pytest.approx(GEOMETRIES["slim"].n)
    # the truth is not in the case folder
    files = [p for p in tmp_path.rglob("*") if p.is_file()]
    assert len(files) == 4 * (11 + 2) and not any("stiffening" in p.read_text() for p in files)


def test_split_is_disjoint_stable_and_answers_are_separate(tmp_path):
    cases = make_cases(dict(SMALL, n_cases=200), seed=1)
    ids = [c.id for c in cases]
    assert len(set(ids)) == 200
    cal = {c.id for c in cases if c.split == "calibration"}
    ho = {c.id for c in cases if c.split == "heldout"}
    assert cal.isdisjoint(ho) and cal | ho == set(ids) and 70 < len(ho) < 130
    # the split depends on the id alone: another config or seed does not move a case between halves
    other = make_cases(dict(SMALL, n_cases=50, noise_deg=[0.5, 0.6]), seed=9)
    assert all(c.split == split_of(c.id) for c in other)
    assert split_of("oof-0001") == split_of("oof-0001") and {split_of(f"x{i}") for i in range(10)} == {
        "calibration", "heldout"}
    kinds = {c.kind for c in cases}
    assert kinds == {"single", "null", "pair", "out_of_catalogue"}
    singles = {(e.effect, e.form) for c in cases if c.kind == "single" for e in c.effects}
    assert {e for e, _ in singles} == set(dataclasses.asdict(cases[0].config)["effects"])
    assert len(singles) >= 2 * 7  # at least two forms per catalogue id
    data = realize(cases[0])
    path = write_answers([write_case(data, tmp_path / "cases")], tmp_path / "answers" / f"{cases[0].split}.yaml")
    assert cases[0].id in path.read_text() and not (tmp_path / "cases" / cases[0].id / "answers.yaml").exists()


def test_effects_are_sized_to_the_target_ratio():
    cfg = dict(SMALL, n_cases=3, mix={"single": 1.0}, effects=["braid_friction", "pressure_lag", "angle_offset"],
               size_ratio=[2.0, 2.0], noise_deg=[0.2, 0.2])
    for case in make_cases(cfg, seed=2):
        data = realize(case)
        assert data.truth["heldout_size_ratio"] == pytest.approx(2.0, rel=0.1), case.truth
    assert empty_spec()["pressure"]["kind"] == "none"


def test_pressure_transducer_noise_is_in_the_log_only_and_off_by_default():
    """``pressure_noise_pa``: white noise on the logged pressure, not on what the muscle saw; absent by default, so
    the draws made before it (their configs, fingerprints and cases) are unchanged."""
    from bpmid.validation.generator import config_digest, generator_config
    plain = make_cases(SMALL, seed=5)
    zero = make_cases({**SMALL, "pressure_noise_pa": [0.0, 0.0]}, seed=5)
    assert "pressure_noise_pa" not in generator_config(SMALL).to_yaml()
    assert config_digest(plain[0].config) == config_digest(zero[0].config)
    assert [(c.id, c.seed, c.noise_deg, c.pressure_noise_pa) for c in plain] == \
           [(c.id, c.seed, c.noise_deg, c.pressure_noise_pa) for c in zero]
    noisy = make_cases({**SMALL, "pressure_noise_pa": [80.0, 80.0]}, seed=5)
    assert noisy[0].pressure_noise_pa == 80.0 and noisy[0].seed == plain[0].seed
    a, b = realize(plain[0]), realize(noisy[0])
    assert b.truth["pressure_noise_pa"] == 80.0 and "pressure_noise_pa" not in a.truth
    d = np.concatenate([y.pressure_pa - x.pressure_pa for x, y in zip(a.logs, b.logs)])
    assert np.std(d) == pytest.approx(80.0, rel=0.1) and abs(np.mean(d)) < 10.0
    for x, y in zip(a.logs, b.logs):      # the muscle saw the same pressure: the same angles, noise and all
        np.testing.assert_array_equal(x.angle_deg, y.angle_deg)
    from bpmid.errors import InputError
    with pytest.raises(InputError) as e:
        make_cases({**SMALL, "pressure_noise_pa": [-1.0, 5.0]}, seed=0)
    assert "generator.pressure_noise_pa" in e.value.format()


def test_bad_generator_config_names_the_key():
    from bpmid.errors import InputError
    with pytest.raises(InputError) as e:
        make_cases({"n_cases": 4, "noise_colour": "pink"}, seed=0)
    assert "generator.noise_colour" in e.value.format()
    with pytest.raises(InputError) as e:
        make_cases({"effects": ["braid_friction", "magic"]}, seed=0)
    assert "generator.effects" in e.value.format()


def test_module_command_writes_cases_and_answers_apart(tmp_path, repo_root):
    from bpmid.validation.__main__ import main

    assert main([f"{repo_root}/configs/sweeps/tiny.yaml", "--out", str(tmp_path), "--limit", "2"]) == 0
    cases = sorted(p.name for p in (tmp_path / "cases").iterdir())
    assert len(cases) == 2
    answers = {p.stem for p in (tmp_path / "answers").iterdir()}
    assert answers and answers <= {"calibration", "heldout"}
    assert not list((tmp_path / "cases").rglob("*answer*"))
    bad = tmp_path / "bad.yaml"
    bad.write_text("generator: {n_case: 3}\n")
    assert main([str(bad), "--out", str(tmp_path / "x")]) == 2
