"""Prony constants of a ``bpmid.relax/1`` fit in the input syntax of finite-element tools.

- **Abaqus** (``<stem>_abaqus.inp``): ``*MATERIAL``, ``*ELASTIC, MODULI=INSTANTANEOUS`` (E0, nu), ``*VISCOELASTIC,
  TIME=PRONY`` with one data line per term ``g_i, k_i, tau_i`` (shear and bulk relaxation modulus ratios and the
  relaxation time), and, when the fit has a WLF shift, ``*TRS, DEFINITION=WLF`` with ``theta_0, C1, C2``.
  Abaqus needs sum g_i < 1 (a positive long-term modulus); a fit with E_inf = 0 is refused for it.
- **ANSYS** Mechanical APDL (``<stem>_ansys.mac``): ``MP,EX`` and ``MP,PRXY`` (instantaneous), ``TB,PRONY,mat,1,n,SHEAR``
  and ``TB,PRONY,mat,1,n,BULK`` tables (NTEMP = 1, NPTS = n, the number of Prony pairs, as in the tables ANSYS itself
  writes: ``datasets/reference/pyvisco-frequency/ansys_prony_terms_*.MPL``), their ``TBDATA,STLOC,...`` runs of pairs
  (alpha_i, tau_i), six values per command (the most ``TBDATA`` takes), and, with a WLF shift, ``TB,SHIFT,mat,1,3,WLF``
  with ``TBDATA,1,T_r,C1,C2``. Comments are ``!`` lines (APDL ignores everything after ``!``).
- **COMSOL** (two files). ``<stem>_comsol.txt``: a parameter list for Global Definitions > Parameters > Load from File
  (``name value[unit] "description"`` per line, ``#`` comments): long-term shear modulus ``G_inf``, branch shear
  moduli ``G_i`` and relaxation times ``tau_i`` of the generalized Maxwell model, the bulk modulus, and ``T_ref``,
  ``C1_WLF``, ``C2_WLF`` for the WLF shift function. ``<stem>_comsol_branches.txt``: the branch table for the
  Viscoelasticity node's own Load from File button, in the format COMSOL documents for it: three space-separated
  columns, branch number, shear modulus (Pa), relaxation time (s); numbers only.

Relative moduli: g_i = G_i / G0 with G0 = G_inf + sum G_i (the instantaneous shear modulus), k_i = K_i / K0 likewise;
alpha_i (ANSYS) are the same ratios. Units are SI (Pa, s); temperatures are those of the fit (deg C). The WLF form
is log10 a_T = -C1 (T - T_ref) / (C2 + T - T_ref), relaxation times at T being tau_i a_T (bpmid's, pyvisco's and
Abaqus' convention, whose ``*TRS`` data line is theta_0, C1, C2; ANSYS and COMSOL take the same positive C1, C2:
ANSYS writes its shift as log10 A = C1 (T - T_r)/(C2 + T - T_r) with A multiplying time, A = 1/a_T). Every file but
the numbers-only branch table starts with comment lines giving the provenance: bpmid version, the fit file and its
sha256, and the fit's own command and inputs. Sources: docs/notes/i17b-shift.md.
"""
from __future__ import annotations

import math
import re
import textwrap
from pathlib import Path

import numpy as np

from bpmid.errors import InputError

TOOLS = ("abaqus", "ansys", "comsol")
SUFFIX = {"abaqus": "_abaqus.inp", "ansys": "_ansys.mac", "comsol": "_comsol.txt"}
#: the COMSOL branch table (Viscoelasticity node > Load from File)
COMSOL_BRANCHES = "_comsol_branches.txt"


def _wlf(data: dict, path: Path) -> dict | None:
    """``shift.wlf`` of the fit file, checked (None when the fit has no shift)."""
    shift = data.get("shift")
    if shift is None:
        return None
    if not isinstance(shift, dict):
        raise InputError("expected a mapping", path=path, key="shift")
    w = shift.get("wlf")
    if w is None:
        return None
    if not isinstance(w, dict):
        raise InputError("expected a mapping with C1, C2, T_ref", path=path, key="shift.wlf")
    out = {}
    for k in ("C1", "C2", "T_ref"):
        v = w.get(k)
        if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v):
            raise InputError(f"expected a number, found {v!r}", path=path, key=f"shift.wlf.{k}")
        out[k] = float(v)
    if not out["C2"] > 0:
        raise InputError(f"C2 must be positive (C), found {out['C2']:g}", path=path, key="shift.wlf.C2")
    return out


