"""One small study run once per test session (``bpmid run`` on the small config of test_run), shared by the
report, browser and figure tests. While it runs, every figure saved anywhere is checked for overlapping or
clipped text (:func:`bpmid.plots.check.text_problems`), so the figure test needs no second run."""
from __future__ import annotations

import shutil
from pathlib import Path

from typer.testing import CliRunner

_CACHE: dict = {}


def shared_study(tmp_path_factory) -> tuple[Path, dict[str, list[str]]]:
    """(DIR of the run, {figure file name: layout problems}); built on first use, then reused."""
    if "out" in _CACHE:
        return _CACHE["out"], _CACHE["figures"]
    import matplotlib.figure

    from bpmid.cli import app
    from bpmid.plots.check import text_problems
    from test_run import make_study

    root = tmp_path_factory.mktemp("report-study")
    cfg = make_study(root, timing=True)
    checked: dict[str, list[str]] = {}
    orig = matplotlib.figure.Figure.savefig

    def savefig(self, fname, *a, **kw):
        if hasattr(fname, "write"):  # the motion fit renders into memory first
            title = self.get_suptitle()
            name = "vbmm_fit.png" if title.startswith("VBMM fit") else f"<buffer: {title}>"
        else:
            name = Path(str(fname)).name
        # a staged temporary name is ".<stem>.<random><suffix>" (maybe staged twice): keep the stem
        if name.startswith(".bpmid-tmp."):  # bpmid.io.atomic: ".bpmid-tmp.<stem>.<random><suffix>", maybe twice
            suffix = Path(name).suffix
            while name.startswith(".bpmid-tmp."):
                name = name[len(".bpmid-tmp."):]
            name = name.split(".")[0] + suffix
        if name.startswith("."):
            name = name.lstrip(".").split(".")[0] + Path(name).suffix
        if self.get_suptitle() or self.axes:
            checked.setdefault(name, text_problems(self))
        return orig(self, fname, *a, **kw)

    matplotlib.figure.Figure.savefig = savefig
    try:
        # one process: every figure passes through the patched savefig above (a forked stage would draw its
        # figures in a copy of this process, out of the checker's sight)
        r = CliRunner().invoke(app, ["run", str(cfg), "--out", str(root / "out"), "--workers", "1"])
        assert r.exit_code == 0, r.output
        # predict draws its figure too (measured vs predicted, error)
        r = CliRunner().invoke(app, ["predict", str(root / "logs" / "amp_1p9.csv"), "--params",
                                     str(root / "out" / "vbmm_fit.yaml"), "--out", str(root / "pred")])
        assert r.exit_code == 0, r.output
    finally:
        matplotlib.figure.Figure.savefig = orig
    _CACHE.update(out=root / "out", figures=checked, root=root)
    return root / "out", checked


def copy_of(study: Path, dest: Path) -> Path:
    shutil.copytree(study, dest)
    return dest
