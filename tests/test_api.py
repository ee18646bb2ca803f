"""The public API (``import bpmid``) and the one result protocol every workflow returns."""
import glob
import os
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

import bpmid
from bpmid.errors import InputError
from bpmid.results import KINDS, FileResult, Result, load

REPO = Path(__file__).resolve().parents[1]


def test_import_is_cheap_and_every_public_name_resolves():
    code = ("import sys, bpmid; heavy = [m for m in ('numpy', 'scipy', 'pandas', 'numba', 'matplotlib', 'typer') "
            "if m in sys.modules]; print(heavy)")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True,
                         env={**os.environ, "PYTHONPATH": str(REPO)}).stdout.strip()
    assert out == "[]"
    for name in bpmid.__all__:
        assert getattr(bpmid, name) is not None, name
    for name in ("fit_relaxation", "fit_motion", "predict", "compare", "discover", "simulate", "control", "load"):
        assert callable(getattr(bpmid, name)), name
    # the workflow modules stay modules for the code that imports them
    import bpmid.compare as C
    assert C.CompareResult is not None and callable(bpmid.compare)
    with pytest.raises(AttributeError):
        bpmid.no_such_name


def test_from_arrays_needs_units_and_converts_them():
    t = np.linspace(0, 10, 101)
    p_bar = 1.0 + 0.5 * np.sin(t)
    with pytest.raises(InputError, match="unit"):
        bpmid.from_arrays(t, p_bar, reference="gauge")
    with pytest.raises(InputError, match="reference"):
        bpmid.from_arrays(t, p_bar, pressure_unit="bar")
    # bar numbers declared as Pa: refused, not fitted to nonsense
    with pytest.raises(InputError, match="unit"):
        bpmid.from_arrays(t, p_bar, pressure_unit="Pa", reference="gauge")
    with pytest.raises(InputError, match="unknown pressure unit"):
        bpmid.from_arrays(t, p_bar, pressure_unit="atm", reference="gauge")
    lg = bpmid.from_arrays(t, p_bar, pressure_unit="bar", reference="gauge")
    np.testing.assert_allclose(lg.pressure_pa, p_bar * 1e5)
    lg = bpmid.from_arrays(t, p_bar + 1.01325, pressure_unit="bar", reference="absolute")
    np.testing.assert_allclose(lg.pressure_pa, p_bar * 1e5, atol=1e-6)
    lg = bpmid.from_arrays(t, p_bar * 100, pressure_unit="kPa", reference="gauge", name="k")
    np.testing.assert_allclose(lg.pressure_pa, p_bar * 1e5)
    # 1 bar absolute said to be gauge-referenced 1 bar below: vacuum -> refused
    with pytest.raises(InputError, match="below atmosphere"):
        bpmid.from_arrays(t, p_bar - 1.4, pressure_unit="bar", reference="gauge")


def test_from_arrays_takes_the_pressure_units_of_the_command_line_with_their_reference():
    """pressure_unit='psig' was asked for a reference and then refused as unknown; from_arrays now reads the units
    --pressure-unit reads (one list), a reference after the unit stating the reference, a conflicting one refused."""
    from bpmid.io.tables import UNITS
    from bpmid.units import PRESSURE_UNITS, PA_PER_PSI

    assert UNITS["pressure"] is PRESSURE_UNITS   # one list, not a copy
    t = np.linspace(0, 10, 101)
    p_psi = 10.0 + 5.0 * np.sin(t)
    for unit, ref in (("psig", None), ("psig", "gauge"), ("PSI g", None), ("psi", "gauge")):
        lg = bpmid.from_arrays(t, p_psi, pressure_unit=unit, reference=ref)
        np.testing.assert_allclose(lg.pressure_pa, p_psi * PA_PER_PSI)
        assert lg.pressure_reference == "gauge" and lg.pressure_unit == "psi"
    lg = bpmid.from_arrays(t, p_psi + 14.6959, pressure_unit="psia")
    assert lg.pressure_reference == "absolute"
    np.testing.assert_allclose(lg.pressure_pa, p_psi * PA_PER_PSI, atol=1.0)
    lg = bpmid.from_arrays(t, (p_psi * PA_PER_PSI + 101325.0) / 100.0, pressure_unit="hPa", reference="absolute")
    np.testing.assert_allclose(lg.pressure_pa, p_psi * PA_PER_PSI, atol=1e-6)
    lg = bpmid.from_arrays(t, (p_psi * PA_PER_PSI + 101325.0) / 1e5, pressure_unit="bar(a)")
    assert lg.pressure_reference == "absolute"
    with pytest.raises(InputError, match="a reference stated twice must agree") as e:
        bpmid.from_arrays(t, p_psi, pressure_unit="psig", reference="absolute")
    assert e.value.key == "reference"
    with pytest.raises(InputError, match=r"pressure_unit='psig'") as e:   # the hint names the form that works
        bpmid.from_arrays(t, p_psi, pressure_unit="psi")
    assert e.value.key == "reference"
    with pytest.raises(InputError, match="millipascal"):
        bpmid.from_arrays(t, p_psi, pressure_unit="mPa", reference="gauge")


