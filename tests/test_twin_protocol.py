"""Protocol files: rendering of the experimenter's segments, seeds, sensors, the manifest, bad files refused."""
import io
import textwrap

import numpy as np
import pandas as pd
import pytest
import yaml

from bpmid.errors import InputError
from bpmid.io.motion_logs import read_motion_log
from bpmid.twin.protocol import load_protocol
from bpmid.twin.simulate import simulate

MOTION = """
kind: motion
name: t
seed: 5
replicates: 2
logs:
  - name: a
    start: 1.2
    program:
      - hold: {duration_s: 1}
      - triangle: {low: 1.2, high: 1.6, rate: 0.2, cycles: 2}
      - step: {to: 1.5, slew: 1.0, hold_s: 2}
      - repeat: {times: 2, program: [{ramp: {to: 1.3, duration_s: 1}}, {ramp: {to: 1.5, rate: 0.4}}]}
plant:
  effects: {braid_friction: {r: 1000, elements: 3}}
  variation: {modulus_cv: 0.05, tau_cv: 0.1}
sensors: {angle_noise_deg: 0.2, angle_resolution_deg: 0.05, angle_drift_deg: 0.3,
          pressure_noise_bar: 0.002, pressure_resolution_bar: 0.001}
"""


def write(tmp_path, text, name="p.yaml"):
    p = tmp_path / name
    p.write_text(textwrap.dedent(text))
    return p


def test_segments_render_as_an_experimenter_means_them(tmp_path):
    proto = load_protocol(write(tmp_path, MOTION))
    t, x = proto.render(proto.logs[0])
    assert np.allclose(np.diff(t), 0.1)
    at = lambda s: x[int(round(s * 10))]
    assert at(0.5) == pytest.approx(1.2)
    assert at(1 + 2) == pytest.approx(1.6) and at(1 + 4) == pytest.approx(1.2) and at(1 + 6) == pytest.approx(1.6)
    assert at(9 + 0.3) == pytest.approx(1.5)               # slew 1 bar/s: 0.3 s from 1.2 to 1.5
    assert at(9 + 0.1) == pytest.approx(1.3)
    assert at(9.3 + 2 + 1) == pytest.approx(1.3)           # ramp over 1 s
    assert at(9.3 + 2 + 1 + 0.5) == pytest.approx(1.5)     # ramp at 0.4 bar/s
    assert t[-1] == pytest.approx(9.3 + 2 + 2 * 1.5)


def test_sine_and_sawtooth(tmp_path):
    proto = load_protocol(write(tmp_path, """
        kind: reference
        unit: deg
        logs:
          - {name: s, start: 60, program: [{sine: {mean: 60, amplitude: 15, frequency_hz: 0.25, cycles: 2}}]}
          - {name: w, start: 45, program: [{sawtooth: {low: 45, high: 75, period_s: 10, cycles: 2}}]}
        """))
    t, x = proto.render(proto.logs[0])
    assert np.allclose(x, 60 + 15 * np.sin(2 * np.pi * 0.25 * t), atol=1e-9) and t[-1] == pytest.approx(8.0)
    t, x = proto.render(proto.logs[1])
    assert x[0] == 45 and x[50] == pytest.approx(60) and x[99] == pytest.approx(74.7) and x[100] == pytest.approx(45)


