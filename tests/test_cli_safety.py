"""The command line never destroys its inputs, and file-system refusals are bad input (exit 2), not crashes."""
from __future__ import annotations

import shutil

from typer.testing import CliRunner

from bpmid.cli import app

runner = CliRunner()


def _copy(repo_root, rel, dst):
    shutil.copy(f"{repo_root}/{rel}", dst)
    return dst


def test_fit_relax_refuses_to_overwrite_its_log(repo_root, tmp_path):
    log = _copy(repo_root, "datasets/relaxation/relax_300mmmin_15pct.csv", tmp_path / "rel.csv")
    before = log.read_bytes()
    res = runner.invoke(app, ["fit", "relax", str(log), "--out", str(log)])
    assert res.exit_code == 2 and ".yaml" in res.output
    res = runner.invoke(app, ["fit", "relax", str(log), "--out", str(tmp_path / "rel.yaml"), "--no-figure"])
    assert res.exit_code == 0, res.output
    (tmp_path / "dir.yaml").mkdir()
    res = runner.invoke(app, ["fit", "relax", str(log), "--out", str(tmp_path / "dir.yaml")])
    assert res.exit_code == 2 and "existing folder" in res.output
    assert log.read_bytes() == before and not (tmp_path / "dir.png").exists()


def test_fit_motion_refuses_to_overwrite_its_init_and_predict_its_logs(repo_root, tmp_path):
    rel = _copy(repo_root, "datasets/relaxation/relax_300mmmin_15pct.csv", tmp_path / "rel.csv")
    assert runner.invoke(app, ["fit", "relax", str(rel), "--out", str(tmp_path / "relax_fit.yaml")]).exit_code == 0
    init_before = (tmp_path / "relax_fit.yaml").read_bytes()
    log = _copy(repo_root, "datasets/motion/fitting_set/fit_1p2_1p6_r1.csv", tmp_path / "mot.csv")
    res = runner.invoke(app, ["fit", "motion", str(log), "--init", str(tmp_path / "relax_fit.yaml"),
                              "--out", str(tmp_path / "relax_fit.yaml")])
    assert res.exit_code == 2 and "overwrite the input" in res.output
    assert (tmp_path / "relax_fit.yaml").read_bytes() == init_before
    res = runner.invoke(app, ["fit", "motion", str(log), "--out", str(tmp_path / "VBMM.yaml"), "--no-plot"])
    assert res.exit_code == 0, res.output
    log_before = log.read_bytes()
    res = runner.invoke(app, ["predict", str(log), "--params", str(tmp_path / "VBMM.yaml"), "--out", str(tmp_path)])
    assert res.exit_code == 2 and "overwrite the input" in res.output
    assert log.read_bytes() == log_before


def test_an_output_the_file_system_refuses_is_exit_2(repo_root, tmp_path):
    log = _copy(repo_root, "datasets/relaxation/relax_300mmmin_15pct.csv", tmp_path / "rel.csv")
    blocker = tmp_path / "blocker"
    blocker.write_text("a file where a folder is needed")
    res = runner.invoke(app, ["fit", "relax", str(log), "--out", str(blocker / "sub" / "fit.yaml")])
    assert res.exit_code == 2, res.output
    assert "internal error" not in res.output


def test_console_script_exit_keeps_output_status_and_exit_handlers(tmp_path):
    """The console script ends without the interpreter's teardown (bpmid.cli._exit): everything printed arrives,
    the exit status is the command's, SystemExit('message') prints it with status 1, atexit handlers run."""
    import os
    import subprocess
    import sys

    env = {**os.environ, "PYTHONPATH": os.pathsep.join(sys.path)}
    marker = tmp_path / "atexit.txt"
    code = ("import atexit, sys\n"
            f"atexit.register(lambda: open({str(marker)!r}, 'w').write('ran'))\n"
            "from bpmid.cli import _exit\n"
            "sys.stdout.write('x' * 200000)\n"
            "_exit(int(sys.argv[1]) if sys.argv[1].isdigit() else sys.argv[1])\n")
    r = subprocess.run([sys.executable, "-c", code, "3"], env=env, capture_output=True, text=True, timeout=60)
    assert r.returncode == 3 and len(r.stdout) == 200000 and marker.read_text() == "ran"
    marker.unlink()
    r = subprocess.run([sys.executable, "-c", code, "stopped: reason"], env=env, capture_output=True, text=True,
                       timeout=60)
    assert r.returncode == 1 and "stopped: reason" in r.stderr and marker.read_text() == "ran"
    r = subprocess.run([sys.executable, "-m", "bpmid", "fit", "relax", str(tmp_path / "none.csv"), "--out",
                        str(tmp_path / "x.yaml")], env=env, capture_output=True, text=True, timeout=120)
    assert r.returncode == 2 and "none.csv" in r.stderr + r.stdout
    assert not (tmp_path / "x.yaml").exists()
