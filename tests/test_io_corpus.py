"""The re-export corpus (tests/data/rig_logs, made by make_corpus.py from clean.csv): every variant reads to the
clean file's samples, or is refused (exit 2) with a message that says what to add, or is read with a warning
that --strict turns into exit 2. None reads silently wrong. A few variants are fitted end to end and give the
clean file's constants."""
from pathlib import Path

import numpy as np
import pytest
import yaml
from typer.testing import CliRunner

from bpmid.cli import app
from bpmid.cli._logopts import LogOptions
from bpmid.config import load_config
from bpmid.errors import InputError
from bpmid.io import plausibility as plaus
from bpmid.io.motion_logs import read_motion_log

runner = CliRunner()
HERE = Path(__file__).resolve().parent / "data" / "rig_logs"
EXPECTED = yaml.safe_load((HERE / "EXPECTED.yaml").read_text())
FLAG = {"--columns": "columns", "--pressure-reference": "pressure_reference", "--pressure-unit": "pressure_unit",
        "--angle-unit": "angle_unit", "--time-unit": "time_unit", "--sheet": "sheet", "--max-gap": "max_gap"}


def io_cfg(flags=(), strict=False):
    kw = {FLAG[a]: (float(b) if a == "--max-gap" else b) for a, b in zip(flags[0::2], flags[1::2])}
    return LogOptions(strict=strict, **kw).apply(load_config(None)).section("io")


@pytest.fixture(scope="module")
def clean():
    return read_motion_log(HERE / "clean.csv", io_cfg(), require_angle=True)


def assert_same(log, clean, drop=()):
    keep = np.setdiff1d(np.arange(clean.n), np.asarray(drop, int))
    assert log.n == keep.size
    assert np.allclose(log.time_s, clean.time_s[keep], rtol=0, atol=1e-6)
    assert np.allclose(log.pressure_pa, clean.pressure_pa[keep], rtol=0, atol=1.0)       # 1 Pa: kPa at 4 decimals
    assert np.allclose(log.angle_deg, clean.angle_deg[keep], rtol=0, atol=1e-6)


def test_corpus_is_complete():
    files = {p.name for p in HERE.iterdir() if p.name not in ("make_corpus.py", "EXPECTED.yaml")}
    assert files == set(EXPECTED), files ^ set(EXPECTED)


@pytest.mark.parametrize("name", sorted(EXPECTED))
def test_variant(name, clean):
    spec = EXPECTED[name]
    path = HERE / name
    kind = spec["expect"]
    if kind == "same":
        log = read_motion_log(path, io_cfg(spec.get("flags", ())), require_angle=True)
        assert_same(log, clean)
        assert not plaus.motion_data_warnings([log]) and not log.warnings
        assert log.reading["columns"]["pressure"]["unit_from"]
    elif kind == "refused":
        with pytest.raises(InputError) as e:
            read_motion_log(path, io_cfg(), require_angle=True)
        msg = e.value.format()
        assert name in msg or str(path) in msg
        for w in spec["words"]:
            assert w in msg, (w, msg)
        if "then_flags" in spec:
            assert_same(read_motion_log(path, io_cfg(spec["then_flags"]), require_angle=True), clean)
    else:
        log = read_motion_log(path, io_cfg(), require_angle=True)
        warnings = log.warnings + plaus.motion_data_warnings([log])
        assert any(spec["warning"] in w for w in warnings), warnings
        assert any(name in w for w in warnings)
        if "drop" in spec:
            assert_same(log, clean, spec["drop"])
        if "refuse_flags" in spec:
            with pytest.raises(InputError, match="--max-gap"):
                read_motion_log(path, io_cfg(spec["refuse_flags"]), require_angle=True)


def _fit(tmp_path, name, *flags):
    out = tmp_path / f"{Path(name).stem}.yaml"
    res = runner.invoke(app, ["fit", "motion", str(HERE / name), "--out", str(out), "--no-plot", *flags])
    return res, out


