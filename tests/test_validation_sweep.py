"""Sweeps on Dask (bpmid.validation.sweep) and ``bpmid calibrate``: streaming, resume, calibration, tables."""
import json
import shutil
from pathlib import Path

import pytest
import yaml
from typer.testing import CliRunner

from bpmid.cli import app
from bpmid.validation.sweep import (RECORDS, code_fingerprint, comparable, load_sweep, read_records, run_sweep,
                                   summarize)

REPO = Path(__file__).resolve().parents[1]
TINY = REPO / "configs" / "sweeps" / "tiny.yaml"


@pytest.fixture(scope="module")
def full_run(tmp_path_factory):
    """The tiny sweep run once without interruption (a real LocalCluster, two workers)."""
    out = tmp_path_factory.mktemp("sweep_full")
    res = run_sweep(load_sweep(TINY), out, workers=2, processes=False)
    return out, res


def test_uninterrupted_sweep_writes_records_thresholds_tables_answers(full_run):
    out, res = full_run
    assert res.complete
    recs = read_records(out / RECORDS)
    cases = {r["id"] for r in recs}
    assert len(recs) == 4 and len(cases) == 4
    assert {r["split"] for r in recs} == {"calibration", "heldout"}
    assert all(r["phase"] == r["split"] for r in recs)
    thr = yaml.safe_load((out / "thresholds.yaml").read_text())
    assert thr["schema"] == "bpmid.discover-thresholds/1" and "tiny" in thr["calibration"]["produced_by"]
    assert res.summary["thresholds_from"].startswith("thresholds.yaml, calibrated in this run")   # its source, said
    # the calibration half's candidates were recorded with their truth
    cal = [r for r in recs if r["split"] == "calibration"]
    assert sum(len(r["calibration_records"]) for r in cal) >= 2
    # ... and the first round's pair trials (a list per case, empty when fewer than two leaders were tested)
    assert all(isinstance(r["calibration_pairs"], list) for r in cal)
    assert all(set(q) >= {"first", "second", "gap_share", "min_gain_given_other", "p_corrected"}
               for r in cal for q in r["calibration_pairs"])
    assert {"pair_share_min", "pair_gain_min_sigma", "identifiable_waived_above_sigma"} <= set(thr)
    # tables: every held-out case counted once, rows by hidden truth
    csv = (out / "confusion.csv").read_text().splitlines()
    assert csv[0].startswith("hidden_truth,named_first_second_relaxation")
    n_ho = sum(1 for r in recs if r["split"] == "heldout")
    assert sum(int(v) for line in csv[1:] for v in line.split(",")[1:]) == n_ho
    md = (out / "confusion.md").read_text()
    assert "false positives on nulls" in md and "| hidden \\ named |" in md
    # answers per split, apart from the records; they hold the truth of exactly that half
    for split in ("calibration", "heldout"):
        ans = yaml.safe_load((out / "answers" / f"{split}.yaml").read_text())
        assert set(ans["cases"]) == {r["id"] for r in recs if r["split"] == split}
        assert all(v["split"] == split for v in ans["cases"].values())


def test_interrupted_sweep_resumes_to_the_same_records(full_run, tmp_path):
    out_full, _ = full_run
    cfg = load_sweep(TINY)
    said, seen = [], []

    def progress(msg):   # a Ctrl-C right after the second record was written
        seen.append(msg)
        if sum(m.startswith("[") for m in seen) == 2:
            raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        run_sweep(cfg, tmp_path, workers=2, processes=False, progress=progress, warn=said.append)
    lines = (tmp_path / RECORDS).read_text().splitlines()
    assert len(lines) == 2
    # it says what it kept (the count once left out the running half's records) and how to go on
    assert any("interrupted: the 2 finished case(s) are kept" in m and "rerun the same command" in m for m in said)
    res = run_sweep(cfg, tmp_path, workers=2, processes=False, stop_after=0)   # the other way to stop: at once
    assert not res.complete and len((tmp_path / RECORDS).read_text().splitlines()) == 2
    with open(tmp_path / RECORDS, "a") as fh:  # a write torn by the interruption
        fh.write('{"id": "tiny-00')
    res2 = run_sweep(cfg, tmp_path, workers=2, processes=False)
    assert res2.complete
    resumed = read_records(tmp_path / RECORDS)
    assert len(resumed) == 4  # the torn line is gone, nothing ran twice
    assert comparable(resumed) == comparable(read_records(out_full / RECORDS))
    assert (tmp_path / "confusion.csv").read_text() == (out_full / "confusion.csv").read_text()
    # a third run has nothing left to do and does not start a cluster
    res3 = run_sweep(cfg, tmp_path, workers=2, processes=False)
    assert comparable(res3.records) == comparable(resumed)