#: the fit's warnings that concern constants a card carries (its Poisson's ratio, a slowest term its data do not
#: separate from E_inf, a fastest term outside the data, shift factors the data do not determine, a WLF that does not
#: describe them): said again with the card and written into its header
CARRIED_WARNINGS = ("Poisson", "are not separated by these data", "is an extrapolation",
                    "do not determine the shift factors", "WLF shift function does not describe")


def _carried(data: dict) -> list[str]:
    return [w for w in (data.get("warnings") or []) if isinstance(w, str) and any(k in w for k in CARRIED_WARNINGS)]


def _provenance_lines(fit_path: Path, data: dict, params, wlf: dict | None) -> list[str]:
    from bpmid import __version__
    from bpmid.io.results import sha256_file
    from bpmid.relax import PAPER_POISSON

    prov = data.get("provenance") if isinstance(data.get("provenance"), dict) else {}
    lines = [f"bpmid {__version__} export of {fit_path.name} (sha256 {sha256_file(fit_path)})",
             f"fit: mode {params.mode or 'unknown'}, {params.tau.size} Prony term(s); units SI (Pa, s)",
             f"nu = {params.poisson_ratio:g}: Poisson's ratio given to the fit, not fitted from its data (bpmid fit relax "
             f"--poisson; the default {PAPER_POISSON:g} is the paper's nearly incompressible rubber)"]
    if prov.get("command"):
        lines.append(f"fit command: {prov['command']}")
    for name, sha in (prov.get("inputs") or {}).items():
        lines.append(f"fit input: {name} (sha256 {sha})")
    lines.append("scope: linear viscoelastic (small strain): elastic moduli with Prony relaxation; no hyperelastic "
                 "law and no density in this card: add them in the FEA model")
    if params.poisson_ratio > 0.49:
        lines.append(f"nu = {params.poisson_ratio:g} is nearly incompressible: use a mixed u-P formulation (hybrid "
                     "elements in Abaqus)")
    if wlf is not None:
        lines.append(f"WLF shift: log10 aT = -C1 (T - T_ref)/(C2 + T - T_ref); T in C; T_ref = {wlf['T_ref']:g} C")
    else:
        lines.append("no temperature shift in this card: the constants hold at the temperature of the tests they were "
                     "fitted on (not recorded in the fit file)")
    lines += [f"from the fit: {w}" for w in _carried(data) if "Poisson" not in w]   # nu is stated above
    # one comment line stays short (input readers limit line length) and free of commas
    out = []
    for ln in lines:
        ln = ln.replace(",", ";")
        # wrapped between words (a command or a path stays whole unless it is longer than a line by itself)
        out += textwrap.wrap(ln, 150, break_long_words=True, break_on_hyphens=False) or [""]
    return out


def _ratios(params):
    G0 = params.G_inf + float(params.G.sum())
    K0 = params.K_inf + float(params.K.sum())
    if not (G0 > 0 and K0 > 0):
        raise InputError("the instantaneous modulus is zero: nothing to export", key="prony.E_inf")
    return G0, K0, params.G / G0, params.K / K0


def _num(v: float) -> str:
    return f"{v:.10e}"


def abaqus_text(params, wlf: dict | None, prov: list[str], name: str) -> str:
    G0, K0, g, k = _ratios(params)
    E0 = params.E_inf + float(params.E.sum())
    if 1.0 - float(g.sum()) <= 1e-12 or 1.0 - float(k.sum()) <= 1e-12:
        raise InputError(f"the long-term modulus is zero (E_inf = 0, so sum g_i = 1; the slowest term has tau = "
                         f"{params.tau.max():.4g} s); Abaqus needs sum g_i < 1. Refit with relax.tau_span_factor: 1 "
                         "(no time constant beyond the data, which usually leaves E_inf > 0) or export to ANSYS or "
                         "COMSOL", key="prony.E_inf")
    out = [f"** {ln}" for ln in prov]
    out += [f"*MATERIAL, NAME={name}",
            "*ELASTIC, MODULI=INSTANTANEOUS",
            f"{_num(E0)}, {params.poisson_ratio:.10g}",
            "*VISCOELASTIC, TIME=PRONY"]
    out += [f"{_num(gi)}, {_num(ki)}, {_num(ti)}" for gi, ki, ti in zip(g, k, params.tau)]
    if wlf is not None:
        out += ["*TRS, DEFINITION=WLF", f"{wlf['T_ref']:.10g}, {wlf['C1']:.10g}, {wlf['C2']:.10g}"]
    return "\n".join(out) + "\n"