def test_a_results_warnings_reach_a_library_caller_once_and_a_command_prints_them_once(tmp_path):
    """A script that prints only ``.params`` still sees a likely unit slip (a BpmidWarning); a command prints each
    warning once, on stderr, not also as a Python warning."""
    from typer.testing import CliRunner

    from bpmid.cli import app

    log = bpmid.read_motion_logs([sorted(glob.glob(str(REPO / "datasets/motion/fitting_set/*.csv")))[0]])[0]
    ms = bpmid.from_arrays(log.time_s * 1e3, log.pressure_pa, log.angle_deg, pressure_unit="Pa", reference="gauge")
    with pytest.warns(bpmid.BpmidWarning, match="time_unit='ms'") as said:
        fit = bpmid.fit_motion([ms])
    assert [str(w.message) for w in said if w.category is bpmid.BpmidWarning] == fit.warnings
    master = REPO / "datasets/reference/pyvisco-frequency/freq_user_master.csv"
    r = CliRunner().invoke(app, ["fit", "relax", str(master), "--terms", "4", "--no-figure", "--out",
                                 str(tmp_path / "m.yaml")])
    assert r.exit_code == 0 and r.stderr.count("Poisson's ratio is the default") == 1
    assert "BpmidWarning" not in r.stderr


def test_from_arrays_takes_time_and_angle_units_and_checks_the_ambient_pressure():
    log = bpmid.read_motion_logs([sorted(glob.glob(str(REPO / "datasets/motion/fitting_set/*.csv")))[0]])[0]
    t, p, a = log.time_s, log.pressure_pa, log.angle_deg
    same = bpmid.from_arrays(t * 1e3, p, np.radians(a), pressure_unit="Pa", reference="gauge", time_unit="ms",
                             angle_unit="rad")
    np.testing.assert_allclose(same.time_s, t, rtol=1e-12)
    np.testing.assert_allclose(same.angle_deg, a, rtol=1e-12)
    from bpmid.io import plausibility as plaus

    # milliseconds passed as seconds, radians as degrees: said, with the argument that states the unit
    said = plaus.motion_data_warnings([bpmid.from_arrays(t * 1e3, p, a, pressure_unit="Pa", reference="gauge")])
    assert len(said) == 1 and "give from_arrays(..., time_unit='ms')" in said[0]
    said = plaus.motion_data_warnings([bpmid.from_arrays(t, p, np.radians(a), pressure_unit="Pa", reference="gauge")])
    assert len(said) == 1 and "give from_arrays(..., angle_unit='rad')" in said[0]
    for key, kw in (("time_unit", {"time_unit": "sec0"}), ("angle_unit", {"angle_unit": "grad"}),
                    ("atmosphere_pa", {"atmosphere_pa": 1.01325}), ("atmosphere_pa", {"atmosphere_pa": float("nan")}),
                    ("atmosphere_pa", {"atmosphere_pa": "101325"}), ("atmosphere_pa", {"atmosphere_pa": 0})):
        with pytest.raises(InputError) as e:
            bpmid.from_arrays(t, p + 101325.0, a, pressure_unit="Pa", reference="absolute", **kw)
        assert e.value.key == key
    with pytest.raises(InputError, match="complex"):
        bpmid.from_arrays(t, p + 0j, a, pressure_unit="Pa", reference="gauge")


# ---------------------------------------------------------------------------------------------
# save -> load round trip of every result type (property test over the file's contents)
# ---------------------------------------------------------------------------------------------
_keys = st.text("abcdefghijklmnopqrstuvwxyz_0123456789", min_size=1, max_size=8)
_leaf = st.one_of(st.none(), st.booleans(), st.integers(-10**9, 10**9),
                  st.floats(allow_nan=True, allow_infinity=True), st.text(max_size=12))
_tree = st.recursive(_leaf, lambda c: st.one_of(st.lists(c, max_size=4), st.dictionaries(_keys, c, max_size=4)),
                     max_leaves=20)
_param = st.fixed_dictionaries({"value": st.floats(-1e9, 1e9, allow_nan=False), "stderr": st.one_of(
    st.none(), st.floats(0, 1e9)), "unit": st.sampled_from(["Pa", "s", "1", "deg"])})


@pytest.mark.parametrize("kind", sorted(KINDS) + ["history_modes"])
@settings(max_examples=10)
@given(body=st.dictionaries(_keys.filter(lambda k: k not in ("schema", "provenance")), _tree, max_size=5),
       prov=st.fixed_dictionaries({"bpmid_version": st.just("0.1.0"), "command": st.text(max_size=20),
                                   "inputs": st.dictionaries(_keys, st.text("0123456789abcdef", min_size=64,
                                                                            max_size=64), max_size=2)}),
       params=st.dictionaries(_keys, _param, max_size=3))
def test_every_result_type_round_trips(kind, body, prov, params):
    cls = KINDS.get(kind)
    body = dict(body)
    if kind == "discovery":
        body["final_model"] = params
    elif kind == "compare":
        body["models"] = {"gpi": {"parameters": params}}
    if cls is None:
        res = FileResult(body, prov, schema=f"bpmid.{kind}/1")
    else:
        res = cls(body, prov)
    with tempfile.TemporaryDirectory() as tmp:
        target = Path(tmp) / ("out" if cls is not None and cls.main_file else "r.yaml")
        res.save(target)
        back = load(target)
    assert type(back) is type(res)
    assert back == res and back.schema == res.schema
    assert back.params.valuesdict() == res.params.valuesdict()
    text = back.summary()
    assert back.schema in text and len(repr(back)) < 300
    assert "<table" in back._repr_html_() or not back.params