def test_a_case_run_with_other_discover_settings_is_rerun(full_run, tmp_path):
    out_full, _ = full_run
    out = tmp_path / "copy"
    shutil.copytree(out_full, out)
    recs = read_records(out / RECORDS)
    ho = sorted(r["id"] for r in recs if r["split"] == "heldout")
    lines = []
    for r in recs:
        if r["id"] == ho[0]:
            r = dict(r, discover_settings=dict(r["discover_settings"], lr_p_max=0.5), named=["stale"])
        lines.append(json.dumps(r))
    (out / RECORDS).write_text("\n".join(lines) + "\n")
    res = run_sweep(load_sweep(TINY), out, workers=2, processes=False)
    again = read_records(out / RECORDS)
    # rerun, and the finished sweep keeps one record per case, the new one (a rescore left 38 lines for 24 cases)
    assert len(again) == 4 and [r["id"] for r in again].count(ho[0]) == 1
    assert next(r for r in again if r["id"] == ho[0])["named"] != ["stale"]
    assert comparable(res.records) == comparable(read_records(out_full / RECORDS))


def test_pool_runs_both_halves_as_calibration(full_run, tmp_path):
    """``split="pool"``: every case runs with the calibration half's permissive settings and calibrates (a draw
    whose held-out half was looked at still calibrates); nothing is scored as held out."""
    out_full, _ = full_run
    shutil.copytree(out_full, tmp_path, dirs_exist_ok=True)   # the calibration half is reused, as it ran alike
    shutil.rmtree(tmp_path / "answers")
    res = run_sweep(load_sweep(TINY), tmp_path, split="pool", workers=2, processes=False)
    recs = list({r["id"]: r for r in read_records(tmp_path / RECORDS)}.values())   # a rerun case: latest wins
    assert len(recs) == 4 and {r["phase"] for r in recs} == {"calibration"}
    assert {r["split"] for r in recs} == {"calibration", "heldout"}
    assert all(r["calibration_records"] for r in recs)
    first = {r["id"]: r for r in read_records(out_full / RECORDS)}
    for r in recs:   # held-out cases rerun with the permissive settings, calibration cases kept
        assert (r["discover_settings"] == first[r["id"]]["discover_settings"]) == (r["split"] == "calibration")
    thr = yaml.safe_load((tmp_path / "thresholds.yaml").read_text())
    assert "4 out-of-family cases" in thr["calibration"]["data"]
    ans = yaml.safe_load((tmp_path / "answers" / "calibration.yaml").read_text())["cases"]
    assert {k: v["split"] for k, v in ans.items()} == {r["id"]: r["split"] for r in recs}
    assert not (tmp_path / "answers" / "heldout.yaml").exists() and res.thresholds is not None
    bad = CliRunner().invoke(app, ["calibrate", str(TINY), "--out", str(tmp_path / "x"), "--split", "half"])
    assert bad.exit_code == 2 and "calibration, heldout, all or pool" in bad.output


def test_summary_rates():
    base = {"error": None, "unexplained": False, "noise_floor_deg": 0.1, "heldout_before_deg": 0.5,
            "heldout_after_deg": 0.2}
    recs = [dict(base, id="a", kind="single", truth_label="pressure_lag", truth_ids=["pressure_lag"],
                 named=["pressure_lag"]),
            dict(base, id="b", kind="null", truth_label="none", truth_ids=[], named=["angle_offset"],
                 heldout_after_deg=0.45),
            dict(base, id="c", kind="null", truth_label="none", truth_ids=[], named=[]),
            dict(base, id="d", kind="pair", truth_label="pair", truth_ids=["angle_offset", "braid_friction"],
                 named=["braid_friction", "angle_offset"]),
            dict(base, id="e", kind="out_of_catalogue", truth_label="out_of_catalogue", truth_ids=["mullins"],
                 named=[], unexplained=True)]
    s = summarize(recs, "heldout")
    assert s["single_named_first_right"]["rate"] == 1.0
    assert s["null_false_positive"]["rate"] == 0.5
    assert s["pair_both_named"]["rate"] == 1.0
    assert s["out_of_catalogue_nothing_named"]["rate"] == 1.0
    assert s["gap_halved_where_named"] == {"n": 3, "halved": 2, "rate": round(2 / 3, 4)}
    assert s["confusion"]["none"]["angle_offset"] == 1 and s["confusion"]["pair"]["braid_friction"] == 1
    # no true noise in these records: no case has a size a user sees
    assert all(c["n"] == 0 for row in s["by_visible_size"].values() for c in row.values())