def _tbdata(values: list[float]) -> list[str]:
    return [f"TBDATA,{i + 1}," + ",".join(_num(v) for v in values[i:i + 6]) for i in range(0, len(values), 6)]


def ansys_text(params, wlf: dict | None, prov: list[str], mat: int = 1) -> str:
    G0, K0, g, k = _ratios(params)
    E0 = params.E_inf + float(params.E.sum())
    n = params.tau.size
    out = [f"! {ln}" for ln in prov]
    out += [f"MP,EX,{mat},{_num(E0)}", f"MP,PRXY,{mat},{params.poisson_ratio:.10g}",
            f"TB,PRONY,{mat},1,{n},SHEAR"]
    out += _tbdata([v for pair in zip(g, params.tau) for v in pair])
    out += [f"TB,PRONY,{mat},1,{n},BULK"]
    out += _tbdata([v for pair in zip(k, params.tau) for v in pair])
    if wlf is not None:
        out += [f"TB,SHIFT,{mat},1,3,WLF", f"TBDATA,1,{wlf['T_ref']:.10g},{wlf['C1']:.10g},{wlf['C2']:.10g}"]
    return "\n".join(out) + "\n"


def comsol_branch_table(params) -> str:
    """The Viscoelasticity node's branch table: ``branch shear_modulus relaxation_time`` per line (Pa, s), numbers
    only (COMSOL's documented Load from File format for that table)."""
    return "".join(f"{j} {_num(Gj)} {_num(tj)}\n" for j, (Gj, tj) in enumerate(zip(params.G, params.tau), start=1))


def comsol_bulk_shift(params) -> tuple[float, float]:
    """(the long-term tensile modulus a COMSOL card implies, Pa; its difference from the fit's E_inf, %).

    This card relaxes the shear modulus only (COMSOL's generalized Maxwell, deviatoric viscoelastic strain; newer
    versions can also relax the volumetric part, which this card does not give) and keeps the bulk modulus elastic
    at K0, where the fit (and the Abaqus and ANSYS cards) relax both: E(t -> inf) = 9 K0 G_inf / (3 K0 + G_inf) instead of the
    fit's E_inf. Nearly incompressible (nu -> 0.5) the two agree; at nu 0.45 they differ by some 2 %."""
    _G0, K0, _, _ = _ratios(params)

    def tensile(K: float, G: float) -> float:   # E = 9 K G / (3 K + G); a material that relaxes fully has E = 0
        return 9.0 * K * G / (3.0 * K + G) if 3.0 * K + G > 0 else 0.0

    E_long, E_inf = tensile(K0, params.G_inf), tensile(params.K_inf, params.G_inf)
    if E_inf > 0:
        return E_long, 100.0 * (E_long / E_inf - 1.0)
    return E_long, 0.0 if E_long == 0 else float("nan")


#: a COMSOL card whose long-term E differs from the fit's by more than this (%) is said on stderr too
COMSOL_BULK_WARN_PCT = 0.5