def test_load_refuses_what_bpmid_did_not_write(tmp_path):
    f = tmp_path / "x.yaml"
    f.write_text("a: 1\n")
    with pytest.raises(InputError, match="schema"):
        bpmid.load(f)
    with pytest.raises(InputError, match="no bpmid result"):
        bpmid.load(tmp_path)


# ---------------------------------------------------------------------------------------------
# the workflows on the shipped data: live results equal what they save, and plot
# ---------------------------------------------------------------------------------------------
@pytest.fixture(scope="module")
def relax():
    return bpmid.fit_relaxation(sorted(glob.glob(str(REPO / "datasets/relaxation/relax_*_[23]0pct.csv"))))


def _round_trip(res: Result, target: Path) -> Result:
    res.save(target)
    back = bpmid.load(target)
    assert back == res
    for r in (res, back):
        fig = r.plot()
        assert fig.axes and any(ax.get_xlabel() or ax.get_ylabel() for ax in fig.axes)
    assert len(str(res)) < 300
    return back


def test_relaxation_and_motion_fit_and_predict(relax, tmp_path):
    back = _round_trip(relax, tmp_path / "relax.yaml")
    assert back.params["E_inf"].unit == "Pa" and back.params["tau_1"].stderr > 0
    assert "[[Correlations]]" in relax.summary() and "C(E_1, tau_1)" in relax.summary()
    logs = sorted(glob.glob(str(REPO / "datasets/motion/fitting_set/*.csv")))[:1]
    fit = bpmid.fit_motion(logs, init=back)
    vb = _round_trip(fit, tmp_path / "VBMM.yaml")
    assert vb.params["K_inf"].identifiability == "estimated" and vb.metrics["rmse_deg"] < 5
    np.testing.assert_allclose(vb.model.material.K_inf, fit.model.material.K_inf)
    log = bpmid.read_motion_logs(logs)[0]
    arr = bpmid.from_arrays(log.time_s, log.pressure_pa / 1e3, pressure_unit="kPa", reference="gauge", name="mem")
    pred = bpmid.predict([logs[0], arr], vb)
    np.testing.assert_allclose(pred.predictions["mem"], pred.predictions[Path(logs[0]).stem])
    _round_trip(pred, tmp_path / "pred")
    assert (tmp_path / "pred" / "mem.csv").is_file()
    # loaded by a relative path, its predictions are found after the working directory changes; a missing one is
    # named, never left out of a shorter dict
    here = os.getcwd()
    try:
        os.chdir(tmp_path)
        loaded = bpmid.load("pred")
        os.chdir(REPO)
        np.testing.assert_allclose(loaded.predictions["mem"], pred.predictions["mem"], atol=1e-6)
        (tmp_path / "pred" / "mem.csv").unlink()
        with pytest.raises(InputError, match="copy or move the whole output folder") as e:
            loaded.predictions
        assert e.value.path.endswith("mem.csv")
    finally:
        os.chdir(here)


def test_simulate_and_control(tmp_path):
    sim = bpmid.simulate(REPO / "configs/datasets/variable_rate.yaml", seed=3, timestamp=False)
    assert sim.params == {} and sim.provenance["seed"] == 3
    _round_trip(sim, tmp_path / "sim")
    with pytest.warns(bpmid.BpmidWarning, match="saturated") as rec:   # control's warnings reach the caller too
        ctl = bpmid.control(_paper_vbmm(tmp_path), reference="steps",
                            controllers="pi,vbmm-pi", seed=1)
    assert all(w.filename == __file__ for w in rec) and ctl.warnings
    back = _round_trip(ctl, tmp_path / "ctl")
    assert set(back.metrics) == {"pi.rmse_deg", "vbmm-pi.rmse_deg"}
    assert (tmp_path / "ctl" / "fig18.png").is_file() and back.params["kp"].unit == "bar/deg"
    with pytest.raises(InputError, match="unknown control setting"):
        bpmid.control(_paper_vbmm(tmp_path), kp=1.0)


def _paper_vbmm(tmp_path) -> Path:
    from bpmid.io.results import write_result
    from bpmid.models.vbmm import VBMM, vbmm_yaml_body

    p = tmp_path / "paper.yaml"
    if not p.is_file():
        write_result(p, "bpmid.vbmm/1", vbmm_yaml_body(VBMM()), {"bpmid_version": bpmid.__version__})
    return p


def test_compare_result(tmp_path):
    train = sorted(glob.glob(str(REPO / "datasets/motion/fitting_set/*.csv")))[:1]
    test = sorted(glob.glob(str(REPO / "datasets/motion/variable_rate/*.csv")))[:1]
    cmp = bpmid.compare(train, test, models=["gpi", "maxwell-slip"])
    back = _round_trip(cmp, tmp_path / "cmp")
    assert list(back.table["model"])[:2] and set(back.table["model"]) == {"gpi", "maxwell-slip"}
    assert any(n.startswith("gpi.") for n in back.params)
    assert "[[Verdicts]]" in cmp.summary()


