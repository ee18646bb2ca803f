"""Layering: fitting never imports plotting. Every module below the workflows' output writers imports
without loading matplotlib or bpmid.plots (figures are drawn by functions that import them when called)."""
import pkgutil
import subprocess
import sys
from pathlib import Path

import bpmid

ROOT = Path(bpmid.__file__).resolve().parent
#: the layers allowed to import plotting when imported: the figures themselves, the command line and the
#: discovery output writer (which draws the figures it writes)
ABOVE = ("bpmid.plots", "bpmid.cli", "bpmid.discover.output", "bpmid.__main__")


def below_the_workflows() -> list[str]:
    names = []
    for mod in pkgutil.walk_packages([str(ROOT)], prefix="bpmid."):
        if mod.name.startswith(ABOVE) or "._data" in mod.name:
            continue
        names.append(mod.name)
    return sorted(names)


def test_no_module_below_the_workflows_imports_plotting():
    names = below_the_workflows()
    assert {"bpmid.fitting", "bpmid.varpro", "bpmid.identifiability", "bpmid.relax.fit", "bpmid.models.gpi",
            "bpmid.effects.catalogue", "bpmid.control"} <= set(names)
    code = ("import importlib, sys\n"
            f"for name in {names!r}:\n"
            "    importlib.import_module(name)\n"
            "    bad = [m for m in ('matplotlib', 'bpmid.plots') if m in sys.modules]\n"
            "    if bad:\n"
            "        print(name, 'imports', bad); sys.exit(1)\n")
    res = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, cwd=ROOT.parent, timeout=120)
    assert res.returncode == 0, res.stdout + res.stderr