def test_a_sine_after_another_level_changes_to_its_mean_at_its_slew_or_jumps_without_one(tmp_path):
    proto = load_protocol(write(tmp_path, """
        kind: reference
        unit: deg
        sampling_hz: 10
        logs:
          - {name: s, start: 30, program: [{sine: {mean: 60, amplitude: 15, frequency_hz: 0.25, cycles: 1, slew: 10}}]}
          - {name: j, start: 30, program: [{sine: {mean: 60, amplitude: 15, frequency_hz: 0.25, cycles: 1}}]}
        """))
    t, x = proto.render(proto.logs[0])
    assert x[0] == 30 and x[15] == pytest.approx(45) and x[30] == pytest.approx(60)   # 30 deg at 10 deg/s: 3 s
    assert np.allclose(x[30:], 60 + 15 * np.sin(2 * np.pi * 0.25 * (t[30:] - 3.0)), atol=1e-9)
    steepest = max(10.0, 2 * np.pi * 0.25 * 15) * 0.1              # the slew, or the sine's own steepest slope
    assert np.abs(np.diff(x)).max() <= steepest + 1e-9               # no step anywhere
    assert t[-1] == pytest.approx(7.0)
    t, x = proto.render(proto.logs[1])
    assert x[0] == pytest.approx(60) and t[-1] == pytest.approx(4.0)   # no slew: the sine starts at its mean at t = 0
    with pytest.raises(InputError, match="must be positive") as e:
        load_protocol(write(tmp_path, """
            kind: reference
            unit: deg
            logs:
              - {name: s, start: 30, program: [{sine: {mean: 60, amplitude: 15, frequency_hz: 0.25, slew: 0}}]}
            """, "bad.yaml"))
    assert e.value.key.endswith("sine.slew")


def test_motion_simulation_is_seeded_labelled_and_reads_back(tmp_path):
    path = write(tmp_path, MOTION)
    a = simulate(path, effects=["pressure_lag:tau=0.2"], timestamp=False, command="x")
    b = simulate(path, effects=["pressure_lag:tau=0.2"], timestamp=False, command="x")
    c = simulate(path, effects=["pressure_lag:tau=0.2"], seed=6, timestamp=False, command="x")
    assert a.files == b.files and a.files != c.files
    assert set(a.files) == {"a_r1.csv", "a_r2.csv"}
    m = a.manifest
    assert m["seed"] == 5 and m["synthetic"] is True and c.manifest["seed"] == 6
    assert [e["id"] for e in m["effects"]] == ["pressure_lag"]
    assert m["plant"]["effect_order"] == ["pressure_lag", "braid_friction"]
    f1, f2 = m["logs"][0]["modulus_factor"], m["logs"][1]["modulus_factor"]
    assert f1 != f2 and 0.7 < f1 < 1.3                     # replicate variation, recorded
    text = a.files["a_r1.csv"].decode()
    assert "synthetic" in text and "pressure_lag" not in text and "friction" not in text
    out = tmp_path / "out"
    a.write(out)
    log = read_motion_log(out / "a_r1.csv")
    assert log.pressure_reference == "absolute" and log.angle_deg is not None
    assert np.allclose(log.pressure_pa + 101325, np.round(log.pressure_as_given * 1e5))
    # sensors: quantised to their resolution
    df = pd.read_csv(io.StringIO(text), comment="#")
    assert np.allclose(df.angle_deg / 0.05, np.round(df.angle_deg / 0.05), atol=1e-6)
    assert np.allclose(df.pressure_bar / 0.001, np.round(df.pressure_bar / 0.001), atol=1e-6)


def test_injected_effect_changes_the_angle_by_what_it_means(tmp_path):
    """Same protocol, same seed, with and without pressure_lag (tau = 0.2 s): on a ramp held for a while the
    lagged pressure is the ramp delayed by tau, so the angle differs by about -tau * slope * dp/dt."""
    path = write(tmp_path, MOTION)
    lag = simulate(path, effects=["pressure_lag:tau=0.2"], timestamp=False, command="x")
    plain = simulate(path, timestamp=False, command="x")
    a, b = (pd.read_csv(io.BytesIO(s.files["a_r1.csv"]), comment="#") for s in (lag, plain))
    proto = load_protocol(path)
    t, p_cmd = proto.render(proto.logs[0])
    assert np.allclose(a.time_s, t) and np.allclose(b.time_s, t)
    d = (a.angle_deg - b.angle_deg).to_numpy()
    slope = np.polyfit(p_cmd, b.angle_deg, 1)[0]                 # deg/bar of the twin without the lag
    assert 20 < slope < 120
    rate = np.concatenate([[0.0], np.round(np.diff(p_cmd) / np.diff(t), 9)])   # bar/s into each sample
    change = np.concatenate([[True], rate[1:] != rate[:-1]])
    since = t - np.maximum.accumulate(np.where(change, t, -np.inf))
    ramp = (rate != 0) & (since >= 0.6 - 1e-9)                   # 3 tau into a ramp: the lag has settled
    assert ramp.sum() >= 30
    ratio = d[ramp] / (-0.2 * slope * rate[ramp])
    assert 0.7 < np.median(ratio) < 1.4, np.median(ratio)
    assert np.mean(ratio > 0) > 0.9
    assert np.sqrt(np.mean(d ** 2)) > 0.5                        # deg: the lag shows, not just rounding