def test_shipped_data_found_through_the_package(tmp_path):
    from typer.testing import CliRunner

    from bpmid.cli import app

    assert bpmid.data.path("configs/paper.yaml").is_file()
    assert len(bpmid.data.files("datasets/motion/fitting_set/*.csv")) >= 3
    with pytest.raises(InputError, match="shipped"):
        bpmid.data.path("configs/absent.yaml")
    from bpmid.run import default_config_path
    assert default_config_path() == bpmid.data.path("configs/paper.yaml")
    r = CliRunner().invoke(app, ["shipped"])
    assert r.exit_code == 0 and Path(r.output.strip(), "configs", "paper.yaml").is_file()
    r = CliRunner().invoke(app, ["shipped", "--copy", str(tmp_path / "w")])
    assert r.exit_code == 0, r.output
    assert (tmp_path / "w" / "configs" / "paper.yaml").is_file()
    assert (tmp_path / "w" / "datasets" / "relaxation").is_dir()
    (tmp_path / "f").write_text("x")
    r = CliRunner().invoke(app, ["shipped", "--copy", str(tmp_path / "f")])
    assert r.exit_code == 2 and "--copy" in r.output


def test_uniform_recursion_equals_lfilter():
    """The hereditary states on even sampling are bit for bit what scipy.signal.lfilter gave."""
    from scipy.signal import lfilter

    from bpmid.viscoelastic import hereditary_states

    rng = np.random.default_rng(0)
    t = np.arange(3000) * 0.01
    x = rng.normal(size=t.size).cumsum()
    tau = np.array([0.05, 1.3, 40.0])
    dx = np.diff(x, prepend=x[0])
    ref = np.column_stack([lfilter([1.0], [1.0, -np.exp(-(t[1] - t[0]) / tj)], dx) for tj in tau])
    np.testing.assert_array_equal(hereditary_states(t, x, tau), ref)


def test_every_output_of_a_study_loads(timed_small_study):
    """bpmid.load on a `bpmid run` folder and on each file in it: the matching result type, summaries, figures."""
    from bpmid.results import ComparisonResult, DiscoveryResult, RelaxationResult, StudyResult, VBMMFitResult

    study = bpmid.load(timed_small_study)
    assert isinstance(study, StudyResult) and "[[Stages]]" in study.summary()
    res = study.results
    assert isinstance(res["relax"], RelaxationResult) and isinstance(res["vbmm_fit"], VBMMFitResult)
    assert isinstance(res["compare"], ComparisonResult) and isinstance(res["discover"], DiscoveryResult)
    from bpmid.results import ControlResult
    assert isinstance(res["control"], ControlResult)   # every stage's result, control's too
    assert res["vbmm_mat"].params["K_inf"].value == pytest.approx(res["relax"].params["K_inf"].value, rel=1e-9)
    assert set(res["compare"].table["model"]) == {"vbmm-mat", "vbmm-fit", "two-branch", "maxwell-slip"}
    for name, r in res.items():
        assert r == bpmid.load(r.source) and len(repr(r)) < 300, name
        assert r.summary().startswith("[[")
        # metrics are numbers, for every result type (a discovery's held its scoring sentence there)
        assert all(isinstance(v, (int, float)) for v in r.metrics.values()), name
    assert {"before_rmse_deg", "noise_floor_deg"} <= set(res["discover"].metrics)


def test_a_loaded_folder_result_saved_elsewhere_keeps_its_files(timed_small_study, tmp_path):
    """Saving a loaded comparison, discovery or control elsewhere copies the tables, predictions and figures
    beside its YAML (it wrote the YAML alone: an equal result whose table was empty)."""
    for stage, check in (("compare", lambda a, b: a.table.equals(b.table) and len(b.table) > 0),
                         ("discover", lambda a, b: (tmp_path / "discover" / "model.yaml").is_file()),
                         ("control", lambda a, b: (tmp_path / "control" / "summary.csv").is_file())):
        res = bpmid.load(Path(timed_small_study) / stage)
        res.save(tmp_path / stage)
        back = bpmid.load(tmp_path / stage)
        assert back == res and check(res, back), stage
    with pytest.raises(bpmid.InputError, match="loaded from this folder"):
        res.save(Path(timed_small_study) / "control")


def test_run_study_returns_the_study(tmp_path):
    from test_run import make_study

    cfg = make_study(tmp_path)
    cfg.write_text(cfg.read_text().replace("run:\n", "run:\n  stages: [relax]\n", 1))
    study = bpmid.run_study(cfg, tmp_path / "o")
    status = {s["name"]: s["status"] for s in study.body["stages"]}
    assert study.schema == "bpmid.run/1" and status["relax"] == "done"
    assert all(v != "done" for k, v in status.items() if k != "relax")
    assert study.results["relax"].params["E_inf"].unit == "Pa"
    assert study == bpmid.load(tmp_path / "o")


