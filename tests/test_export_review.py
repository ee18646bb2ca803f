"""`bpmid export` as a new user met it: a user's own file is never replaced, the C header says the rig the constants
belong to, the library call takes a path or a loaded result and names its own arguments, the FEA cards carry the
fit's word on Poisson's ratio and wrap between words."""
import re

import pytest
import yaml
from typer.testing import CliRunner

import bpmid
from bpmid.cli import app
from bpmid.errors import BpmidWarning, InputError
from bpmid.export.c import rig_defines
from bpmid.models.vbmm.rig import fit_rig
from bpmid.models.vbmm import VBMM
from tests.test_export_c import write_fit
from tests.test_relax_export import fit_file

runner = CliRunner()


@pytest.fixture
def vbmm_fit(tmp_path):
    return write_fit(tmp_path / "VBMM.yaml", VBMM())


def test_a_users_own_file_in_the_output_folder_is_never_replaced(vbmm_fit, tmp_path):
    mine = tmp_path / "mine"
    mine.mkdir()
    (mine / "main.c").write_text("/* my own main */\n")
    r = runner.invoke(app, ["export", str(vbmm_fit), "--to", "c", "--out", str(mine)])
    assert r.exit_code == 2 and "main.c is already in" in r.output and "bpmid did not write it" in r.output, r.output
    assert (mine / "main.c").read_text() == "/* my own main */\n" and sorted(p.name for p in mine.iterdir()) == ["main.c"]
    # a folder an earlier export wrote is written again
    out = tmp_path / "c"
    for _ in range(2):
        r = runner.invoke(app, ["export", str(vbmm_fit), "--to", "c", "--out", str(out)])
        assert r.exit_code == 0, r.output
    # FEA: the card, and COMSOL's branch table (numbers only: bpmid's when the card beside it is)
    relax = fit_file(tmp_path)
    fea = tmp_path / "fea"
    fea.mkdir()
    (fea / "fit_abaqus.inp").write_text("** my deck\n")
    r = runner.invoke(app, ["export", str(relax), "--to", "abaqus", "--out", str(fea)])
    assert r.exit_code == 2 and "fit_abaqus.inp is already in" in r.output
    assert (fea / "fit_abaqus.inp").read_text() == "** my deck\n"
    (fea / "fit_comsol_branches.txt").write_text("1 2 3\n")
    r = runner.invoke(app, ["export", str(relax), "--to", "comsol", "--out", str(fea)])
    assert r.exit_code == 2 and "fit_comsol_branches.txt is already in" in r.output and not (fea / "fit_comsol.txt").exists()
    (fea / "fit_comsol_branches.txt").unlink()
    for _ in range(2):
        r = runner.invoke(app, ["export", str(relax), "--to", "comsol", "--out", str(fea)])
        assert r.exit_code == 0, r.output


def test_the_c_header_says_the_step_and_the_ambient_of_the_fit():
    absolute = {"pressure_reference": {"reference": "absolute", "atmosphere_pa": 96000.0}}
    data = {"fit": {"logs": [{"samples": 381, "duration_s": 38.0, "step_s": 0.1},
                             {"samples": 201, "duration_s": 23.1, "step_s": 0.1},   # a 3 s gap: its median step
                             {"samples": 381, "duration_s": 38.0}]},                 # a file from before step_s
            "provenance": {"reading": {"a": absolute, "b": absolute}}}
    steps, atm, gauge = fit_rig(data)
    assert steps == pytest.approx([0.1, 0.1, 0.1]) and atm == [96000.0] and not gauge
    h = rig_defines(data)
    assert "#define BPMID_FIT_STEP_S 0.1\n" in h and "#define BPMID_FIT_ATMOSPHERE_PA 96000.0\n" in h
    # logs at two rates: no step made up between them
    two_rates = {"fit": {"logs": [{"step_s": 0.1}, {"step_s": 0.01}]}}
    assert "#define BPMID_FIT_STEP_S" not in rig_defines(two_rates) and "different steps (0.01, 0.1 s" in rig_defines(two_rates)
    # logs read as gauge, a file without the record, a rate-independent model: said, never a made-up number
    gauge = {"provenance": {"reading": {"a": {"pressure_reference": {"reference": "gauge"}}}}}
    assert "gauge pressure as the rig measured it" in rig_defines(gauge) and "#define" not in rig_defines(gauge)
    assert "records no sampling step" in rig_defines({}) and "records no ambient" in rig_defines({})
    assert "STEP" not in rig_defines(data, rate_dependent=False)
    two = {"provenance": {"reading": {k: {"pressure_reference": {"reference": "absolute", "atmosphere_pa": a}}
                                      for k, a in (("a", 95000.0), ("b", 101325.0))}}}
    assert "ambient 95000, 101325 Pa" in rig_defines(two) and "#define" not in rig_defines(two)
    mixed = {"provenance": {"reading": {"a": absolute, "b": {"pressure_reference": {"reference": "gauge"}}}}}
    assert "#define" not in rig_defines(mixed) and "gave gauge pressure already" in rig_defines(mixed)
    # a hand-edited value that is no number is left out, not written into C or raised as a bare ValueError
    for bad in (float("nan"), "abc", -5.0):
        edited = {"provenance": {"reading": {"a": {"pressure_reference": {"reference": "absolute", "atmosphere_pa": bad}}}},
                  "fit": {"logs": [{"step_s": "x", "samples": "y", "duration_s": 3.0}]}}
        h = rig_defines(edited)
        assert "#define" not in h and "nan" not in h.lower().replace("ambient", ""), bad