def comsol_text(params, wlf: dict | None, prov: list[str], branches: str | None = None) -> str:
    G0, K0, _, _ = _ratios(params)
    E_long, pct = comsol_bulk_shift(params)
    out = [f"# {ln}" for ln in prov]
    if branches:
        import hashlib

        sha = hashlib.sha256(comsol_branch_table(params).encode("utf-8")).hexdigest()
        out.append(f"# the same branches as a table for the Viscoelasticity node (Load from File): {branches}")
        out.append(f"# (that table's sha256 {sha}: how a later export knows the table as its own)")
    out.append('# generalized Maxwell model: G(t) = G_inf + sum_i G_i exp(-t/tau_i); the bulk modulus is elastic '
               "(the instantaneous K0)")
    out.append(f"# so the long-term tensile modulus of this card is {_num(E_long)} Pa, {pct:+.3g} % from the fit's "
               f"E_inf (the Abaqus and ANSYS cards relax the bulk modulus too and match the fit)")
    out.append(f'G_inf {_num(params.G_inf)}[Pa] "long-term shear modulus"')
    out.append(f'K_bulk {_num(K0)}[Pa] "bulk modulus (instantaneous)"')
    out.append(f'nu_inst {params.poisson_ratio:.10g} "Poisson\'s ratio given to the fit (not fitted)"')
    for j, (Gj, tj) in enumerate(zip(params.G, params.tau), start=1):
        out.append(f'G_{j} {_num(Gj)}[Pa] "shear modulus of Maxwell branch {j}"')
        out.append(f'tau_{j} {_num(tj)}[s] "relaxation time of Maxwell branch {j}"')
    if wlf is not None:
        out.append(f'T_ref {wlf["T_ref"]:.10g}[degC] "WLF reference temperature"')
        out.append(f'C1_WLF {wlf["C1"]:.10g} "WLF constant C1"')
        out.append(f'C2_WLF {wlf["C2"]:.10g}[K] "WLF constant C2"')
    return "\n".join(out) + "\n"


def export_fea(fit_path: Path, tool: str, out_dir: Path) -> list[Path]:
    """Write the Prony constants of a ``bpmid.relax/1`` fit for ``tool`` (abaqus, ansys or comsol) into ``out_dir``.

    Returns the paths written (one file; two for COMSOL: the parameter list and the branch table). Bad input raises :class:`bpmid.errors.InputError` naming the key; the file
    is written atomically (whole or not at all).
    """
    from bpmid.io.atomic import write_text
    from bpmid.io.results import read_result
    from bpmid.relax.result import relax_fit_from_mapping

    fit_path = Path(fit_path)
    tool = str(tool).strip().lower()
    if tool not in TOOLS:
        raise InputError(f"unknown tool {tool!r} (expected one of {', '.join(TOOLS)})", key="tool")   # this call's argument
    data = read_result(fit_path, "bpmid.relax/")
    params = relax_fit_from_mapping(data, fit_path)
    if params.tau.size == 0:
        raise InputError("the fit has no Prony terms: nothing viscoelastic to export", path=fit_path,
                         key="prony.terms")
    wlf = _wlf(data, fit_path)
    prov = _provenance_lines(fit_path, data, params, wlf)
    stem = fit_path.stem
    try:
        if tool == "abaqus":
            name = re.sub(r"[^A-Za-z0-9_\-]", "_", stem).upper() or "BPMID"
            if not name[0].isalpha():
                name = "M_" + name
            text = abaqus_text(params, wlf, prov, name[:80])
        elif tool == "ansys":
            text = ansys_text(params, wlf, prov)
        else:
            text = comsol_text(params, wlf, prov, f"{stem}{COMSOL_BRANCHES}")
    except InputError as exc:
        if exc.path is None:
            raise InputError(exc.message, path=fit_path, key=exc.key) from None
        raise
    out_dir = Path(out_dir)
    if out_dir.exists() and not out_dir.is_dir():
        raise InputError("--out must be a folder, found a file", path=out_dir, key="--out")
    out = out_dir / f"{stem}{SUFFIX[tool]}"
    write_text(out, text)
    # what the fit said of its Poisson's ratio (the bulk modulus follows it) and of the constants its data do not
    # determine applies to every card: said again here
    carried = _carried(data)
    if carried:
        from bpmid.io.plausibility import emit

        emit([f"{out.name}: from {fit_path.name}: {w}" for w in carried])
    if tool != "comsol":
        return [out]
    pct = comsol_bulk_shift(params)[1]
    if abs(pct) > COMSOL_BULK_WARN_PCT:
        from bpmid.io.plausibility import emit

        emit([f"{out.name}: this COMSOL card keeps the bulk modulus elastic (K0), so at Poisson's ratio "
              f"{params.poisson_ratio:g} the card's long-term tensile modulus is {pct:+.3g} % from the fit's E_inf "
              f"(the Abaqus and ANSYS cards match the fit); nearly incompressible (nu near 0.5) the two agree"])
    table = out_dir / f"{stem}{COMSOL_BRANCHES}"
    write_text(table, comsol_branch_table(params))
    return [out, table]