def test_library_saves_never_replace_an_input_and_logs_are_named_safely(relax, tmp_path):
    """As the CLI: a result saved over a file it was made from is refused with nothing written; in-memory logs
    that share a name, or whose name is not a plain file stem, are refused (outputs are named by it); a folder
    holding two results is not loaded as one of them."""
    import shutil

    src = sorted(glob.glob(str(REPO / "datasets/motion/fitting_set/*.csv")))[0]
    mine = tmp_path / "my_log.csv"
    shutil.copy(src, mine)
    before = mine.read_bytes()
    start = relax.save(tmp_path / "start.yaml")
    start_bytes = start.read_bytes()
    fit = bpmid.fit_motion([mine], init=start)
    with pytest.raises(InputError, match="would replace the input"):
        fit.save(start)
    assert start.read_bytes() == start_bytes
    with pytest.raises(InputError, match="written as YAML: give a path ending .yaml"):   # nor YAML under .csv
        fit.save(mine)
    with pytest.raises(InputError, match="would replace the input"):
        bpmid.predict([mine], fit).save(tmp_path)
    assert mine.read_bytes() == before and not (tmp_path / "predict.yaml").exists()
    fit.save(tmp_path / "VBMM.yaml")   # any other name is fine
    log = bpmid.read_motion_logs([src])[0]
    a = bpmid.from_arrays(log.time_s, log.pressure_pa, pressure_unit="Pa", reference="gauge")
    b = bpmid.from_arrays(log.time_s, log.pressure_pa * 1.01, pressure_unit="Pa", reference="gauge")
    with pytest.raises(InputError, match="share the file name 'log'"):
        bpmid.predict([a, b], fit)
    for bad in ("../escaped", "a/b", "", ".."):
        with pytest.raises(InputError, match="plain file stem"):
            bpmid.from_arrays(log.time_s, log.pressure_pa, pressure_unit="Pa", reference="gauge", name=bad)
    with pytest.raises(InputError, match="finite"):
        bpmid.from_arrays(np.r_[log.time_s[:-1], np.inf], log.pressure_pa, pressure_unit="Pa", reference="gauge")
    assert bpmid.from_arrays(log.time_s, log.pressure_pa / 1e5, pressure_unit=" bar ", reference="gauge").n == log.n
    both = tmp_path / "both"
    bpmid.predict([a], fit).save(both)
    (both / "compare.yaml").write_text((tmp_path / "VBMM.yaml").read_text().replace("bpmid.vbmm/1", "bpmid.compare/1"))
    with pytest.raises(InputError, match="holds 2 results"):
        bpmid.load(both)


def test_plotting_leaves_the_callers_matplotlib_as_it_was(relax, tmp_path):
    """.plot() and .save(figure=...) keep the caller's backend and rcParams and leave no pyplot figure open
    (a notebook keeps its inline backend and its own style)."""
    import matplotlib
    import matplotlib.pyplot as plt

    backend0 = matplotlib.get_backend()
    plt.switch_backend("svg")   # stand-in for a notebook's inline backend
    try:
        with matplotlib.rc_context({"lines.linewidth": 3.25, "font.size": 13.5}):
            rc0 = {k: str(v) for k, v in matplotlib.rcParams.items()}
            open0 = plt.get_fignums()
            figs = [relax.plot() for _ in range(3)]
            relax.save(tmp_path / "r.yaml", figure=True)
            changed = [k for k, v in matplotlib.rcParams.items() if str(v) != rc0[k] and k != "backend"]
            assert matplotlib.get_backend() == "svg" and plt.get_fignums() == open0 and changed == []
            assert all(f.axes for f in figs) and (tmp_path / "r.png").stat().st_size > 1000
    finally:
        plt.switch_backend(backend0)


def test_results_of_shear_data_fitted_from_files_and_bad_settings(tmp_path):
    """A loaded result saves its figure too (figure=True beside it as .png); constants a relaxation fit barely fixes
    are not called estimated; settings of the wrong type are InputErrors naming the key."""
    relax = bpmid.fit_relaxation(sorted(glob.glob(str(REPO / "datasets/relaxation/*.csv")))[:2])
    relax.save(tmp_path / "r.yaml")
    back = bpmid.load(tmp_path / "r.yaml")
    back.save(tmp_path / "r2.yaml", figure=True)
    assert (tmp_path / "r2.png").stat().st_size > 1000
    for p in back.params.values():
        if p.identifiability == "estimated" and p.stderr is not None and p.value:
            assert p.stderr / abs(p.value) <= 0.5, p
    src = (REPO / "datasets/reference/pyvisco-frequency/freq_user_master.csv").read_text().splitlines()
    src[0] = src[0].replace("E_stor", "G_stor").replace("E_loss", "G_loss")
    (tmp_path / "G_master.csv").write_text("\n".join(src) + "\n")
    with pytest.warns(bpmid.BpmidWarning, match="Poisson's ratio is the default"):   # a glassy polymer's moduli
        g = bpmid.fit_relaxation([tmp_path / "G_master.csv"], terms=6)
    assert g.params["G_inf"].identifiability in ("estimated",) or g.params["G_inf"].identifiability.startswith("not")
    assert g.params["E_inf"].identifiability == "derived (Poisson's ratio)"
    assert g.params["G_1"].identifiability != "derived (Poisson's ratio)"
    with pytest.raises(InputError, match="kp_bar_per_deg"):
        bpmid.control(None, reference="steps", kp_bar_per_deg="x")
    with pytest.raises(InputError, match="seed"):
        bpmid.simulate("fitting_set", seed="x")


