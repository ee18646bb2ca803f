"""Provenance: what was run, with which inputs (sha256), in which stages. Last, and collapsed."""
from __future__ import annotations

from bpmid import __version__
from bpmid.report.doc import fmt

KEY = "provenance"
TITLE = "Provenance: what was run"


def build(doc, st, figs) -> None:
    doc.section(KEY, TITLE, collapsed=True)
    prov = st.provenance()
    cfg = prov.get("config") if isinstance(prov.get("config"), dict) else {}
    doc.table(["item", "value"], [["bpmid version (this report)", __version__],
                                  ["bpmid version (the run)", prov.get("bpmid_version", "-")],
                                  ["command", prov.get("command", "-")],
                                  ["config", cfg.get("path", "-")],
                                  ["config sha256", cfg.get("sha256", "-")],
                                  ["created", prov.get("created", "-")],
                                  ["run id", prov.get("run_id", "-")],
                                  ["seed", prov.get("seed", "-")]])
    if st.run is not None and st.run.stages:
        doc.p("Stages of the run (wall time on this machine):")
        doc.table(["stage", "status", "seconds", "outputs"],
                  [[s.name, "this report" if (s.name, s.status) == ("report", "running") else
                    (s.status + (f" ({s.note})" if s.note else "")
                     + ("; its files were since replaced by another command (STALE)" if s.name in st.foreign else "")),
                    _seconds(s.seconds), ", ".join(s.outputs) or "-"]
                   for s in st.run.stages])
    inputs = st.inputs()
    if inputs:
        doc.p(f"Input files ({len(inputs)}) and their sha256:")
        doc.table(["input file", "sha256"], [[k, v] for k, v in sorted(inputs.items())])
    if st.problems:
        doc.p("Files that could not be used:")
        doc.table(["file", "problem"], [[p.path, p.what] for p in st.problems])


def _seconds(x) -> str:
    """A stage's wall time to 0.1 s: what it is good for, and never a string of digits that reads like a
    measured or quoted number elsewhere in the report (a discover stage of 0.936 s printed exactly as the paper's
    R^2 of 0.936)."""
    try:
        return f"{float(x):.1f}"
    except (TypeError, ValueError):
        return "-"
