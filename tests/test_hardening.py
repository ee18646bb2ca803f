"""Issue 15: nothing lost, nothing half-written, no hang -- every case of the issue as a test.

Each case ends in exit 0 with a correct result or exit 2 with a message naming the file, line or key; none
loses an input, leaves a mixed folder, hangs or ends in exit 1. (The kill tests are in test_hardening_kill.py.)
"""
from __future__ import annotations

import errno
import os
import shutil
import time
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from typer.testing import CliRunner

from bpmid.cli import app
from bpmid.config import load_config, parse_config
from bpmid.errors import InputError
from bpmid.io import atomic
from bpmid.io.atomic import guard_inputs, recover, staged_dir, write_text
from bpmid.io.yamlsafe import loads

runner = CliRunner()

BOMB = "a: &a [x, x, x, x, x, x, x, x, x, x]\n" + "".join(
    f"{chr(98 + i)}: &{chr(98 + i)} [" + ", ".join([f"*{chr(97 + i)}"] * 10) + "]\n" for i in range(9))


def _run(args):
    res = runner.invoke(app, [str(a) for a in args])
    assert res.exit_code in (0, 2), f"exit {res.exit_code}: {res.output}"
    assert "Traceback" not in res.output and "internal error" not in res.output, res.output
    return res


def _hidden(folder: Path) -> list[str]:
    return sorted(p.name for p in folder.rglob(".bpmid-*"))


def _tiny_protocol(path: Path, **top) -> Path:
    top = {"sampling_hz": 5, **top}
    lines = ["kind: motion"] + [f"{k}: {v}" for k, v in top.items()] + [
        "logs:", "  - name: t1", "    start: 1.1", "    program:",
        "      - ramp: {to: 1.6, rate: 0.1}", "      - hold: {duration_s: 2}"]
    path.write_text("\n".join(lines) + "\n")
    return path


def _log(path: Path, t, p_bar, angle, reference="absolute") -> Path:
    body = "\n".join(f"{a:.3f},{b:.6f},{c:.6f}" for a, b, c in zip(t, p_bar, angle))
    path.write_text(f"# pressure_reference: {reference}\ntime_s,pressure_bar,angle_deg\n{body}\n")
    return path


# --------------------------------------------------------------------------------------------------
# 1. data loss: no command replaces an input that sits in --out under an output's name
# --------------------------------------------------------------------------------------------------
def test_simulate_refuses_to_replace_its_protocol_in_out(tmp_path):
    d = tmp_path / "d"
    d.mkdir()
    proto = _tiny_protocol(d / "manifest.yaml")
    before = proto.read_bytes()
    res = _run(["simulate", proto, "--out", d])
    assert res.exit_code == 2 and "manifest.yaml" in res.output and "would replace the input" in res.output
    assert proto.read_bytes() == before and sorted(p.name for p in d.iterdir()) == ["manifest.yaml"]
    # the same protocol into another folder works, and a hard link to it is the same file
    os.link(proto, tmp_path / "alias.yaml")
    res = _run(["simulate", tmp_path / "alias.yaml", "--out", d])
    assert res.exit_code == 2 and proto.read_bytes() == before
    assert _run(["simulate", proto, "--out", tmp_path / "sim"]).exit_code == 0
    assert (tmp_path / "sim" / "t1.csv").is_file() and _hidden(tmp_path) == []


@pytest.mark.parametrize("cmd", ["compare", "control", "discover"])
def test_commands_refuse_an_input_under_an_output_name_before_any_work(repo_root, tmp_path, cmd):
    d = tmp_path / "d"
    d.mkdir()
    src = Path(repo_root) / "datasets" / "motion" / "fitting_set" / "fit_1p2_1p6_r1.csv"
    if cmd == "compare":
        cfg = d / "compare.yaml"
        cfg.write_text("compare: {timing: false}\n")
        args = ["compare", "--train", src, "--test", src, "--config", cfg, "--out", d]
        victim = cfg
    elif cmd == "control":
        params = d / "control.yaml"
        params.write_text("schema: bpmid.vbmm/1\n")
        args = ["control", "--params", params, "--reference", "steps", "--out", d]
        victim = params
    else:
        victim = shutil.copy(src, d / "verdict.txt")
        args = ["discover", victim, "--out", d]
    before = Path(victim).read_bytes()
    t0 = time.perf_counter()
    res = _run(args)
    assert res.exit_code == 2 and "would replace the input" in res.output, res.output
    assert Path(victim).read_bytes() == before and _hidden(tmp_path) == []
    assert time.perf_counter() - t0 < 5.0  # refused before the work, not after it