def test_sensor_noise_is_what_the_protocol_says(tmp_path):
    text = MOTION.replace("angle_drift_deg: 0.3", "angle_drift_deg: 0.0").replace("angle_resolution_deg: 0.05",
                                                                                   "angle_resolution_deg: 0.0")
    noisy = simulate(write(tmp_path, text), timestamp=False, command="x")
    clean = simulate(write(tmp_path, text.replace("angle_noise_deg: 0.2", "angle_noise_deg: 0.0"), "c.yaml"),
                     timestamp=False, command="x")
    d = [pd.read_csv(io.BytesIO(s.files["a_r1.csv"]), comment="#").angle_deg.values for s in (noisy, clean)]
    assert np.std(d[0] - d[1]) == pytest.approx(0.2, rel=0.2)


def test_blind_protocols_keep_the_effect_out_of_the_manifest(tmp_path):
    sim = simulate(write(tmp_path, MOTION + "blind: true\neffects: {angle_offset: {offset: 1.0}}\n"),
                   timestamp=False, command="x")
    assert "angle_offset" not in yaml.safe_dump(sim.manifest)
    assert sim.answer["effects"][0]["id"] == "angle_offset"


@pytest.mark.parametrize("edit,key", [
    (("rate: 0.2", "rat: 0.2"), "logs[0].program[1].triangle.rat"),
    (("rate: 0.2", "rate: -0.2"), "logs[0].program[1].triangle.rate"),
    (("high: 1.6", "high: 40.0"), "logs[0].program[1].triangle.high"),
    (("to: 1.5, slew", "to: 0.9, slew"), "logs[0].program[2].step.to"),
    (("replicates: 2", "replicate: 2"), "replicate"),
    (("braid_friction: {r: 1000", "backlash: {r: 1000"), "plant.effects.backlash"),
    (("braid_friction: {r: 1000", "braid_friction: {rr: 1000"), "plant.effects.braid_friction.rr"),
    (("angle_noise_deg: 0.2", "angle_noise_deg: -0.2"), "sensors.angle_noise_deg"),
    (("{duration_s: 1}", "{duration_s: -1}"), "logs[0].program[0].hold.duration_s"),
    (("replicates: 2", "replicates: 0"), "replicates"),
    (("seed: 5", "seed: 5\nsampling_hz: 0"), "sampling_hz"),
])
def test_bad_protocols_are_refused_naming_the_key(tmp_path, edit, key):
    with pytest.raises(InputError) as exc:
        simulate(write(tmp_path, MOTION.replace(*edit)), timestamp=False)
    assert exc.value.key == key, exc.value.format()


def test_a_top_level_rate_is_named_as_written_and_infinity_is_not_called_non_positive(tmp_path):
    """sampling_hz: 0 was named '.sampling_hz' (a leading dot: no such key in the file), and sampling_hz: .inf
    was told it 'must be positive'."""
    with pytest.raises(InputError) as exc:
        load_protocol(write(tmp_path, MOTION.replace("seed: 5", "seed: 5\nsampling_hz: .inf")))
    assert exc.value.key == "sampling_hz"
    assert "finite" in str(exc.value) and "must be positive," not in str(exc.value)