def test_outcomes_by_the_size_a_user_sees():
    from bpmid.validation.sweep import SIZE_BANDS, by_visible_size, confusion_markdown, summarize

    def rec(i, kind, named, before, truth=("pressure_lag",), **kw):
        label = {"single": truth[0], "null": "none"}.get(kind, kind)
        return dict({"id": str(i), "kind": kind, "truth_label": label,
                     "truth_ids": list(truth) if kind in ("single", "pair") else [], "named": list(named),
                     "error": None, "unexplained": not named, "noise_floor_deg": 0.1, "noise_deg": 0.1,
                     "heldout_before_deg": before, "heldout_after_deg": 0.1}, **kw)
    recs = [rec(0, "single", [], 0.105), rec(1, "single", ["pressure_lag"], 0.11),     # below 1.2: 1 of 2
            rec(2, "single", ["angle_offset"], 0.13),                                   # 1.2-1.5: wrong name
            rec(3, "pair", ["braid_friction", "angle_offset"], 0.2, truth=("angle_offset", "braid_friction")),
            rec(4, "pair", ["braid_friction"], 0.16, truth=("angle_offset", "braid_friction")),
            rec(5, "null", [], 0.1), rec(6, "out_of_catalogue", ["angle_offset"], 0.12),
            rec(7, "single", ["pressure_lag"], None, error="cannot judge")]            # not judged: in no band
    b = by_visible_size(recs)
    low, mid, high = (name for _, _, name in SIZE_BANDS)
    assert b["single"][low] == {"n": 2, "right": 1, "rate": 0.5}
    assert b["single"][mid] == {"n": 1, "right": 0, "rate": 0.0} and b["single"][high]["n"] == 0
    assert b["pair"][high] == {"n": 2, "right": 1, "rate": 0.5}
    assert b["null"][low]["right"] == 1 and b["out_of_catalogue"][mid] == {"n": 1, "right": 0, "rate": 0.0}
    md = confusion_markdown(summarize(recs, "heldout"))
    assert "| single effect named first right | 1/2 (50 %) | 0/1 (0 %) | - |" in md
    assert "| pair: both named | - | - | 1/2 (50 %) |" in md


def test_cli_calibrate_resumes_a_finished_folder_and_rejects_bad_configs(full_run, tmp_path):
    runner = CliRunner()
    out_full, _ = full_run
    out = tmp_path / "again"
    shutil.copytree(out_full, out)
    (out / "confusion.md").unlink()
    r = runner.invoke(app, ["--quiet", "calibrate", str(TINY), "--out", str(out)])
    assert r.exit_code == 0, r.output
    assert "Confusion matrix, heldout half" in r.output and (out / "confusion.md").exists()
    # without --quiet, progress goes to stderr as whole lines even when it is not a terminal (a log file)
    r = runner.invoke(app, ["calibrate", str(TINY), "--out", str(out)])
    assert r.exit_code == 0 and "[bpmid] heldout half:" in r.stderr and "0 to run" in r.stderr
    assert "[bpmid]" not in r.stdout and "\r" not in r.stderr
    # a bad key names itself, exit 2
    bad = tmp_path / "bad.yaml"
    bad.write_text(TINY.read_text().replace("  duration_scale: 0.08", "  duration_scael: 0.08"))
    r = runner.invoke(app, ["calibrate", str(bad), "--out", str(tmp_path / "x")])
    assert r.exit_code == 2 and "generator.duration_scael" in r.output
    bad.write_text(TINY.read_text().replace("max_effects: 1, n_confirm: 2, min_fit_samples: 100}\nevaluation",
                                            "max_effect: 1, n_confirm: 2, min_fit_samples: 100}\nevaluation"))
    r = runner.invoke(app, ["calibrate", str(bad), "--out", str(tmp_path / "x")])
    assert r.exit_code == 2 and "calibration.discover.max_effect" in r.output
    bad.write_text("sweep: {seed: 1}\nnoise: 0.2\n")
    r = runner.invoke(app, ["calibrate", str(bad), "--out", str(tmp_path / "x")])
    assert r.exit_code == 2 and "noise" in r.output and "unknown section" in r.output
    r = runner.invoke(app, ["calibrate", str(TINY), "--out", str(tmp_path / "x"), "--split", "half"])
    assert r.exit_code == 2 and "--split" in r.output
    # another config into a folder holding a sweep: refused, not mixed
    other = tmp_path / "other.yaml"
    other.write_text(TINY.read_text().replace("seed: 3", "seed: 4"))
    r = runner.invoke(app, ["calibrate", str(other), "--out", str(out)])
    assert r.exit_code == 2 and "another config" in r.output
    r = runner.invoke(app, ["calibrate", "--help"], env={"COLUMNS": "400"})
    text = " ".join(r.output.split())
    assert r.exit_code == 0 and "Example" in text and "bpmid calibrate configs/sweeps/small.yaml" in text