def test_run_refuses_a_config_in_out_named_like_an_output(repo_root, tmp_path):
    d = tmp_path / "d"
    d.mkdir()
    cfg = d / "run.yaml"
    log = Path(repo_root) / "datasets" / "relaxation" / "relax_300mmmin_15pct.csv"
    cfg.write_text(f"run: {{relax_logs: ['{log}'], stages: [relax]}}\n")
    before = cfg.read_bytes()
    res = _run(["run", cfg, "--out", d])
    assert res.exit_code == 2 and "run.yaml" in res.output and "would replace the input" in res.output
    assert cfg.read_bytes() == before and sorted(p.name for p in d.iterdir()) == ["run.yaml"]


def test_guard_refuses_a_replacing_write_and_allows_own_files(tmp_path):
    src = tmp_path / "in.yaml"
    src.write_text("a: 1\n")
    with guard_inputs():
        load_config(None)
        from bpmid.config import read_yaml

        read_yaml(src)
        with pytest.raises(InputError, match="would replace the input"):
            write_text(src, "b: 2\n")
        with pytest.raises(InputError, match="would replace the input"):
            with staged_dir(tmp_path) as st_:
                write_text(st_ / "in.yaml", "b: 2\n")
        out = write_text(tmp_path / "own.yaml", "c: 3\n")
        read_yaml(out)  # a file this command wrote is not an input: it may be written again
        write_text(out, "c: 4\n")
    assert src.read_text() == "a: 1\n" and _hidden(tmp_path) == []
    write_text(src, "free: outside a command\n")  # no guard outside a command


# --------------------------------------------------------------------------------------------------
# 3. SIGTERM is Ctrl-C (the SIGKILL cases are in test_hardening_kill.py)
# --------------------------------------------------------------------------------------------------
def test_sigterm_inside_a_staged_write_rolls_back(tmp_path):
    import signal

    out = tmp_path / "out"
    out.mkdir()
    (out / "a.csv").write_text("old\n")
    with pytest.raises(atomic.Terminated):
        with atomic.sigterm_as_interrupt():
            with staged_dir(out) as d:
                write_text(d / "a.csv", "new\n")
                write_text(d / "b.csv", "new\n")
                os.kill(os.getpid(), signal.SIGTERM)
                time.sleep(1)
    assert (out / "a.csv").read_text() == "old\n" and sorted(p.name for p in out.iterdir()) == ["a.csv"]
    assert _hidden(tmp_path) == []


def test_a_staged_file_written_through_write_text_stays_locked_against_recovery(tmp_path):
    # a result's YAML is staged (staged_file) and written with write_text while its figure is drawn: another
    # command's recover() on the folder meanwhile (a second `bpmid run`, `bpmid report DIR`) must leave it alone
    out = tmp_path / "out"
    out.mkdir()
    with atomic.staged_file(out / "relax_fit.yaml") as tmp:
        write_text(tmp, "a: 1\n")
        assert atomic._is_live(tmp)
        recover(out)
        assert tmp.read_text() == "a: 1\n"
    assert (out / "relax_fit.yaml").read_text() == "a: 1\n" and _hidden(tmp_path) == []


def test_a_second_writer_into_a_held_folder_is_refused_not_mixed_in(tmp_path, monkeypatch):
    from _holders import held_by_another_process

    from bpmid.run import OutputJournal

    out = tmp_path / "out"
    out.mkdir()
    (out / "a.csv").write_text("old\n")
    with held_by_another_process(out):
        monkeypatch.setattr(atomic, "COMMIT_WAIT_S", 0.2)
        with pytest.raises(InputError, match="another bpmid command"):
            with staged_dir(out) as d:
                write_text(d / "a.csv", "new\n")
        with pytest.raises(InputError, match="another bpmid command"):
            OutputJournal(out)
    assert (out / "a.csv").read_text() == "old\n" and _hidden(tmp_path) == []
    journal = OutputJournal(out)  # free again; and re-entrant within one process
    with staged_dir(out) as d:
        write_text(d / "b.csv", "b\n")
    journal.commit()
    assert sorted(p.name for p in out.iterdir()) == ["a.csv", "b.csv"]


# --------------------------------------------------------------------------------------------------
# 4. config values are type-checked inside mappings and lists; YAML 1.2 numbers
# --------------------------------------------------------------------------------------------------
def test_yaml_reads_exponent_numbers_as_floats_and_refuses_python_tags():
    data = loads("a: 5e6\nb: 1E-3\nc: .5\nd: 7\ne: 1_000\nf: 12:30\ng: '5e6'\nh: .inf\n")
    assert data == {"a": 5e6, "b": 1e-3, "c": 0.5, "d": 7, "e": 1000, "f": "12:30", "g": "5e6", "h": float("inf")}
    assert isinstance(data["a"], float) and isinstance(data["d"], int)
    for bad, where in (("a: " + "[" * 100_000 + "]" * 100_000, "nested too deeply"),  # libyaml: SIGSEGV
                       ("a: \x00\n", "characters are not allowed"),
                       ("x: !!python/object:os.system {}\n", "!!python/object"),
                       ("x: !!python/name:os.system\n", "!!python/object"),
                       ("a: 1\nb: 2\na: 3\n", "given twice")):
        with pytest.raises(InputError, match=where) as exc:
            loads(bad, path="c.yaml")
        assert exc.value.path == "c.yaml" and "\n" not in exc.value.message


