"""bpmid simulate through the command line: outputs, exit codes, nothing half-written."""
import os

import numpy as np
import pandas as pd
import yaml
from typer.testing import CliRunner

from bpmid.cli import app

runner = CliRunner()


def steady_ramps(t, p, settle_s):
    """Samples of the command p(t) on a ramp whose slope has not changed for ``settle_s``, and the slope."""
    rate = np.concatenate([[0.0], np.round(np.diff(p) / np.diff(t), 9)])
    change = np.concatenate([[True], rate[1:] != rate[:-1]])
    since = t - np.maximum.accumulate(np.where(change, t, -np.inf))
    return (rate != 0) & (since >= settle_s - 1e-9), rate
PROTO = """kind: motion
name: cli
seed: 4
logs:
  - name: tri
    start: 1.2
    program:
      - triangle: {low: 1.2, high: 1.8, rate: 0.2, cycles: 2}
sensors: {angle_noise_deg: 0.2}
"""


def test_help_has_an_example():
    r = runner.invoke(app, ["simulate", "--help"])
    assert r.exit_code == 0 and "Example: bpmid simulate" in r.output


def test_simulate_writes_logs_and_a_manifest(tmp_path):
    p = tmp_path / "p.yaml"
    p.write_text(PROTO)
    out = tmp_path / "out"
    r = runner.invoke(app, ["simulate", str(p), "--out", str(out), "--effect", "braid_friction:r=2000,elements=3",
                            "--seed", "9"])
    assert r.exit_code == 0, r.output
    m = yaml.safe_load((out / "manifest.yaml").read_text())
    assert m["seed"] == 9 and m["effects"][0]["id"] == "braid_friction"
    assert m["effects"][0]["settings"] == {"elements": 3} and m["effects"][0]["params"]["r"]["value"] == 2000
    assert m["provenance"]["seed"] == 9 and "created" in m["provenance"]
    assert "braid" not in (out / "tri.csv").read_text()
    # the effect acts on the plant: the same protocol and seed without it gives other angles, and by what a
    # dead band of r = 2000 Pa means (play operators: on a ramp the muscle sees the pressure r behind, so the
    # angle is about slope * r lower while rising and higher while falling)
    plain = tmp_path / "plain"
    r = runner.invoke(app, ["simulate", str(p), "--out", str(plain), "--seed", "9"])
    assert r.exit_code == 0, r.output
    with_fx, without = (pd.read_csv(d / "tri.csv", comment="#") for d in (out, plain))
    assert np.array_equal(with_fx.time_s, without.time_s)
    from bpmid.twin.protocol import load_protocol

    proto = load_protocol(p)
    t, p_cmd = proto.render(proto.logs[0])
    assert np.allclose(t, without.time_s)
    d = (with_fx.angle_deg - without.angle_deg).to_numpy()
    slope = np.polyfit(p_cmd, without.angle_deg, 1)[0]          # deg/bar of the effect-free twin
    assert 20 < slope < 120
    ramp, rate = steady_ramps(t, p_cmd, 0.5)                     # 0.5 s: all three slip limits passed
    assert ramp.sum() >= 40
    ratio = d[ramp] / (-np.sign(rate[ramp]) * slope * 2000 / 1e5)
    assert 0.7 < np.median(ratio) < 1.5, np.median(ratio)
    assert np.mean(ratio > 0) > 0.95                              # below while rising, above while falling


def test_bad_input_exits_2_naming_the_key_and_writes_nothing(tmp_path):
    out = tmp_path / "out"
    cases = [(PROTO.replace("rate: 0.2", "rate: -0.2"), [], "logs[0].program[0].triangle.rate"),
             (PROTO.replace("cycles: 2}", "cycles: 2, colour: red}"), [], "logs[0].program[0].triangle.colour"),
             (PROTO.replace("high: 1.8", "high: 99"), [], "logs[0].program[0].triangle.high"),
             (PROTO, ["--effect", "gremlins"], "key '--effect.gremlins'"),
             (PROTO, ["--effect", "pressure_lag:tau=0.1,lag=2"], "key '--effect.pressure_lag.lag'"),
             (PROTO, ["--effect", "pressure_lag:tau=-1"], "key '--effect.pressure_lag.tau'"),
             (PROTO, ["--effect", "pressure_lag:tau=fast"], "key '--effect.pressure_lag.tau'")]
    for i, (text, extra, key) in enumerate(cases):
        p = tmp_path / f"p{i}.yaml"
        p.write_text(text)
        r = runner.invoke(app, ["simulate", str(p), "--out", str(out)] + extra)
        assert r.exit_code == 2, (key, r.output)
        assert key in r.output, r.output
        assert not out.exists() or not os.listdir(out)
    assert not [f for f in os.listdir(tmp_path) if f.startswith(".out")]