def _constants(out):
    d = yaml.safe_load(out.read_text())
    return _constants_from(d), d


def _estimated(d):
    """name -> (value, stderr) of the constants the fit estimated."""
    ident = d["uncertainty"]["identifiability"]
    se = d["uncertainty"]["standard_errors"]
    vals = _constants_from(d)
    return {k: (vals[k], se[k]) for k in vals if ident.get(k) == "estimated" and se.get(k)}


def _constants_from(d):
    m = d["material"]
    vals = {"K_inf": m["K_inf"]["value"], "G_inf": m["G_inf"]["value"]}
    for i, b in enumerate(m["branches"]):
        vals.update({f"K_{i + 1}": b["K"]["value"], f"G_{i + 1}": b["G"]["value"], f"tau_{i + 1}": b["tau"]["value"]})
    return vals


@pytest.fixture(scope="module")
def clean_fit(tmp_path_factory):
    res, out = _fit(tmp_path_factory.mktemp("clean"), "clean.csv")
    assert res.exit_code == 0, res.output
    return _constants(out)[0]


@pytest.mark.parametrize("name,flags", [
    ("semicolon_decimal_comma_cp1252.csv", ()),
    ("matlab_v73.mat", ("--time-unit", "s", "--columns", "angle=phi", "--angle-unit", "deg")),
    ("bare_pressure_kpa_gauge.csv", ("--pressure-unit", "kPa", "--pressure-reference", "gauge")),
])
def test_variant_fits_to_the_clean_constants(tmp_path, clean_fit, name, flags):
    res, out = _fit(tmp_path, name, *flags)
    assert res.exit_code == 0, res.output
    vals, d = _constants(out)
    for k, v in clean_fit.items():
        assert vals[k] == pytest.approx(v, rel=1e-4), k
    reading = d["provenance"]["reading"][Path(name).stem]
    assert reading["columns"]["pressure"]["unit"] in ("bar", "kpa") and reading["pressure_reference"]["from"]


def test_bare_pressure_is_refused_by_fit_with_the_three_ways(tmp_path):
    res, out = _fit(tmp_path, "bare_pressure_kpa_gauge.csv")
    assert res.exit_code == 2 and not out.exists()
    msg = res.output
    assert "(1) in the header" in msg and "(2) a units row" in msg and "(3) the flag --pressure-unit" in msg


def test_gap_fits_close_to_clean_with_a_warning_and_is_refused_by_max_gap(tmp_path, clean_fit):
    res, out = _fit(tmp_path, "gap_eight_samples.csv")
    assert res.exit_code == 0 and "gap of 0.9 s" in res.output, res.output
    vals, d = _constants(out)
    assert any("gap of 0.9 s" in w for w in d["warnings"]) and d["provenance"]["warnings"] == d["warnings"]
    # 8 of 385 samples fewer, inside a transient: each estimated constant stays within 2 of its standard errors
    for name, (v, se) in _estimated(d).items():
        assert abs(v - clean_fit[name]) <= 2 * se, (name, v, clean_fit[name], se)
    assert len(_estimated(d)) >= 3
    res, out2 = _fit(tmp_path / "b", "gap_eight_samples.csv", "--max-gap", "0.5")
    assert res.exit_code == 2 and "--max-gap" in res.output and not out2.exists()


@pytest.mark.parametrize("name,word,strict", [("absolute_under_gauge_line.csv", "absolute", False),
                                              ("radians_in_deg_column.csv", "radians", True)])
def test_silently_wrong_today_warns_and_strict_refuses(tmp_path, name, word, strict):
    res, out = _fit(tmp_path, name, *(["--strict"] if strict else []))
    if strict:
        assert res.exit_code == 2 and "--strict" in res.output and word in res.output and not out.exists()
        return
    assert res.exit_code == 0 and "warning:" in res.output and word in res.output, res.output
    d = yaml.safe_load(out.read_text())
    assert any(word in w for w in d["warnings"])