@pytest.mark.parametrize("text, key, expected", [
    ("motion: {start: {K_inf: 5e6}}", None, None),
    ("model: {window_s: 1e9}", None, None),
    ("io: {columns: {Zeit: 5}}", "io.columns.Zeit", "expected text"),
    ("motion: {start: {K_inf: fast}}", "motion.start.K_inf", "expected a number"),
    ("motion: {bounds: {tau_1: [0.01, high]}}", "motion.bounds.tau_1[1]", "expected a number"),
    ("compare: {test_sets: {a: [1.5]}}", "compare.test_sets.a[0]", "expected text"),
    ("compare: {options: {gpi: 3}}", "compare.options.gpi", "expected a mapping"),
    # a trial's study config: one pattern where a list is asked, a list where named test sets are asked
    ("run: {relax_logs: lab/relax/*.csv}", "run.relax_logs", 'write it as a list, \'["lab/relax/*.csv"]\''),
    ("run: {history_durations_s: 100}", "run.history_durations_s", "write it as a list, '[100]'"),
    ("run: {test_sets: [a.csv, b.csv]}", "run.test_sets", "give each entry a name, {set_name: [paths], ...}"),
    ("io: {columns: [Zeit]}", "io.columns", "give each entry a name, {name: value, ...}"),
    ("run: {history_durations_s: [100, .nan]}", "run.history_durations_s[1]", "not a number"),
    ("run: {history_repeats: 2.5}", "run.history_repeats", "whole number"),
    ("run: {history_repeats: 1e1}", None, None),
    ("control: {seed: true}", "control.seed", "whole number"),
])
def test_config_values_are_checked_with_their_dotted_key(tmp_path, text, key, expected):
    path = tmp_path / "c.yaml"
    path.write_text(text + "\n")
    if key is None:
        cfg = load_config(path)
        if "K_inf" in text:
            assert cfg.section("motion").start["K_inf"] == 5e6
        if "window_s" in text:
            assert cfg.section("model").window_s == 1e9
        if "history_repeats" in text:
            assert cfg.section("run").history_repeats == 10
        return
    with pytest.raises(InputError) as exc:
        load_config(path)
    assert exc.value.key == key and expected in exc.value.message and exc.value.path == str(path)


def test_fit_motion_takes_an_exponent_start_value(repo_root, tmp_path):
    cfg = tmp_path / "c.yaml"
    cfg.write_text("motion: {start: {K_inf: 5e6}, max_nfev: 5, linear_start: false}\n")
    log = Path(repo_root) / "datasets" / "motion" / "fitting_set" / "fit_1p2_1p6_r1.csv"
    res = _run(["fit", "motion", log, "--config", cfg, "--out", tmp_path / "v.yaml", "--no-plot"])
    assert res.exit_code == 0 and (tmp_path / "v.yaml").is_file()


# --------------------------------------------------------------------------------------------------
# 5. resource limits before work starts
# --------------------------------------------------------------------------------------------------
@pytest.mark.parametrize("where", ["config", "params", "protocol"])
def test_a_yaml_bomb_is_refused_at_once(repo_root, tmp_path, where):
    bomb = tmp_path / "bomb.yaml"
    bomb.write_text(BOMB)
    log = Path(repo_root) / "datasets" / "motion" / "fitting_set" / "fit_1p2_1p6_r1.csv"
    args = {"config": ["fit", "motion", log, "--config", bomb, "--out", tmp_path / "v.yaml"],
            "params": ["predict", log, "--params", bomb, "--out", tmp_path / "p"],
            "protocol": ["simulate", bomb, "--out", tmp_path / "s"]}[where]
    t0 = time.perf_counter()
    res = _run(args)
    assert res.exit_code == 2 and "bomb.yaml" in res.output and "aliases" in res.output
    assert time.perf_counter() - t0 < 5.0


def test_oversized_yaml_is_refused(tmp_path, monkeypatch):
    monkeypatch.setenv("BPMID_MAX_YAML_BYTES", "1000")
    big = tmp_path / "big.yaml"
    big.write_text("run: {seed: 1}\n" + "# padding\n" * 200)
    with pytest.raises(InputError, match="BPMID_MAX_YAML_BYTES"):
        load_config(big)