def test_a_motion_fit_records_each_logs_median_step(tmp_path):
    from tests.test_cli_fit_motion_predict import write_log

    log = write_log(tmp_path / "fit.csv", 1.6, 60.0, seed=1)
    r = runner.invoke(app, ["fit", "motion", str(log), "--out", str(tmp_path / "VBMM.yaml")])
    assert r.exit_code == 0, r.output
    d = yaml.safe_load((tmp_path / "VBMM.yaml").read_text())
    assert d["fit"]["logs"][0]["step_s"] == pytest.approx(0.1)
    r = runner.invoke(app, ["export", str(tmp_path / "VBMM.yaml"), "--to", "c", "--out", str(tmp_path / "c")])
    h = (tmp_path / "c" / "bpmid_model.h").read_text()
    assert "#define BPMID_FIT_STEP_S 0.1\n" in h and "#define BPMID_FIT_ATMOSPHERE_PA 101325.0\n" in h
    # the gauge pressures it was fitted on, for a controller to check against (the model answers beyond them)
    lo, hi = d["fit"]["logs"][0]["pressure_gauge_pa"]
    assert f"#define BPMID_FIT_PRESSURE_MIN_PA {float(f'{lo:.9g}')!r}\n" in h
    assert f"#define BPMID_FIT_PRESSURE_MAX_PA {float(f'{hi:.9g}')!r}\n" in h and hi > 1e4


def test_the_c_header_gives_the_fitted_pressures_over_every_log_and_never_a_made_up_one():
    two = {"fit": {"logs": [{"pressure_gauge_pa": [1000.0, 40000.0]}, {"pressure_gauge_pa": [-50.0, 61000.5]}]}}
    h = rig_defines(two)
    assert "#define BPMID_FIT_PRESSURE_MIN_PA -50.0\n" in h and "#define BPMID_FIT_PRESSURE_MAX_PA 61000.5\n" in h
    for bad in ({}, {"fit": {"logs": [{"pressure_gauge_pa": ["x", 3.0]}, {"pressure_gauge_pa": [1.0]}]}},
                {"fit": {"logs": [{"pressure_gauge_pa": [float("nan"), 3.0]}]}}):
        assert "BPMID_FIT_PRESSURE" not in rig_defines(bad), bad


