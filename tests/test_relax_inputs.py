"""``bpmid fit relax`` and the relaxation reader on bad input: gaps, too few samples, compression, mixed kinds,
time constants outside the data, and relaxation fits read back with a bad mode, Poisson's ratio or unit."""
from pathlib import Path

import numpy as np
import pytest
import yaml
from typer.testing import CliRunner

from bpmid.cli import app
from bpmid.errors import InputError
from bpmid.relax import load_relax_fit

runner = CliRunner()


@pytest.fixture
def repo_root(repo_root):
    return Path(repo_root)


REL = "datasets/relaxation/relax_300mmmin_15pct.csv"
MASTER = "datasets/reference/pyvisco/time_user_master.csv"


def _lines(repo_root, rel=REL):
    return (repo_root / rel).read_text().splitlines(keepends=True)


def _header_count(lines):
    """Number of lines before the first data row (comments and the header row)."""
    i = 0
    while lines[i].lstrip().startswith("#"):
        i += 1
    return i + 1


def _fit(tmp_path, *args):
    out = tmp_path / "o.yaml"
    res = runner.invoke(app, ["fit", "relax", *map(str, args), "--out", str(out)])
    return res, out


def _refused(res, out, *needles):
    assert res.exit_code == 2, res.output
    for n in needles:
        assert n in res.output, (n, res.output)
    assert not out.exists() and not out.with_suffix(".png").exists()


# ---- 12: a gap in a test log -------------------------------------------------------------------
def test_gap_in_relax_log_is_warned_with_file_and_line_and_refused_by_max_gap(repo_root, tmp_path):
    lines = _lines(repo_root)
    h = _header_count(lines)
    gap = tmp_path / "gap.csv"
    gap.write_text("".join(lines[:h + 40] + lines[h + 91:]))     # data rows 40..90 lost: ~1 s at 0.02 s sampling
    res, out = _fit(tmp_path, gap)
    assert res.exit_code == 0 and f"gap.csv:{h + 41}: gap of" in res.output and "--max-gap" in res.output
    out.unlink()
    out.with_suffix(".png").unlink()
    res = runner.invoke(app, ["fit", "relax", str(gap), "--out", str(out), "--max-gap", "0.5"])
    _refused(res, out, "longer than --max-gap", f"gap.csv:{h + 41}")


def test_relax_max_gap_factor_setting(repo_root, tmp_path):
    lines = _lines(repo_root)
    h = _header_count(lines)
    gap = tmp_path / "gap.csv"
    gap.write_text("".join(lines[:h + 40] + lines[h + 91:]))
    cfg = tmp_path / "c.yaml"
    cfg.write_text("relax:\n  max_gap_factor: 100\n")            # a relax-level setting wins over io.max_gap_factor
    out = tmp_path / "o.yaml"
    res = runner.invoke(app, ["fit", "relax", str(gap), "--out", str(out), "--config", str(cfg), "--no-figure"])
    assert res.exit_code == 0 and "gap of" not in res.output, res.output   # below the factor: no gap, no warning
    cfg.write_text("io:\n  max_gap_factor: 100\n")               # null relax.max_gap_factor falls back to io's
    out.unlink()
    res = runner.invoke(app, ["fit", "relax", str(gap), "--out", str(out), "--config", str(cfg), "--no-figure"])
    assert res.exit_code == 0 and "gap of" not in res.output, res.output   # below the factor: no gap, no warning
    cfg.write_text("relax:\n  max_gap_factor: 0.5\n")
    out.unlink()
    res = runner.invoke(app, ["fit", "relax", str(gap), "--out", str(out), "--config", str(cfg)])
    _refused(res, out, "relax.max_gap_factor", "c.yaml")


def test_log_spaced_modulus_curve_is_not_a_gap(repo_root, tmp_path):
    res, out = _fit(tmp_path, repo_root / MASTER, "--poisson", "0.35")   # a glassy polymer's ratio (else warned)
    assert res.exit_code == 0, res.output
    warned = [ln for ln in res.output.splitlines() if ln.startswith("warning")]
    # no gap; the one warning is that BIC still fell at the default cap of 32 terms (the cap set the count)
    assert "gap" not in res.output and len(warned) == 1 and "the most relax.max_terms = 32 lets it try" in warned[0]