def test_bad_effect_arguments_name_the_key(tmp_path):
    path = write(tmp_path, MOTION)
    with pytest.raises(InputError, match="unknown effect id"):
        simulate(path, effects=["warp_drive"])
    with pytest.raises(InputError) as exc:
        simulate(path, effects=["pressure_lag:tua=0.1"])
    assert exc.value.key == "--effect.pressure_lag.tua"
    with pytest.raises(InputError, match="given twice") as exc:
        simulate(path, effects=["braid_friction:r=10"])
    # it says where the id already is and how to change it instead
    assert exc.value.key == "plant.effects.braid_friction"
    assert "plant.effects and --effect" in str(exc.value) and "edit plant.effects.braid_friction" in str(exc.value)
    # twice on the command line: nothing in the protocol to edit (it said "edit --effect.pressure_lag ... (a copy
    # of the protocol for its own keys)", naming the protocol file)
    with pytest.raises(InputError, match="given twice") as exc:
        simulate(path, effects=["pressure_lag:tau=0.2", "pressure_lag:dead_time=0.1"])
    assert exc.value.key == "--effect.pressure_lag" and exc.value.path is None
    assert "--effect pressure_lag:key=value,key=value" in str(exc.value)
    assert "copy of the protocol" not in str(exc.value)


def test_the_pressure_limit_is_the_protocol_preset_s(tmp_path):
    """The check took paper_mat's limit for a paper_fit plant: 24.4 bar passed it and the run then failed with a
    pressure at a time, in Pa; the protocol's own preset decides now, naming the key."""
    import pytest as _pytest

    from bpmid.errors import InputError
    from bpmid.twin.simulate import _max_gauge_pa, simulate

    soft, stiff = _max_gauge_pa(None, "paper_fit"), _max_gauge_pa(None, "paper_mat")
    assert soft < stiff
    high = (soft + 101325.0) / 1e5 + 0.5     # between the two limits, bar absolute
    assert high < (stiff + 101325.0) / 1e5
    p = tmp_path / "high.yaml"
    p.write_text("schema: bpmid.protocol/1\nname: high\nkind: motion\nunit: bar\npressure_reference: absolute\n"
                 "sampling_hz: 10\nseed: 1\nlogs:\n  - name: tri\n    program:\n      - triangle: {low: 1.2, "
                 f"high: {high:.3f}, rate: 0.5, cycles: 1}}\n")
    with _pytest.raises(InputError, match=r"above the model's range \(at most") as e:
        simulate(p)
    assert e.value.key == "logs[0].program[0].triangle.high"


def test_protocol_errors_name_the_key(tmp_path):
    """A missing required field said Python's 'Hold.__init__() missing 1 required positional argument'; a bad
    value in the relaxation block named only 'relaxation' with a dump of the block."""
    import pytest as _pytest

    from bpmid.errors import InputError
    from bpmid.twin.protocol import load_protocol

    p = tmp_path / "miss.yaml"
    p.write_text("schema: bpmid.protocol/1\nkind: motion\nunit: bar\nsampling_hz: 10\nlogs:\n  - name: a\n    start: 1.2\n"
                 "    program:\n      - hold: {}\n")
    with _pytest.raises(InputError, match="missing key 'duration_s'") as e:
        load_protocol(p)
    assert e.value.key == "logs[0].program[0].hold.duration_s" and "positional" not in str(e.value)


def test_a_reference_protocol_beyond_0_to_180_deg_is_refused_naming_the_key(tmp_path):
    import pytest as _pytest

    from bpmid.errors import InputError
    from bpmid.twin.protocol import load_protocol

    p = tmp_path / "ref.yaml"
    p.write_text("schema: bpmid.protocol/1\nkind: reference\nunit: deg\nsampling_hz: 10\nlogs:\n  - name: r\n"
                 "    start: 30\n    program:\n      - ramp: {to: 900, duration_s: 5}\n")
    with _pytest.raises(InputError, match="angle 900 deg is outside 0..180 deg") as e:
        load_protocol(p)
    assert e.value.key == "logs[0].program[0].ramp.to"