def test_the_library_call_takes_a_path_or_a_loaded_result_and_names_its_arguments(vbmm_fit, tmp_path):
    written = bpmid.export(vbmm_fit, "c", tmp_path / "a")
    assert [p.name for p in written] == ["bpmid_model.h", "bpmid_model.c", "main.c"]
    again = bpmid.export(bpmid.load(vbmm_fit), "c", tmp_path / "b")
    assert (tmp_path / "b" / "bpmid_model.c").read_text() == written[1].read_text()
    assert bpmid.export.export is not None and callable(bpmid.export)   # the module of the exporters, callable
    cases = [((vbmm_fit, "fortran", tmp_path / "x"), {}, "to"), ((vbmm_fit, "c", tmp_path / "x"), {"model": "gpi"}, "model"),
             ((tmp_path, "c", tmp_path / "x"), {}, "fit"), ((object(), "c", tmp_path / "x"), {}, "fit"),
             ((vbmm_fit, "c", vbmm_fit), {}, "out")]
    for args, kw, key in cases:
        with pytest.raises(InputError) as e:
            bpmid.export(*args, **kw)
        assert e.value.key == key, (key, str(e.value))
    (tmp_path / "c").mkdir()
    (tmp_path / "c" / "main.c").write_text("int main(void) { return 0; }\n")
    with pytest.raises(InputError) as e:
        bpmid.export(vbmm_fit, "c", tmp_path / "c")
    assert e.value.key == "out" and "bpmid did not write it" in str(e.value)
    assert not (tmp_path / "x").exists()
    # a result fitted in the session has no file: said, with what to do
    from bpmid.results import VBMMFitResult

    unsaved = VBMMFitResult(bpmid.load(vbmm_fit).to_dict(), None)
    with pytest.raises(InputError, match=r"not loaded from a file.*result.save\('fit.yaml'\)") as e:
        bpmid.export(unsaved, "c", tmp_path / "y")
    assert e.value.key == "fit"


def test_a_folder_given_as_the_fit_names_the_fit_files_in_it(vbmm_fit, tmp_path):
    d = tmp_path / "run"
    d.mkdir()
    (d / "vbmm_fit.yaml").write_text(vbmm_fit.read_text())
    r = runner.invoke(app, ["export", str(d), "--to", "c", "--out", str(tmp_path / "out")])
    assert r.exit_code == 2 and "the fit is a folder" in r.output and "vbmm_fit.yaml (--to c)" in r.output, r.output
    assert not (tmp_path / "out").exists()


def test_fea_cards_carry_the_fits_word_on_poisson_and_wrap_between_words(tmp_path):
    p = fit_file(tmp_path, wlf=False)
    body = yaml.safe_load(p.read_text())
    body["warnings"] = ["Poisson's ratio is the default 0.49933 (the paper's rubber), but the instantaneous modulus is "
                        "9.35 GPa: give the material's own with --poisson", "an unrelated warning"]
    long_cmd = "bpmid fit relax " + " ".join(f"/a/rather/long/folder/name/log_{i:02d}.csv" for i in range(8)) + " --out fit.yaml"
    body["provenance"]["command"] = long_cmd
    p.write_text(yaml.safe_dump(body))
    with pytest.warns(BpmidWarning, match=r"fit_abaqus.inp: from fit.yaml: Poisson's ratio is the default") as rec:
        card = bpmid.export(p, "abaqus", tmp_path / "fea")[0]
    assert not any("unrelated" in str(w.message) for w in rec)
    text = card.read_text()
    assert "nu = 0.45: Poisson's ratio given to the fit; not fitted from its data" in text
    # the long command wraps between its words: every path stays whole on one line
    comment = [ln[2:].strip() for ln in text.splitlines() if ln.startswith("**")]
    for i in range(8):
        assert any(f"/a/rather/long/folder/name/log_{i:02d}.csv" in ln for ln in comment), i
    assert all(len(ln) <= 150 for ln in comment)
    r = runner.invoke(app, ["export", str(p), "--to", "comsol", "--out", str(tmp_path / "fea2")])
    assert r.exit_code == 0 and "fit_comsol.txt: from fit.yaml: Poisson's ratio is the default" in r.output
    assert re.search(r'nu_inst 0\.45 "Poisson\'s ratio given to the fit \(not fitted\)"', (tmp_path / "fea2" / "fit_comsol.txt").read_text())


def test_a_negative_modulus_in_a_hand_edited_fit_names_its_own_key(tmp_path):
    for where, key in ((("prony", "E_inf"), "prony.E_inf"), (("prony", "terms", 1, "E"), "prony.terms[1].E")):
        p = fit_file(tmp_path, name=f"neg_{len(where)}.yaml")
        body = yaml.safe_load(p.read_text())
        node = body
        for k in where:
            node = node[k]
        node["value"] = -100.0
        p.write_text(yaml.safe_dump(body))
        r = runner.invoke(app, ["export", str(p), "--to", "abaqus", "--out", str(tmp_path / "fea")])
        assert r.exit_code == 2 and f"key '{key}'" in r.output and "found -100 Pa" in r.output, r.output
    assert not (tmp_path / "fea").exists()