def test_shipped_sweep_configs_load_and_are_big_enough():
    from bpmid.validation import make_cases
    for name in ("tiny", "small", "full"):
        cfg = load_sweep(REPO / "configs" / "sweeps" / f"{name}.yaml")
        cases = make_cases(cfg.effective_generator, cfg.sweep.seed, prefix=cfg.sweep.name)
        assert len(cases) == cfg.generator.n_cases
    full = make_cases(load_sweep(REPO / "configs" / "sweeps" / "full.yaml").effective_generator,
                      load_sweep(REPO / "configs" / "sweeps" / "full.yaml").sweep.seed, prefix="full")
    ho = [c for c in full if c.split == "heldout"]
    assert len(full) >= 200 and len(ho) >= 100
    assert sum(c.kind == "null" for c in ho) >= 20
    assert {c.kind for c in ho} == {"single", "null", "pair", "out_of_catalogue"}
    assert {c.geometry.name for c in ho} >= {"paper", "slim", "wide"}
    assert {e.effect for c in ho if c.kind == "single" for e in c.effects} == set(json.loads(json.dumps(
        list(load_sweep(REPO / "configs" / "sweeps" / "full.yaml").generator.effects))))


def test_rig_section_sets_noise_rate_and_geometry(tmp_path):
    from bpmid.validation import make_cases
    cfg_path = tmp_path / "rig.yaml"
    cfg_path.write_text(TINY.read_text() + "rig: {noise_deg: 0.25, noise_ar1_rho: 0.6, sampling_hz: 40, "
                        "pressure_unit: psi, pressure_noise_pa: 60, geometry: {name: mine, th_mm: 1.8, "
                        "alpha0_deg: 28, R0_mm: 14, l0_mm: 170, n: 6.5}}\n")
    cfg = load_sweep(cfg_path)
    cases = make_cases(cfg.effective_generator, cfg.sweep.seed, prefix="rig")
    assert {(c.noise_deg, c.noise_rho, c.fs_hz, c.pressure_unit, c.geometry.name, c.pressure_noise_pa)
            for c in cases} == {(0.25, 0.6, 40.0, "psi", "mine", 60.0)}
    cfg_path.write_text(TINY.read_text() + "rig: {noise_deg: -1}\n")
    from bpmid.errors import InputError
    with pytest.raises(InputError) as e:
        load_sweep(cfg_path)
    assert "rig.noise_deg" in e.value.format()


def test_calibration_section_fills_every_gate_key_it_does_not_set_permissively(tmp_path):
    # a section written before fit_share_min and the later-round gain existed: the shipped values of those must
    # not be applied to the run that records the statistics they are calibrated from
    from bpmid.discover.calibrate import PERMISSIVE
    from bpmid.validation.sweep import load_sweep

    p = tmp_path / "sweep.yaml"
    p.write_text("sweep: {name: t, seed: 1}\ngenerator: {n_cases: 4}\n"
                 "calibration:\n  discover: {heldout_gain_min_sigma: -1.0e+9, gap_share_min: 0.0, max_effects: 1}\n")
    cfg = load_sweep(p).discover_config("calibration")
    assert cfg.fit_share_min == PERMISSIVE["fit_share_min"] == 0.0
    assert cfg.heldout_gain_min_sigma_later == PERMISSIVE["heldout_gain_min_sigma_later"]
    assert cfg.family_alpha == PERMISSIVE["family_alpha"]
    assert cfg.max_effects == 1                       # what the section sets wins
    # the permissive run records the pair trials and asks condition (4) as the old records did
    assert cfg.record_pair_trials is True and cfg.identifiable_waived_above_sigma == float("inf")
    # the held-out half is not touched: the calibrated gate applies there
    ev = load_sweep(p).discover_config("heldout", {"fit_share_min": 0.3})
    assert ev.fit_share_min == 0.3
    # a first-round gain the section sets without the later one sets both (as everywhere else)
    p.write_text("sweep: {name: t, seed: 1}\ngenerator: {n_cases: 4}\n"
                 "calibration:\n  discover: {heldout_gain_min_sigma: 0.1}\n")
    cfg = load_sweep(p).discover_config("calibration")
    assert cfg.heldout_gain_min_sigma == cfg.heldout_gain_min_sigma_later == 0.1
    assert cfg.fit_share_min == 0.0


def test_a_calibration_case_rerun_on_its_own_is_the_same_run(full_run, tmp_path):
    """What the calibration reruns rest on (benchmarks/record_pair_trials.py, rerun_floor_cases.py): a case found
    by id in its config and rerun with the calibration settings writes the record the sweep wrote."""
    from bpmid.validation.sweep import calibration_records, cases_by_id, rerun_calibration

    out_full, _ = full_run
    old = calibration_records([out_full / RECORDS])
    cases = cases_by_id([TINY])
    assert old and set(old) < set(cases)          # the calibration half of the 4 tiny cases
    cid = sorted(old)[0]
    seen = []
    rerun_calibration([cases[cid]], tmp_path, workers=1, on_record=lambda r: seen.append(r["id"]), processes=False)
    new = read_records(tmp_path / RECORDS)
    assert seen == [cid] and len(new) == 1
    assert comparable(new) == comparable([old[cid]])