@pytest.mark.parametrize("freq,fs,ok", [(8.0, 10.0, False), (5.0, 10.0, False), (4.9, 10.0, True), (0.3, 10.0, True)])
def test_a_sine_at_or_above_half_the_sampling_rate_is_refused_not_aliased(tmp_path, freq, fs, ok):
    """An 8 Hz sine in a 10 Hz protocol was logged (and run through the plant) as a 2 Hz sine, exit 0."""
    text = MOTION.replace("seed: 5", f"seed: 5\nsampling_hz: {fs}").replace(
        "      - hold: {duration_s: 1}\n",
        "      - hold: {duration_s: 1}\n"
        f"      - repeat: {{times: 2, program: [{{sine: {{mean: 1.4, amplitude: 0.1, frequency_hz: {freq}, "
        "cycles: 3}}]}\n")
    path = write(tmp_path, text)
    if ok:
        assert load_protocol(path).sampling_hz == fs
        return
    with pytest.raises(InputError) as exc:
        simulate(path, timestamp=False)
    assert exc.value.key == "logs[0].program[1].repeat.program[0].sine.frequency_hz"
    assert "aliasing" in str(exc.value) and "sampling_hz" in str(exc.value)
    from typer.testing import CliRunner

    from bpmid.cli import app

    out = tmp_path / "out"
    r = CliRunner().invoke(app, ["simulate", str(path), "--out", str(out)])
    assert r.exit_code == 2 and "frequency_hz" in r.output and "Traceback" not in r.output
    assert not out.exists()


def test_an_unknown_key_lists_only_keys_a_protocol_file_may_hold(tmp_path):
    """A typo listed 'path' and 'sha256' among the known keys, yet a file giving either was refused: they are
    filled in by bpmid."""
    with pytest.raises(InputError) as exc:
        load_protocol(write(tmp_path, MOTION.replace("seed: 5", "sampling_hzz: 10")))
    assert exc.value.key == "sampling_hzz" and "sampling_hz," in str(exc.value)
    assert "path" not in str(exc.value).split("known here:")[1] and "sha256" not in str(exc.value)
    with pytest.raises(InputError) as exc:
        load_protocol(write(tmp_path, MOTION + "sha256: abc\n"))
    assert exc.value.key == "sha256" and "known here:" in str(exc.value)
    assert load_protocol(write(tmp_path, MOTION)).sha256   # still filled in from the file


@pytest.mark.parametrize("segment,key,ok", [
    ("sawtooth: {low: 1.2, high: 1.6, period_s: 0.15, cycles: 20}", "sawtooth.period_s", False),
    ("sawtooth: {low: 1.2, high: 1.6, period_s: 0.5, cycles: 4}", None, True),
    ("triangle: {low: 1.2, high: 1.6, rate: 8.0, cycles: 20}", "triangle.rate", False),
    ("triangle: {low: 1.2, high: 1.6, rate: 2.0, cycles: 4}", None, True),
])
def test_a_sawtooth_or_triangle_of_two_samples_or_fewer_a_cycle_is_refused_not_aliased(tmp_path, segment, key, ok):
    """A 0.15 s sawtooth at 10 Hz was logged as 1.2, 1.6, 1.4, 1.2, 1.6, ... (a slower sawtooth), exit 0."""
    path = write(tmp_path, MOTION.replace("      - hold: {duration_s: 1}\n", f"      - {segment}\n"))
    if ok:
        assert load_protocol(path).logs[0].program
        return
    with pytest.raises(InputError, match="aliasing") as exc:
        load_protocol(path)
    assert exc.value.key == f"logs[0].program[0].{key}"