@pytest.mark.parametrize("change, message", [
    ("sampling_hz: 1e8", "BPMID_MAX_SAMPLES"),
    ("cycles", "program pieces"),
    ("replicates: 100000000", "BPMID_MAX_FILES"),
    ("replicates: 5000\nsampling_hz: 500", "BPMID_MAX_SAMPLES_TOTAL"),
])
def test_protocol_sizes_are_checked_before_rendering(tmp_path, change, message):
    p = tmp_path / "p.yaml"
    if change == "cycles":
        p.write_text("kind: motion\nlogs:\n  - name: big\n    program:\n"
                     "      - triangle: {low: 1.1, high: 2.0, rate: 0.1, cycles: 100000000}\n")
    else:
        _tiny_protocol(p, **dict(kv.split(": ") for kv in change.split("\n")))
    t0 = time.perf_counter()
    res = _run(["simulate", p, "--out", tmp_path / "s"])
    assert res.exit_code == 2 and message in res.output and "p.yaml" in res.output
    if change.startswith("sampling"):
        assert "memory" in res.output and "logs[0]" in res.output
    assert time.perf_counter() - t0 < 5.0 and not (tmp_path / "s").exists()


def test_config_repeat_counts_are_limited_with_an_estimate(tmp_path, monkeypatch):
    cfg = tmp_path / "c.yaml"
    cfg.write_text("compare: {timing_repeats: 1e29}\n")
    with pytest.raises(InputError) as exc:
        load_config(cfg)
    assert exc.value.key == "compare.timing_repeats" and "estimated" in exc.value.message
    assert "BPMID_LIMIT_COMPARE_TIMING_REPEATS" in exc.value.message
    cfg.write_text("compare: {timing_repeats: 2000}\n")
    with pytest.raises(InputError):
        load_config(cfg)
    monkeypatch.setenv("BPMID_LIMIT_COMPARE_TIMING_REPEATS", "5000")  # a stated limit can be raised
    assert load_config(cfg).section("compare").timing_repeats == 2000


# --------------------------------------------------------------------------------------------------
# 6. staging across file systems and on read-only ones
# --------------------------------------------------------------------------------------------------
def test_cross_device_moves_fall_back_to_copy_and_swap(tmp_path, monkeypatch):
    out = tmp_path / "out"
    out.mkdir()
    (out / "a.csv").write_text("old\n")
    real_replace, real_rename = os.replace, os.rename

    def cross(fn):
        def move(src, dst, *a, **k):
            s, d = Path(src), Path(dst)
            if atomic.STAGE_PREFIX in str(s) and atomic.STAGE_PREFIX not in str(d):
                raise OSError(errno.EXDEV, "Invalid cross-device link", str(src))
            return fn(src, dst, *a, **k)
        return move

    monkeypatch.setattr(os, "replace", cross(real_replace))
    monkeypatch.setattr(os, "rename", cross(real_rename))
    with staged_dir(out) as d:
        write_text(d / "a.csv", "new\n")
        write_text(d / "sub" / "b.csv", "new b\n")
    with staged_dir(tmp_path / "fresh") as d:
        write_text(d / "c.csv", "c\n")
    assert (out / "a.csv").read_text() == "new\n" and (out / "sub" / "b.csv").read_text() == "new b\n"
    assert (tmp_path / "fresh" / "c.csv").read_text() == "c\n" and _hidden(tmp_path) == []


@pytest.mark.parametrize("code, words", [(errno.EROFS, "read-only"), (errno.EACCES, "no permission"),
                                         (errno.ENOSPC, "disk is full")])
def test_read_only_and_full_disks_are_named_plainly(tmp_path, monkeypatch, code, words):
    def refuse(*a, **k):
        raise OSError(code, os.strerror(code), str(tmp_path))

    monkeypatch.setattr(atomic.tempfile, "mkdtemp", refuse)
    monkeypatch.setattr(atomic.tempfile, "mkstemp", refuse)
    with pytest.raises(InputError, match=words):
        with staged_dir(tmp_path / "out"):
            pass
    with pytest.raises(InputError, match=words):
        write_text(tmp_path / "x.yaml", "a: 1\n")
    proto = _tiny_protocol(tmp_path / "p.yaml")
    res = _run(["simulate", proto, "--out", tmp_path / "out"])
    assert res.exit_code == 2 and words in res.output


def test_an_output_path_through_a_file_is_named_plainly(tmp_path):
    (tmp_path / "notes.txt").write_text("a file\n")
    res = _run(["simulate", _tiny_protocol(tmp_path / "p.yaml"), "--out", tmp_path / "notes.txt" / "sim"])
    assert res.exit_code == 2 and "notes.txt" in res.output and "is a file, not a folder" in res.output
    assert ".bpmid-" not in res.output and _hidden(tmp_path) == []


# --------------------------------------------------------------------------------------------------
# 8. honest edges
# --------------------------------------------------------------------------------------------------
def test_a_zero_sensitivity_parameter_is_never_estimated():
    from bpmid.fitting import ZERO_SENSITIVITY, fit_least_squares
    from bpmid.params import Param, ParamSet

    x = np.linspace(0.0, 1.0, 200)
    y = 2.0 + 3.0 * x  # noise-free: a perfect fit makes every standard error ~0
    ps = ParamSet([Param("a", 1.0), Param("b", 1.0), Param("k", 5.0, lower=0.1, upper=50.0, log_scale=True)])
    for check in (True, False):
        res = fit_least_squares(lambda p: p.value("a") + p.value("b") * x + 0.0 * p.value("k") - y, ps,
                                check_identifiability=check)
        assert res.params["k"].identifiable is False and res.params["k"].stderr is None
        assert res.held["k"] == ZERO_SENSITIVITY and "k" not in res.free_names
        assert res.params.value("a") == pytest.approx(2.0) and res.params["a"].identifiable