def test_the_table_never_rounds_a_rate_onto_a_target_it_misses():
    from bpmid.validation.sweep import COLUMNS, ROWS, confusion_markdown

    def part(k, n, **kw):
        return {"n": n, **kw, "rate": k / n}
    s = {"split": "heldout", "n_cases": 117, "not_judged": 0, "confusion": {r: {c: 0 for c in COLUMNS} for r in ROWS},
         "single_named_first_right": part(53, 59, right=53), "null_false_positive": part(0, 22, named_something=0),
         "pair_both_named": part(14, 17, both=14), "out_of_catalogue_nothing_named": part(16, 20, nothing=16),
         "gap_halved_where_named": part(71, 71, halved=71)}
    md = confusion_markdown(s)
    assert "| 53/59 (89.8 %) |" in md                 # not "90 %": the target is at least 90 %
    assert "| 16/20 (80 %) |" in md and "| 71/71 (100 %) |" in md and "| 0/22 (0 %) |" in md


# --- a rig user's review (a helper calibrating on its own rig, recounting every table from the records) ---------
def _rec(kind, truth, named, error=None):
    return {"id": f"{kind}-{truth}-{len(named)}-{error}", "kind": kind, "truth_label": truth,
            "truth_ids": [] if truth in ("none", "out_of_catalogue") else [truth], "named": named,
            "error": error, "error_kind": "declined" if error else None, "heldout_before_deg": 0.3,
            "heldout_after_deg": 0.2, "noise_floor_deg": 0.15, "noise_deg": 0.15}


def test_rates_count_judged_cases_only():
    """A case discovery declined named nothing without judging anything: it was counted as a null rightly left
    unnamed and as a missed single."""
    recs = [_rec("single", "angle_offset", ["angle_offset"]), _rec("single", "angle_offset", [], "too short"),
            _rec("null", "none", []), _rec("null", "none", [], "too short")]
    s = summarize(recs, "heldout")
    assert s["n_cases"] == 4 and s["judged"] == 2 and s["not_judged"] == 2
    assert s["single_named_first_right"] == {"n": 1, "right": 1, "rate": 1.0}
    assert s["null_false_positive"]["n"] == 1
    assert sum(sum(row.values()) for row in s["confusion"].values()) == 2
    from bpmid.validation.sweep import confusion_markdown

    assert "4 cases, 2 judged" in confusion_markdown(s)


def test_calibration_on_no_judged_case_is_refused_and_a_thin_one_warned(full_run, tmp_path):
    from bpmid.discover.calibrate import thresholds_from_records, write_thresholds
    from bpmid.errors import InputError
    from bpmid.validation.sweep import _calibrate

    cfg = load_sweep(TINY)
    declined = [_rec("single", "angle_offset", [], "fewer than 30 samples per log")] * 3
    with pytest.raises(InputError, match="no calibration case could be judged"):
        _calibrate(tmp_path, cfg, declined, thresholds_from_records, write_thresholds)
    assert not (tmp_path / "thresholds.yaml").exists()
    out, _ = full_run
    cal = [r for r in read_records(out / RECORDS) if r["phase"] == "calibration"]
    said = []
    _calibrate(tmp_path, cfg, cal, thresholds_from_records, write_thresholds, warn=said.append)
    assert (tmp_path / "thresholds.yaml").exists()
    assert len(said) == 2 and f"on {len(cal)} judged case(s)" in said[0] and "too few" in said[0]
    assert "closed paths the shipped gate has open" in said[1] and "no pair will be named" in said[1]
    # kept in the file, where discover repeats them to whoever uses it
    assert yaml.safe_load((tmp_path / "thresholds.yaml").read_text())["calibration"]["warnings"] == said


def test_a_bad_scheduler_is_refused_before_any_folder_is_made(tmp_path):
    from bpmid.errors import InputError

    with pytest.raises(InputError) as e:
        run_sweep(load_sweep(TINY), tmp_path / "o", scheduler="bogus-address")
    assert e.value.key == "--scheduler" and "LocalCluster" in str(e.value)
    assert not (tmp_path / "o").exists()