# ---- 13: too few samples; compression ----------------------------------------------------------
def test_three_sample_log_names_the_file_not_terms(repo_root, tmp_path):
    lines = _lines(repo_root)
    short = tmp_path / "short.csv"
    short.write_text("".join(lines[:_header_count(lines) + 3]))
    res, out = _fit(tmp_path, short)
    _refused(res, out, "short.csv: 3 samples are too few to fit a Prony series (need at least 5")
    assert "terms" not in res.output.split("need at least")[0]


def test_negative_strain_names_file_and_line(repo_root, tmp_path):
    lines = _lines(repo_root)
    h = _header_count(lines)
    header = lines[h - 1].strip().split(",")
    j = header.index("strain")
    rows = []
    for ln in lines[h:]:
        cells = ln.rstrip("\n").split(",")
        cells[j] = repr(-float(cells[j]))
        rows.append(",".join(cells) + "\n")
    neg = tmp_path / "neg.csv"
    neg.write_text("".join(lines[:h] + rows))
    eps = np.array([-float(r.split(",")[j]) for r in rows])
    first_bad = int(np.flatnonzero(eps > 0.02 * eps.max())[0])
    res, out = _fit(tmp_path, neg)
    _refused(res, out, f"neg.csv:{h + 1 + first_bad}", "negative strain", "tension")


def test_negative_extension_names_file_and_line(tmp_path):
    log = tmp_path / "machine.csv"
    log.write_text("# gauge_length_mm: 50\n# cross_section_mm2: 12\nTime (s),Extension (mm),Load (N)\n"
                   + "".join(f"{t:.2f},{-min(t, 1.0) * 7.5:.4f},{0.3 * min(t, 1.0):.4f}\n"
                             for t in np.arange(0, 5, 0.05)))
    res, out = _fit(tmp_path, log)
    _refused(res, out, "machine.csv:5", "negative extension")


# ---- 14: short modulus curves; time constants outside the data ---------------------------------
def test_three_point_modulus_curve_is_refused(repo_root, tmp_path):
    m3 = tmp_path / "m3.csv"
    m3.write_text("".join(_lines(repo_root, MASTER)[:5]))
    res, out = _fit(tmp_path, m3)
    _refused(res, out, "m3.csv: 3 samples are too few")


def test_time_constant_beyond_the_data_is_flagged(tmp_path):
    t = np.linspace(0.1, 5.0, 50)
    E = 1.0 + np.exp(-t / 200.0) + 0.5 * np.exp(-t / 1.0)       # a 200 s term seen for 5 s
    curve = tmp_path / "slow.csv"
    curve.write_text("time_s,modulus_mpa\n" + "".join(f"{a:.5f},{b:.8f}\n" for a, b in zip(t, E)))
    res, out = _fit(tmp_path, curve, "--terms", "2")
    assert res.exit_code == 0, res.output
    body = yaml.safe_load(out.read_text())
    assert body["warnings"] and "longer than the data's time span" in body["warnings"][0]
    assert "warning: tau_2" in res.stderr


def test_fit_inside_the_data_has_no_warnings(repo_root, tmp_path):
    res, out = _fit(tmp_path, repo_root / REL, "--no-figure")
    assert res.exit_code == 0, res.output
    assert yaml.safe_load(out.read_text())["warnings"] == []
    assert "warning" not in res.stderr


# ---- 15: a test log and a modulus curve together -----------------------------------------------
def test_logs_of_different_kinds_are_refused(repo_root, tmp_path):
    res, out = _fit(tmp_path, repo_root / REL, repo_root / MASTER)
    _refused(res, out, "logs of different kinds", "relax_300mmmin_15pct.csv is a stress/strain log",
             "time_user_master.csv a modulus curve", "fit them separately")
    res, out = _fit(tmp_path, repo_root / REL, repo_root / MASTER, "--mode", "step")
    _refused(res, out, "logs of different kinds")


# ---- 18: reading a relaxation fit back ---------------------------------------------------------
@pytest.fixture
def relax_fit_file(repo_root, tmp_path):
    res, out = _fit(tmp_path, repo_root / REL, "--no-figure")
    assert res.exit_code == 0, res.output
    return out


def _edited(path, tmp_path, name, edit):
    body = yaml.safe_load(path.read_text())
    edit(body)
    p = tmp_path / name
    p.write_text(yaml.safe_dump(body, sort_keys=False))
    return p