def test_calls_that_read_files_say_so_for_other_inputs():
    log = bpmid.read_motion_logs(sorted(glob.glob(str(REPO / "datasets/motion/fitting_set/*.csv")))[:1])
    with pytest.raises(InputError, match="must be file paths"):
        bpmid.compare(train=log, test=log)
    with pytest.raises(InputError, match="must be file paths"):
        bpmid.fit_relaxation(log)
    with pytest.raises(InputError, match="init must be a relaxation fit"):
        bpmid.fit_motion(log, init=3)
    with pytest.raises(InputError, match="init is a bpmid.vbmm/1 or bpmid.relax/1 file") as e:
        bpmid.discover(log, init={"K_inf": 1})
    assert e.value.key == "init"
    with pytest.raises(InputError, match="no logs given") as e:
        bpmid.discover(log, holdout=[])
    assert e.value.key == "holdout"
    # a config as the mapping a YAML file holds: read, its keys checked as a file's are
    with pytest.raises(InputError) as e:
        bpmid.discover(log, config={"discover": {"max_efects": 1}})
    assert e.value.key == "discover.max_efects"


def test_a_conditional_standard_error_is_shown_with_the_estimate():
    from bpmid.results import Parameters, ParamInfo, _entry

    e = _entry("K_1", {"value": 1.3e7, "stderr": 1.3e6, "unit": "Pa", "identifiable": True,
                       "note": "standard error conditional on the held tau_1 (r = -0.995 while it was free) at its "
                               "prior value: the data determine a combination of them"}, "Pa", "estimated")
    assert e.identifiability == "estimated" and "conditional" in e.note
    table = Parameters([e, ParamInfo("K_inf", 6.6e6, 7e4, "Pa", "estimated")]).table()
    assert "[estimated]  (standard error conditional on the held tau_1" in table
    assert table.count("conditional") == 1



def test_a_saved_results_inputs_are_known_by_content_wherever_it_is_saved_from(tmp_path, monkeypatch):
    """A fit made in another folder records its inputs by relative paths: saved from here over its starting fit,
    that input is still refused (by its content), and an unrelated file of the same name here is not."""
    import shutil

    from typer.testing import CliRunner

    from bpmid.cli import app

    w = tmp_path / "w"
    w.mkdir()
    shutil.copy(sorted(glob.glob(str(REPO / "datasets/motion/fitting_set/*.csv")))[0], w / "b.csv")
    monkeypatch.chdir(w)
    relax = sorted(glob.glob(str(REPO / "datasets/relaxation/relax_*_[23]0pct.csv")))
    assert CliRunner().invoke(app, ["fit", "relax", *relax, "--out", "r.yaml", "--no-figure"]).exit_code == 0
    assert CliRunner().invoke(app, ["fit", "motion", "b.csv", "--init", "r.yaml", "--out", "fit.yaml",
                                    "--no-plot"]).exit_code == 0
    monkeypatch.chdir(tmp_path)
    before = (w / "r.yaml").read_bytes()
    with pytest.raises(InputError, match="would replace the input"):
        bpmid.load("w/fit.yaml").save("w/r.yaml")
    assert (w / "r.yaml").read_bytes() == before
    (tmp_path / "r.yaml").write_text("an unrelated file\n")
    bpmid.load("w/fit.yaml").save("r.yaml")   # not the input: replaced as asked


def test_help_on_a_workflow_shows_the_call_first():
    for name in ("predict", "compare", "control", "discover"):
        doc = getattr(bpmid, name).__doc__
        assert doc.startswith(f"bpmid.{name}(") and "Returns" in doc and f"The module bpmid.{name}" in doc, name


def test_a_library_callers_error_names_the_config_key_of_each_reading_flag(tmp_path):
    """Outside a command, an error that names a reading flag also names the config key a script sets; following
    it reads the file. A command's own error names only its flags."""
    from typer.testing import CliRunner

    from bpmid.cli import app

    f = tmp_path / "bare.csv"
    f.write_text("t,p,a\n0,0.1,1\n0.1,0.5,3\n0.2,0.9,5\n")
    with pytest.raises(InputError) as e:
        bpmid.read_motion_logs([f])
    msg = str(e.value)
    assert "--pressure-unit" in msg and "--pressure-unit is io.units.pressure" in msg
    assert "--time-unit is io.units.time" in msg and "config={'io'" in msg and msg.count("from Python") == 1
    io = {"units": {"time": "s", "pressure": "bar", "angle": "deg"}, "pressure_reference": "gauge",
          "columns": {"t": "time", "p": "pressure", "a": "angle"}}
    (log,) = bpmid.read_motion_logs([f], config={"io": io})
    np.testing.assert_allclose(log.pressure_pa, [1e4, 5e4, 9e4])
    r = CliRunner().invoke(app, ["fit", "motion", str(f), "--out", str(tmp_path / "m.yaml")])
    assert r.exit_code == 2 and "--columns" in r.output and "from Python" not in r.output


def test_io_strict_in_the_config_refuses_the_warnings_as_the_command_does(tmp_path):
    """config io.strict (the CLI's --strict) raises on a warning in the library too; without it, a BpmidWarning."""
    import warnings as _w

    rad = REPO / "tests" / "data" / "rig_logs" / "radians_in_deg_column.csv"
    strict = {"io": {"strict": True}}
    with pytest.raises(bpmid.InputError, match="the motion fit was refused: 1 warning") as e:
        bpmid.fit_motion([rad], config=strict)
    assert e.value.key == "io.strict" and "radians" in str(e.value)
    with _w.catch_warnings(record=True) as got:
        _w.simplefilter("always")
        fit = bpmid.fit_motion([rad])
    assert any(issubclass(x.category, bpmid.BpmidWarning) and "radians" in str(x.message) for x in got)
    with pytest.raises(bpmid.InputError, match="the prediction was refused"):
        bpmid.predict([rad], fit, config=strict)
    with pytest.raises(bpmid.InputError, match="the discovery was refused"):
        bpmid.discover([rad], config=strict)