def test_a_zero_sensitivity_parameter_on_its_bound_says_the_data_asked_for_no_more():
    """A term switched off at its bound (a lag of 0 s) is not a term the model ignores: the verdict says which."""
    from bpmid.fitting import ZERO_SENSITIVITY, fit_least_squares
    from bpmid.params import Param, ParamSet

    x = np.linspace(0.0, 1.0, 200)
    y = 2.0 + 3.0 * x
    ps = ParamSet([Param("a", 1.0), Param("b", 1.0), Param("tau", 0.0, "s", lower=0.0, upper=10.0)])
    res = fit_least_squares(lambda p: p.value("a") + p.value("b") * x + p.value("tau") ** 2 * x ** 2 - y, ps)
    why = res.held["tau"]
    assert why.startswith(ZERO_SENSITIVITY) and "ended on its lower bound 0 s" in why, why
    assert res.params.value("b") == pytest.approx(3.0)


def test_constant_pressure_log_holds_the_branch_constants(tmp_path):
    from bpmid.io.motion_logs import read_motion_log
    from bpmid.motion_fit import fit_motion

    t = np.arange(0.0, 60.0, 0.1)
    rng = np.random.default_rng(3)
    # constant pressure, with a second log that moves so that the fit has variation to explain
    a = _log(tmp_path / "hold.csv", t, np.full(t.size, 1.8), 56.67 + 0.05 * rng.standard_normal(t.size))
    res = _run(["fit", "motion", a, "--out", tmp_path / "v.yaml", "--no-plot"])
    assert res.exit_code == 2 and "hold.csv" in res.output  # R^2 <= 0: refused, naming the log
    cfg = parse_config({"motion": {"max_nfev": 20}})
    logs = [read_motion_log(a)]
    b = _log(tmp_path / "ramp.csv", t, 1.1 + 0.7 * t / t[-1], 5.0 + 60 * t / t[-1])
    fit = fit_motion(logs + [read_motion_log(b)], config=cfg)
    for p in fit.fit.params:
        if p.identifiable:
            assert p.stderr is not None and p.stderr > 0


def test_constant_stress_relaxation_log_is_refused(tmp_path):
    t = np.arange(0.0, 30.0, 0.02)
    strain = np.minimum(t / 0.5, 1.0) * 0.2
    rng = np.random.default_rng(5)
    log = tmp_path / "flat.csv"
    log.write_text("time_s,strain,stress_mpa\n" + "\n".join(
        f"{a:.3f},{b:.6f},{0.01 + 1e-9 * rng.standard_normal():.12f}" for a, b in zip(t, strain)) + "\n")
    res = _run(["fit", "relax", log, "--out", tmp_path / "r.yaml", "--no-figure"])
    assert res.exit_code == 2 and "flat.csv" in res.output and "R^2" in res.output
    assert not (tmp_path / "r.yaml").exists()


def test_discover_refuses_a_held_out_log_that_is_also_a_fitting_log(repo_root, tmp_path):
    case = Path(repo_root) / "datasets" / "discovery" / "case_01"
    res = _run(["discover", case / "train_amplitudes.csv", case / "train_steps.csv", "--holdout",
                case / "train_steps.csv", "--out", tmp_path / "d"])
    assert res.exit_code == 2 and "train_steps.csv" in res.output and "held-out" in res.output
    assert not (tmp_path / "d").exists()


def test_discover_noise_floor_zero_names_the_file(tmp_path):
    t = np.arange(0.0, 120.0, 0.1)
    for k in (1, 2):
        p = 1.1 + 0.9 * np.abs(((t / 20 * k) % 2) - 1)
        _log(tmp_path / f"lin{k}.csv", t, p, 10 + 40 * (p - 1.1))
    res = _run(["discover", tmp_path / "lin1.csv", tmp_path / "lin2.csv", "--out", tmp_path / "d"])
    assert res.exit_code == 2 and "noise floor 0" in res.output and "lin1.csv" in res.output


# --------------------------------------------------------------------------------------------------
# 9. smaller cases
# --------------------------------------------------------------------------------------------------
@pytest.mark.parametrize("branches", [1, 5, 8])
def test_motion_branches_within_the_documented_range_work(branches):
    from bpmid.models.vbmm import Material
    from bpmid.motion_fit import MotionFitConfig, _adapt_branches, params_from_material

    cfg = MotionFitConfig(branches=branches)
    ps = params_from_material(_adapt_branches(Material.paper_mat(), cfg), cfg)
    taus = [ps.value(f"tau_{j}") for j in range(1, branches + 1)]
    assert all(1e-3 <= v <= 1e3 for v in taus) and taus == sorted(taus) and len(set(taus)) == branches