def test_load_relax_fit_refuses_bad_mode_and_poisson(relax_fit_file, tmp_path):
    p = _edited(relax_fit_file, tmp_path, "mode.yaml", lambda b: b.update(mode="stepx"))
    with pytest.raises(InputError, match="mode must be ramp or step") as ei:
        load_relax_fit(p)
    assert ei.value.key == "mode" and ei.value.path.endswith("mode.yaml")
    p = _edited(relax_fit_file, tmp_path, "nu.yaml", lambda b: b.update(poisson_ratio=0.5))
    with pytest.raises(InputError, match="below 0.5") as ei:
        load_relax_fit(p)
    assert ei.value.key == "poisson_ratio" and ei.value.path.endswith("nu.yaml")


def test_load_relax_fit_units_convert_or_are_refused(relax_fit_file, tmp_path):
    good = load_relax_fit(relax_fit_file)

    def in_mpa(b):
        e = b["prony"]["E_inf"]
        e.update(value=e["value"] / 1e6, unit="MPa")
    same = load_relax_fit(_edited(relax_fit_file, tmp_path, "mpa.yaml", in_mpa))
    assert same.E_inf == pytest.approx(good.E_inf, rel=1e-12) and same.G_inf == good.G_inf

    def mpa_value_pa_unit(b):                                         # the value in MPa, the unit left at Pa
        b["prony"]["E_inf"]["value"] /= 1e6
    with pytest.raises(InputError, match="disagrees with E/\\(2\\(1\\+nu\\)\\)") as ei:
        load_relax_fit(_edited(relax_fit_file, tmp_path, "slip.yaml", mpa_value_pa_unit))
    assert ei.value.key == "shear.G_inf" and "prony.E_inf" in ei.value.message

    def bulk_in_mpa_labelled_pa(b):
        b["bulk"]["terms"][0]["K"]["value"] /= 1e6
    with pytest.raises(InputError) as ei:
        load_relax_fit(_edited(relax_fit_file, tmp_path, "bulk.yaml", bulk_in_mpa_labelled_pa))
    assert ei.value.key == "bulk.terms[0].K"

    def bad_unit(b):
        b["prony"]["E_inf"]["unit"] = "psi"
    with pytest.raises(InputError, match="unknown unit") as ei:
        load_relax_fit(_edited(relax_fit_file, tmp_path, "psi.yaml", bad_unit))
    assert ei.value.key == "prony.E_inf.unit"


def test_fit_motion_init_refuses_bad_mode(repo_root, relax_fit_file, tmp_path):
    p = _edited(relax_fit_file, tmp_path, "mode.yaml", lambda b: b.update(mode="stepx"))
    out = tmp_path / "VBMM.yaml"
    res = runner.invoke(app, ["fit", "motion", str(repo_root / "datasets/motion/fitting_set/fit_1p2_1p6_r1.csv"),
                              "--init", str(p), "--out", str(out), "--no-plot"])
    _refused(res, out, "mode.yaml", "mode")


def _relax_frame(repo_root, rel=REL):
    import pandas as pd

    return pd.read_csv(repo_root / rel, comment="#")


def test_milliseconds_with_fractions_under_seconds_and_seconds_under_ms_are_said_and_refused_with_strict(
        repo_root, tmp_path):
    """A 2 s ramp read as 2000 s (milliseconds with fractions under time_s: the whole-number check misses them) and
    a 60 s test read as 0.06 s (seconds under time_ms): both fit without error and give a time constant 1000 times
    off, so each is said with the unit map that fixes it, and --strict refuses it with nothing written."""
    d = _relax_frame(repo_root)
    rng = np.random.default_rng(5)
    ms = d.time_s.to_numpy() * 1000 + np.r_[0.0, rng.uniform(-0.4, 0.4, len(d) - 1)]
    slow = tmp_path / "ms_as_s.csv"
    slow.write_text("time_s,strain,stress_mpa\n" + "".join(
        f"{t:.3f},{e},{s}\n" for t, e, s in zip(ms, d.strain, d.stress_mpa)))
    fast = tmp_path / "s_as_ms.csv"
    fast.write_text("time_ms,strain,stress_mpa\n" + "".join(
        f"{t},{e},{s}\n" for t, e, s in zip(d.time_s, d.strain, d.stress_mpa)))
    for path, said, fix in ((slow, "loading ramp lasts", "time_ms=time_s"), (fast, "lasts only", "time_s=time_ms")):
        out = tmp_path / f"{path.stem}.yaml"
        r = runner.invoke(app, ["fit", "relax", str(path), "--out", str(out), "--strict"])
        assert r.exit_code == 2, r.output
        assert said in r.output and fix in r.output and path.name in r.output
        assert not out.exists() and not out.with_suffix(".png").exists()
        r = runner.invoke(app, ["fit", "relax", str(path), "--out", str(out)])
        assert r.exit_code == 0, r.output
        assert any(said in w for w in yaml.safe_load(out.read_text())["warnings"])
    # the shipped test (a 1.1-4 s ramp, 50 Hz, seconds) says neither
    r = runner.invoke(app, ["fit", "relax", str(repo_root / REL), "--out", str(tmp_path / "ok.yaml"), "--strict"])
    assert r.exit_code == 0, r.output