def test_a_table_passed_as_logs_or_reference_is_told_how_it_goes_in(tmp_path):
    """A DataFrame or an array where logs are asked: the message says from_arrays (iterating a DataFrame gave
    its column names, read as missing files); a relaxation fit not yet saved, given to compare: save it first."""
    import pandas as pd

    df = pd.DataFrame({"time_s": [0.0, 1.0], "pressure_kpa": [0.0, 1.0], "angle_deg": [0.0, 1.0]})
    for call in (lambda: bpmid.fit_motion(df), lambda: bpmid.predict(df, bpmid.VBMM()), lambda: bpmid.discover(df),
                 lambda: bpmid.fit_motion(df.to_numpy())):
        with pytest.raises(bpmid.InputError, match="found (DataFrame|ndarray); a table of samples goes in through "
                                                   r"bpmid.from_arrays") as e:
            call()
        assert e.value.key == "logs" and "not found" not in str(e.value)
    with pytest.raises(bpmid.InputError, match="relaxation logs must be file paths .* found DataFrame"):
        bpmid.fit_relaxation(df)
    with pytest.raises(bpmid.InputError, match="reference is a shipped reference's name.* found DataFrame"):
        bpmid.control(bpmid.VBMM(), reference=df)
    relax = bpmid.fit_relaxation(sorted(glob.glob(str(REPO / "datasets/relaxation/relax_*_[23]0pct.csv"))))
    with pytest.raises(bpmid.InputError, match=r"not saved to a file.*relax.save\('relax_fit.yaml'\)"):
        bpmid.compare(relax=relax)


def test_model_of_a_fit_with_effects_says_they_are_left_out(timed_small_study, tmp_path):
    """.model is the constants only: on discover's model.yaml (effects named) a BpmidWarning says so; on a plain
    fit nothing is said."""
    import warnings as _w

    with_fx = bpmid.load(Path(timed_small_study) / "discover" / "model.yaml")
    plain = bpmid.load(Path(timed_small_study) / "vbmm_fit.yaml")
    with _w.catch_warnings(record=True) as got:
        _w.simplefilter("always")
        plain.model
        plain.plot()
    assert not [x for x in got if issubclass(x.category, bpmid.BpmidWarning)]
    assert with_fx.body.get("effects") == []      # the small study names none: give the fit one
    import yaml

    body = yaml.safe_load((Path(timed_small_study) / "vbmm_fit.yaml").read_text())
    body["effects"] = [{"id": "pressure_lag", "parameters": {"tau": 0.1}}]
    lagged = tmp_path / "lagged.yaml"
    lagged.write_text(yaml.safe_dump(body))
    with pytest.warns(bpmid.BpmidWarning, match=r"this fit has effects \(pressure_lag\) that .model leaves out"):
        bpmid.load(lagged).model


def test_results_and_configs_pickle(tmp_path):
    """A config's read-only mappings were MappingProxyType, which does not pickle: a fresh DiscoveryResult (it
    keeps its config) could not go to another process. They are a read-only mapping that pickles now."""
    import pickle

    from bpmid.config import FrozenMap, load_config

    cfg_file = tmp_path / "c.yaml"
    cfg_file.write_text("io:\n  columns: {Zeit: time_s}\ndiscover:\n  max_effects: 1\n")
    cfg = load_config(cfg_file)
    back = pickle.loads(pickle.dumps(cfg))
    assert back.section("io").columns == {"Zeit": "time_s"} and back.section("discover").max_effects == 1
    assert isinstance(back.sections, FrozenMap)
    with pytest.raises(TypeError):
        cfg.section("io").columns["Zeit"] = "x"          # still read-only
    fit = bpmid.fit_motion(sorted(glob.glob(str(REPO / "datasets/motion/fitting_set/*.csv")))[:1])
    assert pickle.loads(pickle.dumps(fit)) == fit


def test_library_errors_name_the_argument_not_the_option():
    """Outside the command line, an error about --models or --reference names the call's argument."""
    with pytest.raises(bpmid.InputError) as e:
        bpmid.model_class("foo")
    assert e.value.key == "models" and "key 'models'" in str(e.value)


def test_summaries_of_a_simulation_and_a_prediction_say_what_they_hold():
    """A simulation's summary named no protocol, seed or logs; a prediction's listed no log."""
    sim = bpmid.load(REPO / "datasets" / "motion" / "fitting_set")
    text = sim.summary()
    assert "protocol: fitting_set (motion)" in text and "seed: 1001" in text and "logs: 3" in text
    assert "synthetic: made by bpmid's digital twin" in text
    assert "seed: none (designed signals" in bpmid.load(REPO / "datasets" / "control").summary()
    logs = sorted(glob.glob(str(REPO / "datasets/motion/fitting_set/*.csv")))
    pred = bpmid.predict(logs[:2], bpmid.VBMM())
    assert "[[Logs]]" in pred.summary() and "RMSE" in pred.summary().split("[[Logs]]")[1]