def test_a_motion_fit_file_takes_kpa_mpa_and_ms_as_a_relaxation_file_does(vbmm_fit, tmp_path):
    from bpmid.models.vbmm import load_vbmm

    body = yaml.safe_load(vbmm_fit.read_text())
    m = body["material"]
    m["K_inf"] = {"value": m["K_inf"]["value"] / 1e6, "unit": "MPa"}
    m["branches"][0]["K"] = {"value": m["branches"][0]["K"]["value"] / 1e3, "unit": "kPa"}
    m["branches"][0]["tau"] = {"value": m["branches"][0]["tau"]["value"] * 1e3, "unit": "ms"}
    p = tmp_path / "units.yaml"
    p.write_text(yaml.safe_dump(body))
    a, b = load_vbmm(vbmm_fit).material, load_vbmm(p).material
    assert a.K_inf == pytest.approx(b.K_inf, rel=1e-12) and a.K == pytest.approx(b.K, rel=1e-12)
    assert a.tauG == pytest.approx(b.tauG, rel=1e-12)
    m["K_inf"]["unit"] = "psi"
    p.write_text(yaml.safe_dump(body))
    with pytest.raises(InputError) as e:
        load_vbmm(p)
    assert e.value.key == "material.K_inf" and "unit 'psi' where 'Pa' is expected (or kpa, mpa, gpa)" in str(e.value)


def test_an_export_is_its_own_to_replace_whatever_its_name_and_a_comsol_table_only_with_its_card(tmp_path):
    long = fit_file(tmp_path, name="a" * 125 + ".yaml")   # the card's first comment line wraps after "export of"
    for tool in ("abaqus", "ansys", "comsol"):
        for _ in range(2):
            bpmid.export(long, tool, tmp_path / "long")
    p = fit_file(tmp_path)
    out = tmp_path / "fea"
    card, table = bpmid.export(p, "comsol", out)
    assert bpmid.export(p, "comsol", out) == [card, table]          # its own pair, written again
    table.write_text("1 5 6\n")                                      # a user's own table beside bpmid's card
    with pytest.raises(InputError, match="fit_comsol_branches.txt is already in"):
        bpmid.export(p, "comsol", out)
    assert table.read_text() == "1 5 6\n"
    card.unlink()
    bpmid.export(p, "abaqus", out)                                   # other tools are not held up by it
    with pytest.raises(InputError, match="no card fit_comsol.txt of bpmid.s beside it names its sha256; delete it"):
        bpmid.export(p, "comsol", out)                               # a table whose card is gone: refused


def test_a_card_without_a_shift_says_its_constants_hold_at_the_test_temperature(tmp_path):
    plain = bpmid.export(fit_file(tmp_path, wlf=False), "ansys", tmp_path / "a")[0].read_text()
    shifted = bpmid.export(fit_file(tmp_path, name="w.yaml"), "ansys", tmp_path / "b")[0].read_text()
    assert "no temperature shift in this card" in plain and "WLF shift" not in plain
    assert "WLF shift" in shifted and "no temperature shift" not in shifted


def test_a_prediction_given_to_export_points_to_the_fit_it_ran(vbmm_fit, tmp_path):
    from tests.test_cli_fit_motion_predict import write_log

    log = write_log(tmp_path / "run.csv", 1.6, 20.0, seed=4)
    r = runner.invoke(app, ["predict", str(log), "--params", str(vbmm_fit), "--out", str(tmp_path / "pred")])
    assert r.exit_code == 0, r.output
    r = runner.invoke(app, ["export", str(tmp_path / "pred" / "predict.yaml"), "--to", "c", "--out", str(tmp_path / "c")])
    assert r.exit_code == 2 and "a prediction (bpmid predict)" in r.output and f"instead: {vbmm_fit}" in r.output, r.output
    assert not (tmp_path / "c").exists()