def test_simulate_a_reference_protocol(tmp_path):
    """The shipped control references (kind: reference, designed signals with no seed) crashed with KeyError
    'seed' after writing their files."""
    from pathlib import Path as _P

    repo = _P(__file__).resolve().parents[1]
    res = runner.invoke(app, ["simulate", str(repo / "configs" / "datasets" / "control_references.yaml"), "--out",
                              str(tmp_path / "ref"), "--seed", "3"])
    assert res.exit_code == 0, res.output
    assert "wrote 5 files and manifest.yaml" in res.output and "--seed has no effect" in res.output
    assert (tmp_path / "ref" / "manifest.yaml").is_file() and len(list((tmp_path / "ref").glob("*.csv"))) == 5
    (tmp_path / "ref" / "earlier_run.csv").write_text("time_s,pressure_bar,angle_deg\n0,1.2,10\n")
    res = runner.invoke(app, ["simulate", str(repo / "configs" / "datasets" / "control_references.yaml"), "--out",
                              str(tmp_path / "ref")])
    assert res.exit_code == 0 and "already held 1 other log file (earlier_run.csv)" in res.output, res.output


def test_a_blind_simulation_keeps_its_answer_out_of_the_folder_and_the_command(tmp_path, monkeypatch):
    """The answer was written among the logs, and the manifest's command named the hidden effect's values."""
    proto = tmp_path / "blind.yaml"
    proto.write_text("schema: bpmid.protocol/1\nkind: motion\nunit: bar\npressure_reference: absolute\nsampling_hz: 10\n"
                     "seed: 2\nblind: true\nlogs:\n  - name: a\n    start: 1.2\n    program:\n"
                     "      - triangle: {low: 1.2, high: 1.6, rate: 0.2, cycles: 1}\n")
    out = tmp_path / "case"
    args = ["simulate", str(proto), "--effect", "angle_offset:offset=3", "--out", str(out)]
    monkeypatch.setattr("sys.argv", ["bpmid", *args])   # the command line the manifest records
    res = runner.invoke(app, args)
    assert res.exit_code == 0, res.output
    assert not list(out.glob("*ANSWER*")) and (tmp_path / "case_ANSWER.yaml").is_file()
    text = (out / "manifest.yaml").read_text()
    command = yaml.safe_load(text)["provenance"]["command"]
    assert "offset=3" not in text and "--effect <hidden>" in command and "offset" not in command
    assert "angle_offset" in (tmp_path / "case_ANSWER.yaml").read_text()


def test_an_effect_key_given_twice_is_refused(tmp_path):
    from bpmid.twin.simulate import parse_effect_arg
    import pytest as _pytest
    from bpmid.errors import InputError

    with _pytest.raises(InputError, match="tau is given twice") as e:
        parse_effect_arg("pressure_lag:tau=0.1,tau=0.2")
    assert e.value.key == "--effect.pressure_lag.tau"


def test_a_blind_answer_stays_out_of_the_current_folder(tmp_path, monkeypatch):
    from bpmid.twin.simulate import Simulation

    monkeypatch.chdir(tmp_path)
    assert Simulation.answer_path(".") == tmp_path.parent / f"{tmp_path.name}_ANSWER.yaml"


def test_a_protocol_whose_logs_would_be_too_short_to_read_is_refused(tmp_path):
    """sampling_hz 0.01 on a 38 s log wrote 1-sample CSVs that bpmid's own fit then refused; now the protocol is
    refused naming sampling_hz, and nothing is written."""
    from pathlib import Path

    repo = Path(__file__).resolve().parents[1]
    text = (repo / "configs" / "datasets" / "fitting_set.yaml").read_text().replace("sampling_hz: 10", "sampling_hz: 0.01")
    proto = tmp_path / "slow.yaml"
    proto.write_text(text)
    r = runner.invoke(app, ["simulate", str(proto), "--out", str(tmp_path / "o")])
    assert r.exit_code == 2 and "key 'sampling_hz'" in r.output and "fewer than the 2" in r.output, r.output
    assert not (tmp_path / "o").exists()


def test_a_negative_seed_names_the_flag(tmp_path):
    """--seed -5 was refused as key 'seed' (the library's argument), a key the command line does not have."""
    p = tmp_path / "p.yaml"
    p.write_text(PROTO)
    r = runner.invoke(app, ["simulate", str(p), "--seed", "-5", "--out", str(tmp_path / "o")])
    assert r.exit_code == 2 and "key '--seed'" in r.output and "-5" in r.output, r.output
    assert not (tmp_path / "o").exists()