def test_motion_bounds_error_names_a_key_the_user_wrote():
    from bpmid.models.vbmm import Material
    from bpmid.motion_fit import MotionFitConfig, _adapt_branches, params_from_material

    cfg = parse_config({"motion": {"bounds": {"tau_1": [5.0, 10.0]}}}).section("motion")
    with pytest.raises(InputError) as exc:
        params_from_material(_adapt_branches(Material.paper_mat(), cfg), cfg)
    assert exc.value.key == "motion.bounds.tau_1"
    cfg = MotionFitConfig(branches=3, bounds={"tau_1": (0.001, 1000.0)})
    params_from_material(_adapt_branches(Material.paper_mat(), cfg), cfg)


def _vbmm_file(tmp_path, repo_root, edit) -> Path:
    from bpmid.io.results import write_result
    from bpmid.models.vbmm import VBMM, Material, VBMMConfig, vbmm_yaml_body

    body = vbmm_yaml_body(VBMM.from_config(Material.paper_fit(), VBMMConfig()))
    edit(body)
    return write_result(tmp_path / "VBMM.yaml", "bpmid.vbmm/1", body, {"created": "test"})


@pytest.mark.parametrize("edit, key", [
    (lambda b: b["material"]["K_inf"].update(stdev=3.0), "material.K_inf.stdev"),
    (lambda b: b["material"]["branches"][0]["tau"].update(valeu=1.0), "material.branches[0].tau.valeu"),
    (lambda b: b["model"].update(history="bogus"), "model.history"),
    (lambda b: b["model"].update(window_s=-1), "model.window_s"),
    (lambda b: b["model"].update(speed="fast"), "model.speed"),
    (lambda b: b["material"].update(branches=b["material"]["branches"] * 500), "material.branches"),
])
def test_params_files_refuse_unknown_entry_keys_and_a_bogus_model_block(repo_root, tmp_path, edit, key):
    params = _vbmm_file(tmp_path, repo_root, edit)
    log = Path(repo_root) / "datasets" / "motion" / "fitting_set" / "fit_1p2_1p6_r1.csv"
    res = _run(["predict", log, "--params", params, "--out", tmp_path / "p"])
    assert res.exit_code == 2 and key in res.output and "VBMM.yaml" in res.output
    good = _vbmm_file(tmp_path, repo_root, lambda b: None)
    assert _run(["predict", log, "--params", good, "--out", tmp_path / "p"]).exit_code == 0


@pytest.mark.parametrize("args", [["--out", ""], ["--out="], ["--params", ""]])
def test_an_empty_path_is_refused(repo_root, tmp_path, args, monkeypatch):
    monkeypatch.chdir(tmp_path)
    log = Path(repo_root) / "datasets" / "motion" / "fitting_set" / "fit_1p2_1p6_r1.csv"
    base = ["predict", str(log)] + (["--params", "x.yaml"] if "--params" not in args else ["--out", "p"])
    res = runner.invoke(app, base + args)
    assert res.exit_code == 2 and "empty" in res.output
    assert list(tmp_path.iterdir()) == []


# --------------------------------------------------------------------------------------------------
# the next command recovers what a killed one left (the kills themselves: test_hardening_kill.py)
# --------------------------------------------------------------------------------------------------
def test_a_dead_journal_is_rolled_back_by_the_next_command(tmp_path):
    import json

    out = tmp_path / "out"
    out.mkdir()
    (out / "keep.txt").write_text("user file\n")
    (out / "t1.csv").write_text("old t1\n")
    backup = out / ".bpmid-undo.abc"
    backup.mkdir()
    (backup / "t1.csv").write_text("old t1\n")
    (out / "t1.csv").write_text("half-switched new t1\n")
    (out / "manifest.yaml").write_text("new, not there before\n")
    (out / ".bpmid-journal.dead.json").write_text(json.dumps(
        {"version": 1, "pid": 1, "out": str(out), "backup": backup.name, "saved": ["t1.csv"],
         "new": ["manifest.yaml"], "new_dirs": [], "before": None}))
    (tmp_path / ".bpmid-stage.dead").mkdir()
    (out / ".bpmid-run-undo.old").mkdir()
    # the next command on the folder (a protocol that writes t1.csv and manifest.yaml) first recovers, then writes
    res = _run(["simulate", _tiny_protocol(tmp_path / "p.yaml"), "--out", out])
    assert res.exit_code == 0
    assert (out / "keep.txt").read_text() == "user file\n" and "time_s" in (out / "t1.csv").read_text()
    assert _hidden(tmp_path) == []
    # recover() alone restores the old state
    (out / ".bpmid-undo.x").mkdir()
    (out / ".bpmid-undo.x" / "keep.txt").write_text("user file\n")
    (out / "keep.txt").write_text("changed\n")
    (out / ".bpmid-journal.x.json").write_text(json.dumps(
        {"version": 1, "out": str(out), "backup": ".bpmid-undo.x", "saved": ["keep.txt"], "new": [],
         "new_dirs": []}))
    assert recover(out) and (out / "keep.txt").read_text() == "user file\n" and _hidden(out) == []


