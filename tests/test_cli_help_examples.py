"""Every command's --help shows an example, and every shipped path an example names exists."""
import glob
import os
import re

import pytest
from typer.testing import CliRunner

from bpmid.cli import app

COMMANDS = [["fit", "relax"], ["fit", "motion"], ["predict"], ["compare"], ["discover"], ["report"],
            ["simulate"], ["run"], ["control"], ["export"], ["calibrate"], ["shipped"]]


@pytest.mark.parametrize("cmd", COMMANDS, ids=lambda c: " ".join(c))
def test_help_has_an_example_on_shipped_paths(cmd, repo_root):
    res = CliRunner().invoke(app, cmd + ["--help"], env={"COLUMNS": "400"})
    assert res.exit_code == 0, res.output
    text = " ".join(res.output.split())
    assert "Example" in text
    paths = re.findall(r"((?:datasets|configs)/[\w./*-]+)", text)
    for p in paths:
        p = p.rstrip(".")
        assert glob.glob(os.path.join(repo_root, p)), f"{' '.join(cmd)} --help names {p}, which does not exist"


def _example(cmd):
    res = CliRunner().invoke(app, cmd + ["--help"], env={"COLUMNS": "400"})
    text = " ".join(res.output.split())
    m = re.search(r"bpmid " + " ".join(cmd) + r" (.*?)(?:\(|\||$)", text[text.index("Example"):])
    return m.group(1).split()


@pytest.mark.parametrize("cmd", [["fit", "relax"], ["simulate"], ["discover"]], ids=lambda c: " ".join(c))
def test_self_contained_examples_run(cmd, repo_root, tmp_path, monkeypatch):
    """The first example of these commands needs only shipped files: it must run as printed."""
    args = _example(cmd)
    expanded = []
    for a in args:
        if "*" in a:
            expanded += sorted(glob.glob(os.path.join(repo_root, a)))
        elif a.startswith(("datasets/", "configs/")):
            expanded.append(os.path.join(repo_root, a))
        else:
            expanded.append(a)
    i = expanded.index("--out")
    expanded[i + 1] = str(tmp_path / expanded[i + 1])
    res = CliRunner().invoke(app, cmd + expanded)
    assert res.exit_code == 0, res.output
    assert (tmp_path / args[args.index("--out") + 1]).exists()