def test_workers_without_this_bpmid_are_named_not_waited_for():
    """A worker that cannot import bpmid died on the first case and the sweep waited forever, silently."""
    import importlib.metadata

    from bpmid import __version__
    from bpmid.errors import InputError
    from bpmid.validation.sweep import _check_workers

    class Client:   # the two questions asked of a cluster, answered as a cluster without bpmid answers them
        def __init__(self, wait_ok, answers):
            self.wait_ok, self.answers = wait_ok, answers

        def wait_for_workers(self, n, timeout):
            if not self.wait_ok:
                raise TimeoutError("no workers")

        def run(self, fn, *args, on_error):
            assert on_error == "return"
            if fn is code_fingerprint:   # asked only once every worker has this version
                return {w: prints.get(w, code_fingerprint()) for w in self.answers}
            assert fn is importlib.metadata.version and args == ("bpmid",)
            return self.answers

    prints = {}
    with pytest.raises(InputError, match="has no worker"):
        _check_workers(Client(False, {}), "tcp://h:1")
    with pytest.raises(InputError, match="has no bpmid"):
        _check_workers(Client(True, {"tcp://w1": __version__,
                                     "tcp://w2": importlib.metadata.PackageNotFoundError("bpmid")}), "tcp://h:1")
    with pytest.raises(InputError, match="has bpmid 0.0.1"):
        _check_workers(Client(True, {"tcp://w1": "0.0.1"}), "tcp://h:1")
    _check_workers(Client(True, {"tcp://w1": __version__}), "tcp://h:1")   # this bpmid everywhere: fine
    # the same version string on other code (another commit): named with both fingerprints
    prints = {"tcp://w2": "0123456789abcdef"}
    with pytest.raises(InputError, match="run other bpmid code") as e:
        _check_workers(Client(True, {"tcp://w1": __version__, "tcp://w2": __version__}), "tcp://h:1")
    assert "tcp://w2" in e.value.message and "0123456789abcdef" in e.value.message
    assert code_fingerprint() in e.value.message and e.value.key == "--scheduler"


def test_the_code_fingerprint_follows_the_package_source(tmp_path, monkeypatch):
    """Equal for the same files wherever they are installed; another byte anywhere gives another fingerprint."""
    import bpmid

    src = Path(bpmid.__file__).resolve().parent
    copy = tmp_path / "site" / "bpmid"
    shutil.copytree(src, copy, ignore=shutil.ignore_patterns("__pycache__"))
    here = code_fingerprint()
    monkeypatch.setattr(bpmid, "__file__", str(copy / "__init__.py"))
    assert code_fingerprint() == here
    with open(copy / "discover" / "thresholds.yaml", "a") as f:
        f.write("\n# a local edit\n")
    assert code_fingerprint() != here


@pytest.mark.parametrize("rig, key, words", [
    ("noise_ar1_rho: 1.5", "rig.noise_ar1_rho", "from 0 (white) to 0.99"),
    ("noise_deg: -0.1", "rig.noise_deg", "above 0"),
    ("geometry: {name: mine, th_mm: 2.0}", "rig.geometry.alpha0_deg", "missing alpha0_deg, R0_mm, l0_mm, n"),
    ("geometry: {name: mine, th_mm: -2, alpha0_deg: 30, R0_mm: 15, l0_mm: 180, n: 7}", "rig.geometry.th_mm",
     "must be positive"),
    # metres under a _mm key ran the whole calibration half, every case declined, before the cause was said
    ("geometry: {name: mine, th_mm: 2.2, alpha0_deg: 26, R0_mm: 0.011, l0_mm: 160, n: 6}", "rig.geometry.R0_mm",
     "metres given under a _mm key? R0_mm takes millimetres (11 for 0.011 m)"),
    ("geometry: {name: mine, th_mm: 2.2, alpha0_deg: 26, R0_mm: 11, l0_mm: 160000, n: 6}", "rig.geometry.l0_mm",
     "too large for a muscle (at most 5000 mm)")])
def test_a_bad_rig_value_is_named_under_the_users_own_key(tmp_path, rig, key, words):
    """The rig's values were checked as the generator ranges they replace: 'rig.noise_rho' (a key the user never
    wrote), '[1.5, 1.5]', or a Python signature for a geometry."""
    from bpmid.errors import InputError

    p = tmp_path / "rig.yaml"
    p.write_text(f"sweep: {{name: m, seed: 1}}\ngenerator: {{n_cases: 2}}\nrig:\n  {rig}\n")
    with pytest.raises(InputError) as e:
        load_sweep(p)
    assert e.value.key == key and words in str(e.value) and "__init__" not in str(e.value)


def test_rig_units_are_read_as_bpmid_spells_them(tmp_path):
    p = tmp_path / "rig.yaml"
    p.write_text("sweep: {name: m, seed: 1}\ngenerator: {n_cases: 2}\n"
                 "rig: {pressure_unit: kPa, pressure_reference: Gauge, time_unit: ms}\n")
    gen = load_sweep(p).effective_generator
    assert gen.pressure_units == ("kpa",) and gen.pressure_references == ("gauge",) and gen.time_units == ("ms",)