@pytest.mark.parametrize("journal", [
    {"out": "elsewhere", "before": []},                    # a journal copied in from another folder
    {"out": None, "new": ["../victim.txt"]},               # a path leaving the folder
    {"out": None, "backup": "../x", "saved": ["keep.txt"]},
])
def test_a_hostile_journal_deletes_nothing(tmp_path, journal):
    import json

    out = tmp_path / "out"
    out.mkdir()
    (out / "keep.txt").write_text("data\n")
    (tmp_path / "victim.txt").write_text("outside\n")
    body = {"version": 1, **journal}
    body["out"] = str(out) if body["out"] is None else str(tmp_path / body["out"])
    (out / ".bpmid-journal.evil.json").write_text(json.dumps(body))
    done = recover(out)
    assert any("left" in d for d in done)
    assert (out / "keep.txt").read_text() == "data\n" and (tmp_path / "victim.txt").is_file()


# --------------------------------------------------------------------------------------------------
# property tests: random configs and random protocol sizes never crash or hang
# --------------------------------------------------------------------------------------------------
_scalars = st.one_of(st.none(), st.booleans(), st.integers(-10**30, 10**30), st.floats(allow_nan=True),
                     st.text(max_size=6), st.sampled_from(["5e6", "1e9", "auto", "paper", "recursive"]))


def _nested(children):
    return st.lists(children, max_size=3) | st.dictionaries(st.text(max_size=8), children, max_size=3)


_values = st.recursive(_scalars, _nested, max_leaves=8)
_KEYS = {"io": ["columns", "pressure_reference", "atmosphere_pa", "max_gap_factor"],
         "model": ["closure", "history", "window_s", "geometry"],
         "motion": ["branches", "start", "fixed", "bounds", "max_nfev", "tau_grid", "split_tau"],
         "compare": ["models", "test_sets", "options", "timing_repeats", "figure_logs"],
         "run": ["stages", "history_durations_s", "history_repeats", "seed", "test_sets"],
         "control": ["kp_bar_per_deg", "rate_hz", "controllers", "ms_elements", "sensors"],
         "relax": ["terms", "specimen", "columns", "poisson"],
         "discover": ["candidates", "max_effects", "lr_p_max"]}


@st.composite
def _configs(draw):
    cfg = {}
    for section in draw(st.lists(st.sampled_from(sorted(_KEYS)), max_size=3, unique=True)):
        keys = draw(st.lists(st.sampled_from(_KEYS[section] + ["bogus"]), max_size=3, unique=True))
        cfg[section] = {k: draw(_values) for k in keys}
    return cfg


@settings(max_examples=100, suppress_health_check=[HealthCheck.too_slow])
@given(_configs())
def test_random_configs_load_or_name_the_key(cfg):
    t0 = time.perf_counter()
    try:
        parse_config(cfg)
    except InputError as exc:
        assert exc.key and exc.message
        assert exc.key.split(".")[0].split("[")[0] in cfg
    assert time.perf_counter() - t0 < 1.0


@settings(max_examples=60)
@given(st.floats(1e-2, 1e10), st.integers(1, 10**12), st.floats(1e-4, 1e6), st.integers(1, 10**6),
       st.sampled_from(["triangle", "sine", "sawtooth", "repeat"]))
def test_random_protocol_sizes_are_refused_or_rendered_as_estimated(fs, cycles, rate, times, kind):
    import yaml

    from bpmid.twin.protocol import _extent, _first_level, load_protocol

    seg = {"triangle": {"triangle": {"low": 1.1, "high": 2.0, "rate": rate, "cycles": cycles}},
           "sine": {"sine": {"mean": 1.5, "amplitude": 0.3, "frequency_hz": rate, "cycles": cycles}},
           "sawtooth": {"sawtooth": {"low": 1.1, "high": 2.0, "period_s": 1.0 / rate, "cycles": cycles}},
           "repeat": {"repeat": {"times": times, "program": [{"ramp": {"to": 1.9, "rate": rate}},
                                                             {"hold": {"duration_s": 1.0 / rate}}]}}}[kind]
    text = yaml.safe_dump({"kind": "motion", "sampling_hz": fs,
                           "logs": [{"name": "x", "start": 1.1, "program": [seg]}]})
    path = Path(os.environ.get("TMPDIR", "/tmp")) / f"bpmid-prop-{os.getpid()}.yaml"
    path.write_text(text)
    os.environ["BPMID_MAX_SAMPLES"] = "20000"  # accepted protocols stay cheap to render
    t0 = time.perf_counter()
    try:
        proto = load_protocol(path)
    except InputError as exc:
        assert exc.path == str(path) and ("BPMID_MAX_SAMPLES" in exc.message or "pieces" in exc.message
                                          or (kind != "repeat" and "aliasing" in exc.message))
    else:
        spec = proto.logs[0]
        t, x = proto.render(spec)
        dur, _pieces, _end = _extent(spec.program, _first_level(spec.program) if spec.start is None else spec.start)
        assert abs(t.size - (dur * fs + 1)) <= 2 and np.all(np.isfinite(x))
    finally:
        os.environ.pop("BPMID_MAX_SAMPLES", None)
        path.unlink()
    assert time.perf_counter() - t0 < 2.0