def _four_columns(repo_root, path, *, L0_machine, A0_machine, L0_stated=50, A0_stated=12, stress=True,
                  instrument=False):
    d = _relax_frame(repo_root)
    head = f"# gauge_length_mm: {L0_stated}\n# cross_section_mm2: {A0_stated}\n" if L0_stated else ""
    if instrument and L0_stated:   # an instrument's lines above the table
        head = f"Gauge Length (mm),{L0_stated}\nArea (mm^2),{A0_stated}\n"
    ext, load = d.strain * 50.0, d.stress_mpa * 12.0            # what the specimen (50 mm, 12 mm^2) gave
    cols = "Time (s),Extension (mm),Load (N),Tensile strain (%)" + (",Tensile stress (MPa)" if stress else "")
    rows = [f"{t},{x:.8f},{f:.10f},{100 * x / L0_machine:.8f}" + (f",{f / A0_machine:.10f}" if stress else "")
            for t, x, f in zip(d.time_s, ext, load)]
    path.write_text(head + cols + "\n" + "\n".join(rows) + "\n")
    return path


def test_strain_stress_beside_extension_load_must_agree_over_the_stated_specimen(repo_root, tmp_path):
    """A machine export with both pairs: its strain and stress computed with a wrongly entered specimen (40 mm,
    10 mm^2) while the file states 50 mm and 12 mm^2 gave E_inf 4 % off without a word. Now refused, naming both
    pairs and the specimen each implies; when they agree the machine's pair is read and the check recorded; a lone
    machine strain beside extension and load no longer hides the usable pair."""
    bad = _four_columns(repo_root, tmp_path / "wrong_specimen.csv", L0_machine=40, A0_machine=10)
    r = runner.invoke(app, ["fit", "relax", str(bad), "--out", str(tmp_path / "bad.yaml")])
    assert r.exit_code == 2, r.output
    assert "disagree" in r.output and "gauge_length_mm = 40" in r.output and "cross_section_mm2 = 10" in r.output
    assert "wrong_specimen.csv" in r.output and not (tmp_path / "bad.yaml").exists()
    inst = _four_columns(repo_root, tmp_path / "instrument.csv", L0_machine=40, A0_machine=10, instrument=True)
    r = runner.invoke(app, ["fit", "relax", str(inst), "--out", str(tmp_path / "inst.yaml")])
    assert r.exit_code == 2 and "gauge_length_mm = 40" in r.output, r.output
    # a config's specimen is checked the same way (and its key named)
    cfg = tmp_path / "spec.yaml"
    cfg.write_text("relax:\n  specimen: {gauge_length_mm: 50, cross_section_mm2: 12}\n")
    nolines = _four_columns(repo_root, tmp_path / "no_lines.csv", L0_machine=40, A0_machine=10, L0_stated=None)
    r = runner.invoke(app, ["fit", "relax", str(nolines), "--config", str(cfg), "--out", str(tmp_path / "b2.yaml")])
    assert r.exit_code == 2 and "relax.specimen" in r.output, r.output
    good = _four_columns(repo_root, tmp_path / "agree.csv", L0_machine=50, A0_machine=12)
    out = tmp_path / "good.yaml"
    r = runner.invoke(app, ["fit", "relax", str(good), "--out", str(out)])
    assert r.exit_code == 0, r.output
    body = yaml.safe_load(out.read_text())
    assert body["data"]["logs"][0]["source"] == "stress-strain"
    check = body["provenance"]["reading"]["agree"]["load_extension"]
    assert "agree" in check["note"] and check["implied_specimen"]["gauge_length_mm"] == pytest.approx(50, rel=1e-4)
    lone = _four_columns(repo_root, tmp_path / "lone_strain.csv", L0_machine=50, A0_machine=12, stress=False)
    r = runner.invoke(app, ["fit", "relax", str(lone), "--out", str(tmp_path / "lone.yaml")])
    assert r.exit_code == 0, r.output
    lone_body = yaml.safe_load((tmp_path / "lone.yaml").read_text())
    assert lone_body["data"]["logs"][0]["source"] == "load-extension"
    assert lone_body["prony"]["E_inf"]["value"] == pytest.approx(body["prony"]["E_inf"]["value"], rel=1e-3)