def test_a_log_an_empty_file_a_picture_or_an_exported_file_given_as_the_fit_says_what_to_give(vbmm_fit, tmp_path):
    """A log given where a fit file belongs (bpmid export, control --params) was refused with 'expected a YAML
    mapping', an image with 'not a UTF-8 text file', a card bpmid export wrote with a YAML parse error: now each
    says what the file is and what to give instead; exit 2, nothing written."""
    from tests.test_cli_fit_motion_predict import write_log

    log = write_log(tmp_path / "run.csv", 1.6, 20.0, seed=5)
    (tmp_path / "empty.yaml").write_text("")
    (tmp_path / "fig.png").write_bytes(b"\x89PNG\r\n\x1a\n\x00\x00\x00\rIHDR\xff\xfe")
    for fit, args, words in (
            (log, ["--to", "c"], ["reads as plain text, as a log or a table does",
                                  "give a motion fit (bpmid fit motion LOG... --out VBMM.yaml"]),
            (tmp_path / "empty.yaml", ["--to", "abaqus"], ["the file is empty",
                                                           "give a relaxation fit (bpmid fit relax LOG..."]),
            (tmp_path / "fig.png", ["--to", "c"], ["not a UTF-8 text file", "give a motion fit"])):
        r = runner.invoke(app, ["export", str(fit), *args, "--out", str(tmp_path / "out")])
        text = " ".join(r.output.split())
        assert r.exit_code == 2 and str(fit) in text and all(w in text for w in words), r.output
        assert "Traceback" not in r.output and not (tmp_path / "out").exists()
    r = runner.invoke(app, ["control", "--params", str(log), "--reference", "steps_45_75", "--out",
                            str(tmp_path / "ctl")])
    assert r.exit_code == 2 and "give a motion fit" in " ".join(r.output.split()), r.output
    assert not (tmp_path / "ctl").exists()
    # what bpmid export wrote (C, every FEA card) is not read back: the fit it was made from is named
    r = runner.invoke(app, ["export", str(vbmm_fit), "--to", "c", "--out", str(tmp_path / "c")])
    assert r.exit_code == 0, r.output
    relax = fit_file(tmp_path)
    for to in ("abaqus", "ansys", "comsol"):
        r = runner.invoke(app, ["export", str(relax), "--to", to, "--out", str(tmp_path / "fea")])
        assert r.exit_code == 0, r.output
    made = [(tmp_path / "c" / n, vbmm_fit.name) for n in ("main.c", "bpmid_model.h", "bpmid_model.c")]
    made += [(f, relax.name) for f in sorted((tmp_path / "fea").iterdir()) if not f.name.endswith("_branches.txt")]
    assert len(made) == 6
    for f, src in made:
        with pytest.raises(InputError, match="a file bpmid export wrote") as exc:
            bpmid.load(f)
        assert f"the fit file it was made from, {src}," in str(exc.value) and exc.value.path == str(f)


def test_a_control_run_without_ms_pi_says_so_when_its_feedforward_is_exported(vbmm_fit, tmp_path):
    """bpmid control --controller pi,vbmm-pi writes no ms_feedforward; exporting it with --model maxwell-slip said
    'the file was edited or cut short (a file bpmid writes has it)'. Now: the run had no ms-pi, and what to do."""
    ref = tmp_path / "ref.csv"
    ref.write_text("time_s,angle_deg\n" + "".join(f"{0.1 * i:.1f},{40.0 + 0.2 * i:.1f}\n" for i in range(40)))
    r = runner.invoke(app, ["control", "--params", str(vbmm_fit), "--reference", str(ref), "--controller",
                            "pi,vbmm-pi", "--no-figure", "--out", str(tmp_path / "ctl")])
    assert r.exit_code == 0, r.output
    r = runner.invoke(app, ["export", str(tmp_path / "ctl" / "control.yaml"), "--to", "c", "--model", "maxwell-slip",
                            "--out", str(tmp_path / "c")])
    text = " ".join(r.output.split())
    assert r.exit_code == 2 and "key 'ms_feedforward'" in text, r.output
    assert "had no ms-pi controller (pi, vbmm-pi ran)" in text and "ms-pi in --controller" in text, r.output
    assert "edited or cut short" not in text and not (tmp_path / "c").exists()