def test_a_refit_that_does_not_check_identifiability_never_reports_an_undetermined_parameter_as_identifiable():
    # discovery's refits hold nothing (check_identifiability=False); a constant driven onto its bound stays
    # free but reads not identifiable, with the reason, as the checked fit would say (there it is held)
    from bpmid.fitting import fit_least_squares
    from bpmid.params import Param, ParamSet

    rng = np.random.default_rng(4)
    x = np.linspace(0.0, 1.0, 200)
    y = 2.0 + 3.0 * x + 0.01 * rng.normal(size=x.size)    # the best c is -0.5: below its lower bound 0.2
    ps = ParamSet([Param("a", 1.0), Param("b", 1.0), Param("c", 1.0, lower=0.2, upper=10.0)])
    res = fit_least_squares(lambda p: p.value("a") + p.value("b") * x + p.value("c") * x ** 2 - (y - 0.5 * x ** 2),
                            ps, check_identifiability=False)
    c = res.params["c"]
    assert c.value == pytest.approx(0.2, abs=1e-6) and not c.fixed and c.identifiable is False
    assert c.note.startswith("not identifiable: ") and "not check identifiability" in c.note
    assert res.params["a"].identifiable and res.params["b"].identifiable
    checked = fit_least_squares(lambda p: p.value("a") + p.value("b") * x + p.value("c") * x ** 2
                                - (y - 0.5 * x ** 2), ps, check_identifiability=True)
    assert "c" in checked.held and checked.params["c"].identifiable is False


def test_an_output_folder_that_may_not_be_written_is_refused_before_any_input_is_read(tmp_path, monkeypatch):
    # a trial (a user without write permission on --out) waited 10-14 s of reading and checking logs for the
    # refusal at the first write; the folder is checked with the other output checks, before any work
    import bpmid.io.motion_logs as motion_logs

    ro = tmp_path / "shared"
    ro.mkdir()
    real_access = os.access

    def access(path, mode, *a, **k):
        if Path(path) in (ro, ro / "new") and mode & os.W_OK:
            return False
        return real_access(path, mode, *a, **k)

    def never(*a, **k):
        raise AssertionError("a log was read before the output folder was checked")

    monkeypatch.setattr(atomic.os, "access", access)
    monkeypatch.setattr(motion_logs, "read_motion_logs", never)
    logs = sorted(str(p) for p in (Path(__file__).parents[1] / "datasets" / "motion" / "fitting_set").glob("*.csv"))
    for args in (["compare", "--train", logs[0], "--test", logs[1], "--out", ro],
                 ["compare", "--train", logs[0], "--test", logs[1], "--out", ro / "new" / "deeper"],
                 ["fit", "motion", logs[0], "--out", ro / "VBMM.yaml"],
                 ["discover", *logs[:2], "--out", ro]):
        res = _run(args)
        assert res.exit_code == 2 and "cannot write into the folder" in res.output, (args, res.output)
        assert str(ro) in res.output and "nothing was read or written" in res.output, res.output
    assert sorted(p.name for p in ro.iterdir()) == []


def test_a_rerun_into_a_folder_says_what_it_replaced(tmp_path, capsys):
    """A second run into the same --out replaced the first's files without a word: it says how many and which,
    and that the folder's other files stay; a first run into a new folder says nothing of the kind."""
    out = tmp_path / "o"
    with staged_dir(out) as d:
        (d / "a.yaml").write_text("1")
        (d / "b.csv").write_text("1")
    assert "replaced" not in capsys.readouterr().err
    with staged_dir(out) as d:          # the same files again: nothing else in the folder to speak of
        (d / "a.yaml").write_text("1")
        (d / "b.csv").write_text("1")
    err = capsys.readouterr().err
    assert f"replaced 2 file(s) already in {out} with this run's (a.yaml, b.csv)" in err and "other files" not in err
    (out / "mine.txt").write_text("kept")
    with staged_dir(out) as d:
        (d / "a.yaml").write_text("2")
        (d / "c.png").write_text("2")
    err = capsys.readouterr().err
    assert f"replaced 1 file(s) already in {out} with this run's (a.yaml); the folder's other files are left" in err
    assert (out / "a.yaml").read_text() == "2" and (out / "b.csv").read_text() == "1"
    assert (out / "mine.txt").read_text() == "kept"