def test_cli_refuses_a_local_cluster_size_beside_an_existing_cluster(tmp_path):
    r = CliRunner().invoke(app, ["calibrate", str(TINY), "--out", str(tmp_path / "o"), "--scheduler",
                                 "tcp://127.0.0.1:1", "--workers", "2"])
    assert r.exit_code == 2 and "--workers" in r.output and "give one or the other" in r.output
    assert not (tmp_path / "o").exists()



def test_a_port_that_is_no_scheduler_is_refused_not_waited_on(tmp_path, monkeypatch):
    """A port that accepts but never speaks Dask (a scheduler's dashboard, a web server) hung past 290 s."""
    import socket

    from bpmid.errors import InputError
    from bpmid.validation import sweep

    monkeypatch.setattr(sweep, "CONNECT_WAIT_S", 0.5)
    with socket.socket() as srv:   # accepts connections (the kernel's backlog) and never answers
        srv.bind(("127.0.0.1", 0))
        srv.listen(4)
        with pytest.raises(InputError) as e:
            run_sweep(load_sweep(TINY), tmp_path / "o", scheduler=f"tcp://127.0.0.1:{srv.getsockname()[1]}")
    assert "no Dask scheduler answered within 0.5 s" in str(e.value) and not (tmp_path / "o").exists()


def test_a_built_in_rig_geometry_is_read_as_written(tmp_path):
    from bpmid.errors import InputError

    p = tmp_path / "rig.yaml"
    p.write_text("sweep: {name: m, seed: 1}\ngenerator: {n_cases: 2}\nrig: {geometry: PAPER}\n")
    assert load_sweep(p).effective_generator.geometries == ("paper",)
    p.write_text("sweep: {name: m, seed: 1}\ngenerator: {n_cases: 2}\nrig: {geometry: mine}\n")
    with pytest.raises(InputError) as e:
        load_sweep(p)
    assert e.value.key == "rig.geometry"


def test_a_calibration_that_closes_a_path_of_the_shipped_gate_says_so():
    """A small calibration on a rig's noise set pair_share_min to .inf (no pair can be named) with only a warning
    about false positives; the closed paths are now named."""
    import math

    from bpmid.validation.sweep import closed_paths

    said = closed_paths({"pair_share_min": math.inf, "to_floor_drop_min_sigma": math.inf})
    assert any("no pair will be named" in s for s in said) and any("to_floor_drop_min_sigma" in s for s in said)
    assert closed_paths({"pair_share_min": 0.3, "to_floor_drop_min_sigma": 0.1}) == []


def test_a_folder_of_another_commands_outputs_is_refused_before_anything_runs(tmp_path):
    """A sweep's files were written beside a discover result's (discovery.yaml, model.yaml) after a whole sweep."""
    out = tmp_path / "disc"
    out.mkdir()
    (out / "discovery.yaml").write_text("schema: bpmid.discovery/1\n")
    (out / "model.yaml").write_text("x: 1\n")
    r = CliRunner().invoke(app, ["calibrate", str(TINY), "--out", str(out), "--workers", "1"])
    assert r.exit_code == 2, r.output
    assert "not a sweep's (discovery.yaml, model.yaml)" in r.output and "give a new --out" in r.output
    assert sorted(p.name for p in out.iterdir()) == ["discovery.yaml", "model.yaml"]


def test_a_calibration_half_says_its_names_are_no_verdict(full_run, tmp_path):
    said = []
    dst = tmp_path / "again"
    shutil.copytree(full_run[0], dst)
    run_sweep(load_sweep(TINY), dst, workers=1, processes=False, progress=said.append)
    cal = next(m for m in said if m.startswith("calibration half"))
    assert "0 to run" in cal and "permissive gate" in cal and "not a verdict" in cal
    assert not any("permissive" in m for m in said if m.startswith("heldout half"))


def test_a_models_geometry_block_is_read_as_a_rig_geometry(tmp_path):
    """The geometry a discover config's model.geometry holds (SI, or keys stating their unit) was refused here as
    'missing th_mm, ...'; and the name the rig's block needs was refused there as an unknown key without a word."""
    from bpmid.config import parse_config
    from bpmid.errors import InputError

    p = tmp_path / "rig.yaml"
    p.write_text("sweep: {name: m, seed: 1}\ngenerator: {n_cases: 2}\n"
                 "rig:\n  geometry: {th: 0.0022, alpha0_deg: 26, R0: 0.011, l0_mm: 160, n: 6}\n")
    (g,) = load_sweep(p).effective_generator.geometries
    assert (g.name, g.th_mm, g.alpha0_deg, g.R0_mm, g.l0_mm, g.n) == ("rig", pytest.approx(2.2), 26.0,
                                                                      pytest.approx(11.0), 160.0, 6.0)
    p.write_text("sweep: {name: m, seed: 1}\ngenerator: {n_cases: 2}\n"
                 "rig:\n  geometry: {th: 0.0022, alpha0_deg: 26, R0: 11, l0: 0.16, n: 6}\n")
    with pytest.raises(InputError) as e:
        load_sweep(p)
    assert e.value.key == "rig.geometry.R0" and "R0 takes metres (0.011 for 11 mm)" in str(e.value)
    with pytest.raises(InputError) as e:
        parse_config({"model": {"geometry": {"name": "mine", "th_mm": 2.2, "alpha0_deg": 26, "R0_mm": 11,
                                             "l0_mm": 160, "n": 6}}})
    assert e.value.key == "model.geometry.name" and "the model's geometry has none: remove it" in str(e.value)