def _quiet_motion(rate_hz: float, integration: str | None = None, step: float | None = None) -> str:
    """MOTION at ``rate_hz`` with no sensor errors and no variation, one replicate (the muscle alone is logged)."""
    data = yaml.safe_load(MOTION)
    data.update(sampling_hz=rate_hz, replicates=1, sensors={
        "angle_noise_deg": 0, "angle_resolution_deg": 0, "angle_drift_deg": 0,
        "pressure_noise_bar": 0, "pressure_resolution_bar": 0})
    data["plant"]["variation"] = {"modulus_cv": 0, "tau_cv": 0}
    data["plant"]["effects"] = {"pressure_lag": {"tau": 0.05, "dead_time": 0.05}, "braid_friction": {"r": 1000}}
    if integration is not None:
        data["plant"]["integration"] = integration
    if step is not None:
        data["plant"]["max_step_s"] = step
    return yaml.safe_dump(data)


def _angle(tmp_path, text, name):
    sim = simulate(write(tmp_path, text, name))
    frame = pd.read_csv(io.BytesIO(sim.files["a.csv"]), comment="#")
    return frame.time_s.to_numpy(), frame.angle_deg.to_numpy(), sim.manifest


def test_the_twin_s_muscle_does_not_depend_on_the_logging_rate(tmp_path):
    """A real muscle moves the same whatever rate it is logged at: the twin integrates it on steps of at most
    plant.max_step_s (continuous, the default) and logs it at sampling_hz. Run at the logging rate (log_rate, the
    model a fit at that rate uses) the 10 Hz and 200 Hz logs of one muscle differ by about a degree."""
    t10, a10, m10 = _angle(tmp_path, _quiet_motion(10), "c10.yaml")
    t200, a200, m200 = _angle(tmp_path, _quiet_motion(200), "c200.yaml")
    assert m10["plant"]["integration"] == "continuous" and m10["plant"]["substeps_per_sample"] == 100
    assert m10["plant"]["internal_step_s"] == m200["plant"]["internal_step_s"] == 0.001
    assert np.allclose(t200[::20], t10) and np.max(np.abs(a200[::20] - a10)) < 1e-5   # the CSV's rounding
    _t, r10, r_m = _angle(tmp_path, _quiet_motion(10, "log_rate"), "r10.yaml")
    _t, r200, _m = _angle(tmp_path, _quiet_motion(200, "log_rate"), "r200.yaml")
    assert r_m["plant"]["integration"] == "log_rate" and r_m["plant"]["substeps_per_sample"] == 1
    assert np.max(np.abs(r10 - r200[::20])) > 0.3        # the sampled model moves with its step ...
    assert np.max(np.abs(r200[::20] - a10)) < np.max(np.abs(r10 - a10)) / 5   # ... and nears the muscle as it shrinks
    # a finer internal step changes the logged muscle by less than the sensor's resolution
    _t, fine, _m = _angle(tmp_path, _quiet_motion(10, step=0.0002), "f10.yaml")
    assert np.max(np.abs(fine - a10)) < 0.02


@pytest.mark.parametrize("step", [0.2, 1e-5])
def test_an_internal_step_outside_its_range_is_refused_naming_the_key(tmp_path, step):
    with pytest.raises(InputError, match="largest internal step") as err:
        load_protocol(write(tmp_path, _quiet_motion(10, step=step)))
    assert err.value.key == "plant.max_step_s"


def test_a_log_whose_internal_steps_exceed_the_limit_is_refused_naming_the_step_and_the_ways_out(tmp_path):
    """A 2.2 h log at 10 Hz has 80 000 samples, but the muscle's 1 ms steps would be 8e6: refused before any work,
    naming plant.max_step_s, its value and the ways out; at log_rate, or with a coarser step, it is accepted."""
    long = yaml.safe_load(_quiet_motion(10))
    long["logs"] = [{"name": "a", "start": 1.2, "program": [{"hold": {"duration_s": 8000}}]}]
    with pytest.raises(InputError, match=r"internal steps.*plant.max_step_s 0.001 s.*log_rate") as err:
        load_protocol(write(tmp_path, yaml.safe_dump(long), "long.yaml"))
    assert err.value.key == "plant.max_step_s"
    long["plant"]["integration"] = "log_rate"
    load_protocol(write(tmp_path, yaml.safe_dump(long), "long2.yaml"))
    long["plant"].update(integration="continuous", max_step_s=0.01)
    load_protocol(write(tmp_path, yaml.safe_dump(long), "long3.yaml"))