def test_a_loaded_fit_with_effects_shows_them_with_their_constants_and_units(tmp_path, timed_small_study):
    """discover's model.yaml runs the VBMM with pressure_lag, and its RMSE includes the lag: loaded, its summary,
    repr and .params showed the five VBMM constants only (new-user trial)."""
    import yaml

    body = yaml.safe_load((Path(timed_small_study) / "discover" / "model.yaml").read_text())
    body["effects"] = [{"id": "pressure_lag", "settings": {"dead_time": 0.0}, "parameters": {
        "tau": {"value": 0.09, "stderr": None, "unit": "s", "fixed": True, "identifiable": False,
                "note": "not identifiable: relative standard error 53% > 50%; kept at 0.09, its start"},
        "share": 0.5}}]   # a bare number takes the catalogue's unit
    (tmp_path / "model.yaml").write_text(yaml.safe_dump(body, sort_keys=False))
    res = bpmid.load(tmp_path / "model.yaml")
    assert res.effects == ["pressure_lag"]
    tau = res.params["pressure_lag.tau"]
    assert tau.value == 0.09 and tau.unit == "s" and tau.identifiability.startswith("not identifiable: relative")
    assert res.params["pressure_lag.share"].unit == "1" and "K_inf" in res.params
    assert "with effects pressure_lag" in repr(res) and len(repr(res)) < 300
    text = res.summary()
    assert "pressure_lag.tau   =         0.09 s  [not identifiable" in text
    effects = text.split("[[Effects]]")[1]
    assert "pressure_lag: constants pressure_lag.tau, pressure_lag.share" in effects
    assert "settings dead_time = 0 s" in effects and "the fit statistics above include them" in effects
    assert "pressure_lag.tau" in res._repr_html_()
    plain = bpmid.load(Path(timed_small_study) / "vbmm_fit.yaml")   # a fit without effects says nothing of them
    assert plain.effects == [] and "[[Effects]]" not in plain.summary() and "effects" not in repr(plain)


def test_model_with_effects_and_a_bad_scale(tmp_path, timed_small_study):
    import warnings as _w

    import yaml

    body = yaml.safe_load((Path(timed_small_study) / "vbmm_fit.yaml").read_text())
    body["effects"] = [{"id": "pressure_lag", "parameters": {"tau": 0.1}}]
    (tmp_path / "lag.yaml").write_text(yaml.safe_dump(body))
    res = bpmid.load(tmp_path / "lag.yaml")
    with _w.catch_warnings():
        _w.simplefilter("error")            # the advised call says nothing
        m = res.model_with_effects
    assert type(m).__name__ == "AugmentedVBMM"
    t = np.arange(0.0, 5.0, 0.1)
    with pytest.raises(bpmid.InputError, match="modulus scale must be one positive finite number"):
        bpmid.VBMM().forward(t, np.full(t.size, 4e4), scale=np.where(t > 2, np.nan, 1.0))


@pytest.mark.parametrize("effects", [[None], 1, "x", [{"id": "a", "params": 3}], [{"id": "a", "params": {"w": 1.0}}]])
def test_a_simulation_manifest_with_malformed_effects_still_loads_and_gives_its_params(effects, tmp_path):
    """Hypothesis found these (effects: [None], effects: 1): .params raised AttributeError/TypeError."""
    from bpmid.results import SimulationResult

    res = SimulationResult({"effects": effects}, {"bpmid_version": "0.1.0", "command": "", "inputs": {}})
    res.save(tmp_path / "out")
    back = load(tmp_path / "out")
    assert back == res and back.params.valuesdict() == res.params.valuesdict()
    assert list(res.params.valuesdict()) == (["a.w"] if effects == [{"id": "a", "params": {"w": 1.0}}] else [])


def test_from_arrays_names_the_array_and_the_index_of_a_bad_sample():
    """A NaN pressure said only 'pressure and angle must be finite numbers', and one time going backwards among
    100 said 'time_s must hold at least two strictly increasing times': neither which array nor where."""
    t = np.arange(0.0, 10.0, 0.1)
    p = 1.2 + 0.3 * np.abs(np.sin(0.3 * t))
    bad = p.copy()
    bad[20] = np.nan
    with pytest.raises(InputError, match=r"pressure must be finite numbers: pressure\[20\] is nan"):
        bpmid.from_arrays(t, bad, None, pressure_unit="bar", reference="absolute")
    with pytest.raises(InputError, match=r"angle_deg\[51\] is inf"):
        bpmid.from_arrays(t, p, np.where(t > 5.05, np.inf, 1.0), pressure_unit="bar", reference="absolute")
    back = t.copy()
    back[30] = back[29] - 0.05
    with pytest.raises(InputError, match=r"goes backwards at time_s\[30\] \(2\.9 s then 2\.85 s\)"):
        bpmid.from_arrays(back, p, None, pressure_unit="bar", reference="absolute")
    rep = t.copy()
    rep[30] = rep[29]
    with pytest.raises(InputError, match=r"repeats at time_s\[30\]"):
        bpmid.from_arrays(rep, p, None, pressure_unit="bar", reference="absolute")
    with pytest.raises(InputError, match="at least two samples, found 1"):
        bpmid.from_arrays(t[:1], p[:1], None, pressure_unit="bar", reference="absolute")
