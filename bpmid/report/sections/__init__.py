"""The report's sections, one module each, in the order they appear (:data:`SECTIONS`): a one-screen summary
first, provenance last. Each module has ``KEY``, ``TITLE`` and ``build(doc, study, figs)``; adding a section is
adding a module and a line here."""
from __future__ import annotations

from importlib import import_module

#: module names of bpmid.report.sections, in report order
SECTIONS = ("summary", "model", "relax", "motion", "compare", "paper", "history", "residuals", "discovery",
            "control", "provenance")


def registry():
    """(key, title, build) of every section, in order."""
    out = []
    for name in SECTIONS:
        mod = import_module(f"bpmid.report.sections.{name}")
        out.append((mod.KEY, mod.TITLE, mod.build))
    return out


def stale_note(doc, st, stage: str) -> None:
    """Say, at the top of a section, that its files are left over from an earlier run, or were written by
    another command than the run in run.yaml."""
    if stage in st.foreign:
        doc.p(f"STALE: {st.stale[stage]}.", css="stale")
    elif stage in st.stale:
        doc.p(f"STALE: {st.stale[stage]}. Its numbers describe that earlier run, not the last one.", css="stale")


def stale_ref(doc, st, stages: tuple[str, ...], what: str) -> None:
    """Say, in a section built from other stages' files, that some of them are stale (the reason is in the
    section of that stage and in the summary)."""
    bad = [s for s in stages if s in st.stale]
    if bad:
        doc.p(f"STALE: {what} from {'stages' if len(bad) > 1 else 'stage'} {', '.join(bad)}: not from the run in "
              "run.yaml (see the summary).", css="stale")


def absent(doc, st, path: str, extra: str = "") -> None:
    """Say why a section has nothing to show: its file is unusable (named, with the problem) or not there."""
    probs = [p for p in st.problems if p.path == path]
    stage = _STAGE_OF_FILE.get(path.split("/")[0])
    done = st.run is not None and stage is not None and st.run.status(stage) == "done"
    if probs:
        doc.p(f"Not available: {path} is unusable ({probs[0].what}).", css="warn")
    elif done:   # the run says it wrote them: they were moved or deleted since
        doc.p(f"Missing: run.yaml records the {stage} stage as done, but {path} is not in this folder (moved or "
              "deleted after the run); rerun the stage to restore it.", css="warn")
    else:
        doc.p(f"Not run (no {path} in this folder){extra}.", css="muted")


#: the first part of a stage file's path -> the stage run.yaml names
_STAGE_OF_FILE = {"relax_fit.yaml": "relax", "vbmm_fit.yaml": "motion", "compare": "compare",
                  "history_modes.yaml": "history", "discover": "discover", "control": "control"}