# ---- an instrument's specimen lines above the table ('Gauge Length (mm),50'): read, or refused naming them --------
def test_instrument_specimen_lines_are_read_with_their_units_and_refused_without_one(tmp_path):
    from bpmid.io.relax_logs import read_relax_log

    rows = "Time (s),Extension (mm),Load (N)\n" + "".join(
        f"{t:.2f},{min(t, 1.0) * 7.5:.4f},{0.3 * min(t, 1.0):.4f}\n" for t in np.arange(0, 5, 0.05))
    f = tmp_path / "instron.csv"
    f.write_text("Specimen label,S1\nGauge Length (mm),50\nArea (mm^2),12\n" + rows)
    log = read_relax_log(f)
    assert log.strain.max() == pytest.approx(7.5 / 50) and log.stress_mpa.max() == pytest.approx(0.3 / 12)
    assert log.reading["specimen"]["from"] == {"gauge_length_mm": "file line 2 (gauge_length_(mm))",
                                               "cross_section_mm2": "file line 3 (area_(mm^2))"}
    # other units and the unit after the value: converted
    g = tmp_path / "cm.csv"
    g.write_text("Gauge length: 5 cm\nArea (cm^2),0.12\n" + rows)
    log = read_relax_log(g)
    assert log.strain.max() == pytest.approx(7.5 / 50) and log.stress_mpa.max() == pytest.approx(0.3 / 12)
    # the command fits it (it asked for a '# gauge_length_mm:' line)
    res, out = _fit(tmp_path, f)
    assert res.exit_code == 0, res.output
    # no unit: refused naming the line and the forms that read (and the config still serves)
    h = tmp_path / "nounit.csv"
    h.write_text("Gauge Length,50\nArea (mm^2),12\n" + rows)
    with pytest.raises(InputError, match="states no unit; units are never guessed") as e:
        read_relax_log(h)
    assert e.value.line == 1 and "'# gauge_length_mm: <value>'" in e.value.message
    assert read_relax_log(h, gauge_length_mm=50.0).strain.max() == pytest.approx(7.5 / 50)
    # two lines that disagree, or one that disagrees with the config: refused
    k = tmp_path / "two.csv"
    k.write_text("Gauge Length (mm),50\nL0 (mm),40\nArea (mm^2),12\n" + rows)
    with pytest.raises(InputError, match="disagree"):
        read_relax_log(k)
    with pytest.raises(InputError, match="says 45"):
        read_relax_log(f, gauge_length_mm=45.0)


def test_fit_motion_init_with_a_motion_fit_says_what_init_takes_and_how_to_start_from_it(repo_root, tmp_path):
    """--init VBMM.yaml (a motion fit where a relaxation fit is expected) said only 'expected bpmid.relax/1'; it now
    says what --init takes, how to predict with the file, and gives the config that starts a fit from it, which
    works."""
    from bpmid.models.vbmm import VBMM, Material, vbmm_yaml_body

    vb = tmp_path / "VBMM_fit.yaml"
    vb.write_text(yaml.safe_dump({"schema": "bpmid.vbmm/1", **vbmm_yaml_body(VBMM(material=Material.paper_fit()))},
                                 sort_keys=False))
    log = repo_root / "datasets/motion/fitting_set/fit_1p2_1p6_r1.csv"
    out = tmp_path / "VBMM.yaml"
    res = runner.invoke(app, ["fit", "motion", str(log), "--init", str(vb), "--out", str(out), "--no-plot"])
    _refused(res, out, "VBMM_fit.yaml", "bpmid fit relax writes", "this file is a motion fit")
    msg = " ".join(res.output.split())
    assert f"bpmid predict LOG --params {vb}" in msg and "drop --init" in msg
    cfg = tmp_path / "start.yaml"
    cfg.write_text(msg.split("(--config): ")[1].split(" (Pa, s)")[0] + "\n")
    start = yaml.safe_load(cfg.read_text())["motion"]["start"]
    assert start["K_inf"] == pytest.approx(Material.paper_fit().K_inf, rel=1e-5) and "tau_1" in start
    res = runner.invoke(app, ["fit", "motion", str(log), "--config", str(cfg), "--out", str(out), "--no-plot"])
    assert res.exit_code == 0 and out.exists(), res.output