def test_a_motion_fit_given_as_params_is_the_muscle_in_continuous_time_that_acts_as_the_fit_did(tmp_path):
    """A fit's constants hold for the sum sampled at its logs' step. Taken straight as a muscle in continuous time
    the twin's log would be 0.9 deg RMS off what the fit predicts at that step; the twin scales each branch modulus
    by the continuous factor of the fit's step, says so in the manifest, and the fit then predicts the twin's 10 Hz
    log within 0.05 deg. Run at the logging rate, the constants are taken as they are."""
    from typer.testing import CliRunner

    from bpmid.cli import app
    from bpmid.models.vbmm.model import continuous_factor

    run = CliRunner()
    bare = yaml.safe_load(_quiet_motion(10))
    bare["plant"]["effects"] = {}      # the muscle alone: what a plain VBMM fit describes
    proto = write(tmp_path, yaml.safe_dump(bare), "p.yaml")
    assert run.invoke(app, ["simulate", str(proto), "--out", str(tmp_path / "s1")]).exit_code == 0
    r = run.invoke(app, ["fit", "motion", str(tmp_path / "s1" / "a.csv"), "--out", str(tmp_path / "fit.yaml")])
    assert r.exit_code == 0, r.output
    assert run.invoke(app, ["simulate", str(proto), "--params", str(tmp_path / "fit.yaml"), "--out",
                            str(tmp_path / "s2")]).exit_code == 0
    m = yaml.safe_load((tmp_path / "s2" / "manifest.yaml").read_text())
    fit = yaml.safe_load((tmp_path / "fit.yaml").read_text())
    k_fit = fit["material"]["branches"][0]["K"]["value"]
    tau = fit["material"]["branches"][0]["tau"]["value"]
    assert "hold for its logs' step, 0.1 s" in m["plant"]["params_as_continuous_time"]
    assert m["plant"]["material"]["branches"][0]["K"]["value"] == pytest.approx(k_fit * continuous_factor(0.1, tau))
    r = run.invoke(app, ["predict", str(tmp_path / "s2" / "a.csv"), "--params", str(tmp_path / "fit.yaml"),
                         "--out", str(tmp_path / "p")])
    assert r.exit_code == 0, r.output
    assert yaml.safe_load((tmp_path / "p" / "predict.yaml").read_text())["logs"]["a"]["metrics"]["rmse_deg"] < 0.05
    bare["plant"]["integration"] = "log_rate"
    lr = write(tmp_path, yaml.safe_dump(bare), "lr.yaml")
    assert run.invoke(app, ["simulate", str(lr), "--params", str(tmp_path / "fit.yaml"), "--out",
                            str(tmp_path / "s3")]).exit_code == 0
    m3 = yaml.safe_load((tmp_path / "s3" / "manifest.yaml").read_text())
    assert "params_as_continuous_time" not in m3["plant"]
    assert m3["plant"]["material"]["branches"][0]["K"]["value"] == pytest.approx(k_fit)


def test_an_internal_step_given_with_log_rate_integration_is_refused_not_ignored(tmp_path):
    """max_step_s set beside integration: log_rate did nothing, without a word (a trial's finding)."""
    with pytest.raises(InputError, match="integration is log_rate") as err:
        load_protocol(write(tmp_path, _quiet_motion(10, "log_rate", step=0.002)))
    assert err.value.key == "plant.max_step_s"
    load_protocol(write(tmp_path, _quiet_motion(10, "continuous", step=0.002), "ok.yaml"))