def test_progress_says_the_time_left_once_a_few_cases_are_done(monkeypatch):
    import bpmid.validation.sweep as S

    monkeypatch.setattr(S.time, "perf_counter", lambda: 100.0)
    assert S._time_left({"n": 2, "run": 2, "t0": 40.0}, 10) == ""              # two cases say too little
    assert S._time_left({"n": 5, "run": 3, "t0": 40.0}, 10) == "; about 2 min left in this half"   # 20 s x 5
    assert S._time_left({"n": 8, "run": 4, "t0": 60.0}, 10) == "; about 20 s left in this half"
    assert S._time_left({"n": 10, "run": 4, "t0": 60.0}, 10) == ""             # nothing left


@pytest.mark.parametrize("files, words", [
    ({"sweep.yaml": "sweep: {name: mine, seed: 1}\n"}, "its sweep.yaml is not one bpmid calibrate wrote"),
    ({"thresholds.yaml": "schema: bpmid.discover-thresholds/1\n"}, "(thresholds.yaml)")])
def test_a_users_own_sweep_or_thresholds_file_is_never_replaced(tmp_path, files, words):
    """A user's sweep config saved as sweep.yaml, or a kept gate as thresholds.yaml, was overwritten (exit 0)."""
    out = tmp_path / "o"
    out.mkdir()
    for name, text in files.items():
        (out / name).write_text(text)
    r = CliRunner().invoke(app, ["calibrate", str(TINY), "--out", str(out), "--workers", "1"])
    assert r.exit_code == 2 and words in r.output and "nothing was written" in r.output, r.output
    assert {p.name: p.read_text() for p in out.iterdir()} == files


def test_a_sweep_folder_with_another_commands_files_is_refused_both_ways(full_run, tmp_path):
    from bpmid.discover.calibrate import THRESHOLDS_PATH

    out = tmp_path / "sweep"
    shutil.copytree(full_run[0], out)
    case = THRESHOLDS_PATH.parents[2] / "datasets" / "discovery" / "case_01"
    r = CliRunner().invoke(app, ["discover", *map(str, sorted(case.glob("train_*.csv"))), "--out", str(out)])
    assert r.exit_code == 2 and "holds a sweep of bpmid calibrate" in r.output, r.output
    assert not (out / "discovery.yaml").exists()
    (out / "discovery.yaml").write_text("schema: bpmid.discovery/1\n")   # as an older bpmid let it be written
    r = CliRunner().invoke(app, ["calibrate", str(TINY), "--out", str(out), "--workers", "1"])
    assert r.exit_code == 2 and "not a sweep's (discovery.yaml)" in r.output, r.output


@pytest.mark.parametrize("geometry, key, words", [
    ("{name: m, th_mm: 2.2, alpha0_deg: 0.4538, R0_mm: 11, l0_mm: 160, n: 6}", "rig.geometry.alpha0_deg",
     "radians given under a _deg key? alpha0_deg takes degrees (26 for 0.4538 rad)"),
    ("{th: 0.0022, alpha0: 26, R0: 0.011, l0: 0.16, n: 6}", "rig.geometry.alpha0",
     "degrees given under alpha0? alpha0 takes radians (0.4538 for 26 deg)")])
def test_a_braid_angle_in_the_other_unit_is_named(tmp_path, geometry, key, words):
    from bpmid.config import parse_config
    from bpmid.errors import InputError

    p = tmp_path / "rig.yaml"
    p.write_text(f"sweep: {{name: m, seed: 1}}\ngenerator: {{n_cases: 2}}\nrig:\n  geometry: {geometry}\n")
    with pytest.raises(InputError) as e:
        load_sweep(p)
    assert e.value.key == key and words in str(e.value)
    with pytest.raises(InputError) as e:   # a discover config's model geometry likewise
        parse_config({"model": {"geometry": {"th_mm": 2.2, "alpha0_deg": 0.5236, "R0_mm": 11, "l0_mm": 160,
                                             "n": 6}}})
    assert e.value.key == "model.geometry.alpha0" and "radians given under alpha0_deg?" in str(e.value)
