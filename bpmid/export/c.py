"""A fitted model as dependency-free C99 for a real-time controller (``bpmid export FIT.yaml --to c``).

Writes ``bpmid_model.h``, ``bpmid_model.c`` and ``main.c`` (a stdin filter) into a folder, whole or not
at all. The model code has no heap allocation and no global state and includes only ``<math.h>``; its
state is one struct whose size is fixed at compile time; the fit's constants are baked in as exact
double literals, and the header comment carries the provenance (bpmid version, sha256 of the fit file).

Two model kinds:

- ``vbmm`` (a ``bpmid.vbmm/1`` file): the VBMM with any number of branches, either closure, shared or
  split time constants, recursive (exact) history, plus the catalogue effects of an optional
  ``effects`` list in the file (see :func:`bpmid.effects.fitfile.effects_from_yaml`): pressure_lag (first-order lag; a dead
  time is refused), braid_friction (mean of play operators, or of friction operators with a
  pressure-proportional band and an elastic stick), angle_offset, second_relaxation (one more
  branch), strain_stiffening, asymmetric_relaxation and thermal_softening. ``step_forward`` is the
  forward model of ``bpmid predict``; ``step_inverse`` is the feedforward of eq. 20 (closed form),
  followed by the exact causal inverses of the pressure terms (lag: the discrete lag solved for its
  input; ``step_feedforward`` solves it for a command held over the step instead, which never rings; plays: the smallest input move that gives the wanted output; friction operators: the same, by
  bisection on their mean output, which never falls as the input rises).
- ``maxwell-slip`` (``--model maxwell-slip``): the Maxwell-slip model of a ``bpmid.compare/1`` file
  (pressure in bar gauge -> angle in deg; ``step_inverse`` solves it for the pressure) or the MS-PI
  feedforward of a ``bpmid.control/1`` file (angle in deg -> pressure in bar gauge, seed 003's inverse
  form; ``step_forward`` solves it for the angle). The solve takes the root nearest the previous input
  (exact where the map is strictly monotone; on a flat stretch the smallest move).

Units at the C interface: time s, gauge pressure Pa, angle deg.
"""
from __future__ import annotations

import dataclasses
import hashlib
import math
import statistics
from importlib import resources
from pathlib import Path
from string import Template
from typing import Sequence

from bpmid.errors import InputError
from bpmid.models.vbmm.rig import STEP_SPREAD, fit_rig, fitted_pressure_span

FILES = ("bpmid_model.h", "bpmid_model.c", "main.c")
MODELS = ("vbmm", "vbmm-fit", "vbmm-mat", "maxwell-slip")
#: catalogue effects this exporter turns into C (every other id is refused, naming it)
EXPORTABLE_EFFECTS = ("pressure_lag", "braid_friction", "angle_offset", "second_relaxation", "strain_stiffening",
                      "asymmetric_relaxation", "thermal_softening")
PA_PER_BAR = 1e5


def _lit(x: float) -> str:
    """An exact C literal of the double ``x`` (shortest round-trip repr), cast to the build's real type."""
    x = float(x)
    if not math.isfinite(x):
        raise InputError(f"a constant of the fit is not finite ({x!r}); it cannot be exported")
    return f"R({x!r})"


def _template(name: str) -> Template:
    return Template(resources.files("bpmid.export").joinpath("templates", name).read_text(encoding="utf-8"))


def _sha256(path: Path) -> str:
    return hashlib.sha256(Path(path).read_bytes()).hexdigest()


def _comment(lines: Sequence[str]) -> str:
    return "".join(f" * {ln}\n".replace(" \n", "\n") for ln in lines)


# ---------------------------------------------------------------------------------------------
# the VBMM with its causal effects
# ---------------------------------------------------------------------------------------------


@dataclasses.dataclass(frozen=True)
class CausalVBMM:
    """The VBMM of a fit split into what the C code steps: the VBMM (structural effects applied), the
    pressure terms in order (("lag", tau_s), ("plays", radii_pa) or ("frictions", (r_pa, mu, slip_pa) per
    element in a row)), the modulus scale of thermal
    softening ((amount, T_s) or None) and the angle offset (deg)."""

    model: object
    chain: tuple = ()
    thermal: tuple | None = None
    offset_deg: float = 0.0
    effect_ids: tuple = ()


def causal_vbmm(aug, path=None) -> CausalVBMM:
    """Split an :class:`~bpmid.effects.base.AugmentedVBMM` into its causal C form; an effect without
    one is refused (InputError naming it and why)."""
    chain, thermal, offset = [], None, 0.0
    p = aug.params
    for i, e in enumerate(aug.effects):
        if e.id not in EXPORTABLE_EFFECTS:
            raise InputError(f"effect {e.id} has no causal C form in this exporter (exportable: "
                             f"{', '.join(EXPORTABLE_EFFECTS)}); export the fit without it", path=path,
                             key=f"effects[{i}].id")
        if e.id == "pressure_lag":
            if getattr(e, "dead_time", 0.0) != 0.0:
                raise InputError("pressure_lag with a dead time cannot be exported: a dead time needs a sample "
                                 "buffer whose length depends on the sample rate, and its inverse (the "
                                 "feedforward) would need the future", path=path, key=f"effects[{i}].settings.dead_time")
            if e.sat_per_pa(p) > 0.0:
                raise InputError("pressure_lag with a flow-limited fill (sat > 0) cannot be exported yet: its C step "
                                 "and its inverse are not written; refit with the fill held linear (a config with "
                                 "discover: {hold: {pressure_lag.sat: 0}}) to export a linear lag", path=path,
                                 key=f"effects[{i}].parameters.sat")
            for tau in e.taus(p):          # one lag, or two in cascade (pressure_lag.share > 0)
                if tau != 0.0:
                    chain.append(("lag", float(tau)))
        elif e.id == "braid_friction":
            # the play form (mu = slip = 0) as play operators; the general form (a pressure-proportional band,
            # an elastic stick) as friction operators, one (r, mu, slip) per element: the plant's causal chain
            chain.extend(e.causal_pressure(p))
        elif e.id == "angle_offset":
            offset += p.value("angle_offset.offset")
        elif e.id == "thermal_softening":
            a = p.value("thermal_softening.amount")
            if a != 0.0:
                thermal = (float(a), float(p.value("thermal_softening.T")))
    model = aug.model().replace(history="recursive")
    return CausalVBMM(model, tuple(chain), thermal, float(offset), tuple(e.id for e in aug.effects))


def load_vbmm_fit(path: str | Path):
    """The :class:`~bpmid.effects.base.AugmentedVBMM` of a ``bpmid.vbmm/1`` file (its ``effects`` list
    included; recursive history). A fit made with a history window too short for its time constants is
    refused: the C runs the exact history, a model other than the one fitted."""
    from bpmid.effects.base import AugmentedVBMM
    from bpmid.effects.fitfile import augmented_from_file
    from bpmid.io.results import read_result
    from bpmid.models.vbmm import fitted_history_note, load_vbmm

    aug = augmented_from_file(load_vbmm(Path(path)), path)
    aug = aug if isinstance(aug, AugmentedVBMM) else AugmentedVBMM(aug)
    note = fitted_history_note(read_result(Path(path), "bpmid.vbmm/").get("model"), aug.model(),
                               runs_as="the exact (recursive) history the exported C runs", window_remedy=False)
    if note:
        raise InputError(note, path=path, key="model.history")
    return aug


def load_vbmm_from_compare(path: str | Path, name: str):
    """The VBMM family ``name`` (vbmm-fit or vbmm-mat) of a ``bpmid.compare/1`` file, as an
    :class:`~bpmid.effects.base.AugmentedVBMM` without effects (recursive history)."""
    from bpmid.effects.base import AugmentedVBMM
    from bpmid.io.results import read_result, require
    from bpmid.models.vbmm import VBMM, geometry_from_yaml
    from bpmid.motion_fit import material_from_params
    from bpmid.params import Param, ParamSet, parse_param_entry

    path = Path(path)
    data = read_result(path, "bpmid.compare/")
    models = data.get("models")
    if not isinstance(models, dict) or not isinstance(models.get(name), dict):
        raise InputError(f"the comparison holds no {name} model (run bpmid compare with --models ...,{name})",
                         path=path, key=f"models.{name}")
    key = f"models.{name}"
    prm = require(data, f"{key}.parameters", path)
    if not isinstance(prm, dict):
        raise InputError("expected a mapping name -> {value, stderr, unit}", path=path, key=f"{key}.parameters")
    params = ParamSet(Param(n, parse_param_entry(v, path=path, key=f"{key}.parameters.{n}")[0],
                            (v.get("unit") if isinstance(v, dict) else None) or "") for n, v in prm.items())
    try:
        mat = material_from_params(params)
    except KeyError as exc:
        raise InputError("missing key", path=path, key=f"{key}.parameters.{exc.args[0]}") from None
    except InputError as exc:
        raise InputError(exc.message, path=path, key=f"{key}.parameters") from None
    closure = require(data, f"{key}.closure", path)
    if closure not in ("paper", "consistent"):
        raise InputError(f"unknown closure {closure!r} (paper or consistent)", path=path, key=f"{key}.closure")
    geo = geometry_from_yaml(require(data, f"{key}.geometry", path), path)
    return AugmentedVBMM(VBMM(material=mat, geometry=geo, closure=closure))


def _vbmm_sources(cv: CausalVBMM, meta: dict) -> dict[str, str]:
    import numpy as np

    m = cv.model
    g = m.geometry
    mat = m.material
    th, alpha0, R0, l0, n = g.th, g.alpha0, g.R0, g.l0, g.n
    # the same double arithmetic as bpmid.models._vbmm_kernels, done once here
    pn2 = 4.0 * math.pi * math.pi * n * n
    consts = {
        "TH": th, "R0": R0, "L0": l0, "PN2": pn2, "DD": l0 * l0 + pn2 * R0 * R0, "EE": pn2 * pn2 * R0 * R0,
        "AA": -math.pi * math.pi * n * n / (l0 * l0), "BB": -4.0 * math.pi * math.pi * n * n * R0 / (l0 * l0),
        "L0CA": l0 * math.cos(alpha0), "CA0": math.cos(alpha0), "BETA_MAX": 4.0 * math.pi,
        # the gauge pressure (Pa) that holds the largest angle relaxed: a feedforward above it is out of range
        "P_TOP": float(m.equilibrium_pressure(np.array([4.0 * math.pi]))[0]),
        "GINF": mat.G_inf, "KINF": mat.K_inf,
    }
    g0 = mat.G_inf
    for v in mat.G:
        g0 += v
    k0 = mat.K_inf
    for v in mat.K:
        k0 += v
    consts["G0FULL"] = g0
    consts["K0FULL"] = k0
    if m.fall_ratio != 1.0:
        consts["FALL"] = m.fall_ratio
    if m.stiffening != 0.0:
        consts["STIFF"] = m.stiffening
    const_lines = [f"#define {k} {_lit(v)}" for k, v in consts.items()]
    # inputs beyond these are refused (status 3): no rig logs them, and they overflow a float build. Double literals:
    # they bound the double arguments (in R() a float build compared them in double all the same, and
    # -Wdouble-promotion, which single-FPU projects use, said so)
    const_lines += ["#define P_INPUT_MAX 1e9", "#define ANGLE_INPUT_MAX 1e6"]
    const_lines.append(f"#define ANGLE_OFFSET_DEG {float(cv.offset_deg)!r}")
    nb = mat.n_branches
    shared = (not mat.split) or all(a == b for a, b in zip(mat.tauG, mat.tau_K))
    fields, decay, hist, commit, reset = [], [], [], [], []
    fields += ["    double dt_a;       /* dt and fall ratio the cached decays belong to */",
               "    bpmid_real r_a;",
               "    bpmid_real dt_prev;   /* previous step (s), for the extrapolated start */",
               "    bpmid_real p_prev, p_prev2;   /* pressures the rubber saw at the previous two steps (Pa) */",
               "    bpmid_real d_prev;    /* dP/dbeta at the last evaluation (Pa/rad), for the start of the next solve */",
               "    bpmid_real e1, e2;    /* strains of the previous step */",
               "    bpmid_real b1, b2;    /* angles (rad) of the previous two steps */",
               "    int falling;          /* 1 when the angle fell on the previous step (asymmetric relaxation) */"]
    for j in range(nb):
        taus = [("", mat.tauG[j])] if shared else [("G", mat.tauG[j]), ("K", mat.tau_K[j])]
        for tag, tau in taus:
            fields.append(f"    bpmid_real a{tag}{j};   /* decay of branch {j + 1} over the step (tau {tau!r} s) */")
            decay.append(f"        s->a{tag}{j} = B_EXP(-dt / ({_lit(tau)} * r));")
        aG = f"s->a{'' if shared else 'G'}{j}"
        aK = f"s->a{'' if shared else 'K'}{j}"
        fields.append(f"    bpmid_real hG1_{j}, hG2_{j}, hK1_{j}, hK2_{j};   /* branch {j + 1} states */")
        for c, M, a, h, x in (("cG1", mat.G[j], aG, f"hG1_{j}", "e1"), ("cG2", mat.G[j], aG, f"hG2_{j}", "e2"),
                              ("cK1", mat.K[j], aK, f"hK1_{j}", "e1"), ("cK2", mat.K[j], aK, f"hK2_{j}", "e2")):
            hist.append(f"    c->{c} += {_lit(M)} * ({a} * s->{h} - s->{x});")
            commit.append(f"        s->{h} = {a} * s->{h} + d{x[-1]};")
            reset.append(f"    s->{h} = R(0.0);")
        for tag, _tau in taus:
            reset.append(f"    s->a{tag}{j} = R(1.0);")
    # strain stiffening and the thermal modulus scale (as pressure_at: s = scale (1 + c e1^2))
    if m.stiffening != 0.0:
        scale = ("    const bpmid_real s = c->sc * (R(1.0) + STIFF * e1 * e1);\n"
                 "    const bpmid_real ds = c->sc * STIFF * R(2.0) * e1 * dF;\n")
    else:
        scale = "    const bpmid_real s = c->sc;\n    const bpmid_real ds = R(0.0);\n"
    if m.closure == "paper":
        closure = ("    const bpmid_real gb = L0CA * (R(1.0) + u3 / R0);\n"
                   "    const bpmid_real dgb = L0CA * de2;\n"
                   "    const bpmid_real den = R(1.0) - R(2.0) * gb * F;\n"
                   "    const bpmid_real nm = s2 * gb + s1 * e1;\n"
                   "    const bpmid_real in = s2 + nm / den;\n"
                   "    const bpmid_real din = ds2 + ((ds2 * gb + s2 * dgb + ds1 * e1 + s1 * dF) * den\n"
                   "                                  + nm * R(2.0) * (dgb * F + gb * dF)) / (den * den);\n")
    else:
        closure = ("    const bpmid_real ca = CA0 * (R(1.0) + e2);\n"
                   "    const bpmid_real dca = CA0 * de2;\n"
                   "    const bpmid_real in = s2 + s1 * e1 / (R(1.0) - ca);\n"
                   "    const bpmid_real din = ds2 + ((ds1 * e1 + s1 * dF) * (R(1.0) - ca) + s1 * e1 * dca)\n"
                   "                                 / ((R(1.0) - ca) * (R(1.0) - ca));\n")
    if cv.thermal is not None:
        a, T = cv.thermal
        thermal = (f"    /* thermal softening: moduli times 1 - {a!r} (1 - exp(-(t - t0) / {T!r} s)) */\n"
                   f"    return (bpmid_real)(1.0 - {a!r} * (1.0 - exp(-(t - s->t0) / {T!r})));\n")
    else:
        thermal = "    return R(1.0);\n"
    if m.fall_ratio != 1.0:
        fall_f = "    if (s->k > 0 && s->falling) {\n        r = FALL;\n    }\n"
        fall_i = _FALL_INVERSE
        fall_c = _FALL_CHECK
    else:
        fall_f = fall_i = fall_c = ""
    chain_code, chain_fields, chain_reset = _chain_sources(cv.chain)
    fields += chain_fields
    reset += chain_reset
    desc = _vbmm_description(cv, meta)
    subs = dict(meta, description=_comment(desc), state_fields="".join(f + "\n" for f in fields),
                constants="\n".join(const_lines) + "\n", scale_code=scale, closure_code=closure,
                decay_code="".join(d + "\n" for d in decay), history_code="".join(h + "\n" for h in hist),
                commit_code="".join(c + "\n" for c in commit), thermal_code=thermal,
                reset_code="".join(r + "\n" for r in reset), chain_code=chain_code, fall_forward=fall_f,
                fall_inverse=fall_i, fall_check=fall_c)
    return {"bpmid_model.h": _template("common.h.in").substitute(subs),
            "bpmid_model.c": _template("vbmm.c.in").substitute(subs),
            "main.c": _template("main.c.in").substitute(subs)}


#: the forward step's check of the direction it assumed (asymmetric relaxation): the angle falling, as
#: :func:`bpmid.models._vbmm_kernels.forward_kernel` decides it (solved with the last step's direction, again with
#: the other when the angle moves the other way, kept when that one is consistent)
_FALL_CHECK = """    if (s->k > 0 && (b < s->b1 - B_DIR_TOL) != (r != R(1.0))) {
        /* the angle moved against the direction assumed: solve again with the other direction's rate */
        const bpmid_real r1 = r;
        bpmid_real b2, d2 = s->d_prev;
        int st2 = BPMID_STATUS_OK;
        r = r1 != R(1.0) ? R(1.0) : FALL;
        history(s, dt, r, &c);
        b2 = solve_beta(p, x0, &c, &st2, &d2);
        if ((b2 < s->b1 - B_DIR_TOL) == (r != R(1.0))) {
            b = b2;
            s->status = st2;
            s->d_prev = d2;
        } else {
            /* neither is consistent (a reversal within the step): the first solve stands, with its decays */
            r = r1;
            history(s, dt, r, &c);
        }
    }
    s->falling = r != R(1.0);
"""


#: the inverse step's choice of rate (asymmetric relaxation): the forward's rule read backwards, so that the
#: pressure returned brings the forward step, from the direction it last took, to the angle asked. The forward
#: solves with its last direction's rate first and keeps the other rate only when that one's angle is consistent
#: (below b1 when falling, not below when rising); otherwise the first solve stands. A solve with rate r comes
#: below b1 exactly when the pressure is below P_r(b1). Near a reversal the forward is not one to one (two
#: pressures give one angle, one with each rate), as friction's dead band is not: of two pressures that both
#: give the angle, the one nearer the last step's keeps the feedforward continuous
_FALL_INVERSE = """    if (s->k > 0) {
        bpmid_step_consts c1, cf;
        bpmid_real d1, p1, pf;
        int ok1, okf;
        const bpmid_real edge = s->b1 - B_DIR_TOL;   /* the angle falls when it ends below this */
        const int down = b < edge;
        c1.sc = cf.sc = modulus_scale(s, t);
        history(s, dt, R(1.0), &c1);
        history(s, dt, FALL, &cf);
        p1 = model_pressure(b, &c1, &d1);
        pf = model_pressure(b, &cf, &d1);
        if (down) {
            okf = s->falling || pf < model_pressure(edge, &c1, &d1);
            ok1 = !s->falling && p1 >= model_pressure(edge, &cf, &d1);
        } else {
            ok1 = !s->falling || p1 >= model_pressure(edge, &cf, &d1);
            okf = s->falling && pf < model_pressure(edge, &c1, &d1);
        }
        if (ok1 && okf) {
            r = B_FABS(pf - s->p_prev) < B_FABS(p1 - s->p_prev) ? FALL : R(1.0);
        } else if (okf || (!ok1 && down)) {
            r = FALL;   /* (neither: no pressure gives b from here; the rate of its direction is the nearest) */
        }
        unreach = !ok1 && !okf;
        s->falling = r != R(1.0);
    }
"""


def _chain_sources(chain) -> tuple[str, list[str], list[str]]:
    """C of the pressure terms: ``pressure_chain_forward`` (logged -> rubber pressure) and
    ``pressure_chain_inverse`` (rubber -> logged pressure, causal inverses in reverse order; ``held``: the lag's
    inverse for a command held over each step instead of the exact inverse of the forward's interpolated lag)."""
    fields, reset, fwd, inv = [], [], [], []
    for i, (op, val) in enumerate(chain):
        if op == "lag":
            fields.append(f"    bpmid_real lag{i}_x, lag{i}_y, lag{i}_a;   /* pressure lag {val!r} s: input, output, decay */")
            fields.append(f"    double lag{i}_dt;")
            reset.append(f"    s->lag{i}_x = s->lag{i}_y = R(0.0);\n    s->lag{i}_a = R(1.0);\n    s->lag{i}_dt = -1.0;")
            tau = _lit(val)
            fwd.append(
                f"    /* first-order lag, tau = {val!r} s, exact for an input linear between samples */\n"
                f"    if (s->k == 0) {{\n        y = x;\n    }} else {{\n"
                f"        if ((double)dt != s->lag{i}_dt) {{\n            s->lag{i}_a = B_EXP(-dt / {tau});\n"
                f"            s->lag{i}_dt = dt;\n        }}\n"
                f"        y = s->lag{i}_a * s->lag{i}_y + (R(1.0) - s->lag{i}_a) * s->lag{i}_x\n"
                f"            + (x - s->lag{i}_x) * (R(1.0) - {tau} * (R(1.0) - s->lag{i}_a) / dt);\n    }}\n"
                f"    s->lag{i}_x = x;\n    s->lag{i}_y = y;\n    x = y;\n")
            inv.append(
                f"    /* inverse of the lag. Exact (bpmid_step_inverse): the forward's lag solved for its input, linear\n"
                f"     * between samples; it has a pole near -1, so on a reference the model did not make (a step) it\n"
                f"     * swings sign every sample. Held (bpmid_step_feedforward): y_k = a y_(k-1) + (1 - a) x solved for\n"
                f"     * a command x held over the step, as a controller's output is: never rings. */\n"
                f"    if (s->k == 0) {{\n        x = y;\n    }} else {{\n"
                f"        if ((double)dt != s->lag{i}_dt) {{\n            s->lag{i}_a = B_EXP(-dt / {tau});\n"
                f"            s->lag{i}_dt = dt;\n        }}\n"
                f"        if (held) {{\n"
                f"            x = (y - s->lag{i}_a * s->lag{i}_y) / (R(1.0) - s->lag{i}_a);\n        }} else {{\n"
                f"            x = s->lag{i}_x + (y - s->lag{i}_a * s->lag{i}_y - (R(1.0) - s->lag{i}_a) * s->lag{i}_x)\n"
                f"                / (R(1.0) - {tau} * (R(1.0) - s->lag{i}_a) / dt);\n        }}\n    }}\n"
                f"    s->lag{i}_x = x;\n    s->lag{i}_y = y;\n    y = x;\n")
        elif op == "frictions":
            ne = len(val) // 3
            fields.append(f"    bpmid_real fr{i}_f[{ne}];   /* friction operators: friction pressure (Pa) per element */")
            fields.append(f"    bpmid_real fr{i}_x;")
            reset.append(f"    {{\n        int e;\n        for (e = 0; e < {ne}; ++e) {{\n            s->fr{i}_f[e] = R(0.0);\n"
                         f"        }}\n    }}\n    s->fr{i}_x = R(0.0);")
            par = "{" + ", ".join(_lit(v) for v in val) + "}"
            fwd.append(
                f"    /* braid friction: the mean of {ne} friction operator(s) (r, mu, slip) */\n"
                f"    {{\n        static const bpmid_real pp[{3 * ne}] = {par};\n"
                f"        x = friction_mean(s->fr{i}_f, pp, {ne}, &s->fr{i}_x, x, s->k == 0, 1);\n    }}\n")
            inv.append(
                f"    /* inverse of the friction operators: the smallest move of their input that gives the wanted mean */\n"
                f"    {{\n        static const bpmid_real pp[{3 * ne}] = {par};\n"
                f"        x = friction_inverse(s->fr{i}_f, pp, {ne}, &s->fr{i}_x, y, s->k == 0);\n"
                f"        y = x;\n    }}\n")
        else:
            radii = list(val)
            nr = len(radii)
            fields.append(f"    bpmid_real play{i}_v[{nr}];   /* play operators (dead bands {', '.join(repr(r) for r in radii)} Pa) */")
            fields.append(f"    bpmid_real play{i}_x;")
            reset.append(f"    {{\n        int e;\n        for (e = 0; e < {nr}; ++e) {{\n            s->play{i}_v[e] = R(0.0);\n"
                         f"        }}\n    }}\n    s->play{i}_x = R(0.0);")
            rad = "{" + ", ".join(_lit(r) for r in radii) + "}"
            fwd.append(
                f"    /* braid friction: the mean of {nr} play operator(s) */\n"
                f"    {{\n        static const bpmid_real rr[{nr}] = {rad};\n        bpmid_real acc = R(0.0);\n        int e;\n"
                f"        for (e = 0; e < {nr}; ++e) {{\n"
                f"            bpmid_real v = s->k == 0 ? x : s->play{i}_v[e];\n"
                f"            if (v < x - rr[e]) {{\n                v = x - rr[e];\n            }} else if (v > x + rr[e]) {{\n"
                f"                v = x + rr[e];\n            }}\n"
                f"            s->play{i}_v[e] = v;\n            acc += v;\n        }}\n"
                f"        s->play{i}_x = x;\n        x = acc / R({float(nr)!r});\n    }}\n")
            inv.append(
                f"    /* inverse of the plays: the smallest move of their input that gives the wanted mean */\n"
                f"    {{\n        static const bpmid_real rr[{nr}] = {rad};\n"
                f"        x = play_inverse(s->play{i}_v, rr, {nr}, s->play{i}_x, y, s->k == 0);\n"
                f"        s->play{i}_x = x;\n        y = x;\n    }}\n")
    helpers = ""
    if any(op == "plays" for op, _v in chain):
        helpers = f"#define PLAY_MAX {max(len(v) for op, v in chain if op == 'plays')}\n" + _PLAY_INVERSE
    if any(op == "frictions" for op, _v in chain):
        helpers += _FRICTION_OPERATORS
    code = helpers
    code += ("/* The logged pressure (Pa) -> the pressure the rubber sees, through the pressure terms in order. */\n"
             "static bpmid_real pressure_chain_forward(bpmid_state *s, bpmid_real dt, bpmid_real x)\n{\n"
             "    bpmid_real y = x;\n    (void)s;\n    (void)dt;\n    (void)y;\n" + "".join(fwd) + "    return x;\n}\n\n")
    code += ("/* The rubber's pressure (Pa) -> the logged pressure that gives it (the terms inverted, in reverse order). */\n"
             "static bpmid_real pressure_chain_inverse(bpmid_state *s, bpmid_real dt, bpmid_real y, int held)\n{\n"
             "    bpmid_real x = y;\n    (void)s;\n    (void)dt;\n    (void)x;\n    (void)held;\n"
             + "".join(reversed(inv)) + "    return y;\n}\n")
    return code, fields, reset


_PLAY_INVERSE = """/* Input x of n play operators (states v, dead bands r, previous input xp) whose mean output is y; the
 * states are committed. The mean is non-decreasing and piecewise linear in x: walk its breakpoints
 * from xp in the direction of y and solve on the segment that holds y (the smallest move). */
static bpmid_real play_inverse(bpmid_real *v, const bpmid_real *r, int n, bpmid_real xp, bpmid_real y, int first)
{
    bpmid_real cur = R(0.0), x = xp, bp[PLAY_MAX];
    int idx[PLAY_MAX], e, m, used[PLAY_MAX];
    if (first) {
        for (e = 0; e < n; ++e) {
            v[e] = y;
        }
        return y;
    }
    for (e = 0; e < n; ++e) {
        cur += v[e];
    }
    cur = cur / (bpmid_real)n;
    if (y != cur) {
        const int up = y > cur;
        /* breakpoints where element e starts to move: v + r (rising) or v - r (falling), nearest first */
        for (e = 0; e < n; ++e) {
            int j = e;
            bpmid_real b = up ? v[e] + r[e] : v[e] - r[e];
            while (j > 0 && (up ? bp[j - 1] > b : bp[j - 1] < b)) {
                bp[j] = bp[j - 1];
                idx[j] = idx[j - 1];
                --j;
            }
            bp[j] = b;
            idx[j] = e;
            used[e] = 0;
        }
        for (m = 1; m <= n; ++m) {
            bpmid_real rest = R(0.0), sr = R(0.0);
            used[idx[m - 1]] = 1;
            for (e = 0; e < n; ++e) {
                if (used[e]) {
                    sr += r[e];
                } else {
                    rest += v[e];
                }
            }
            /* the m moving elements give x -+ r each, the others hold */
            x = up ? ((bpmid_real)n * y - rest + sr) / (bpmid_real)m : ((bpmid_real)n * y - rest - sr) / (bpmid_real)m;
            if (m == n || (up ? x <= bp[m] : x >= bp[m])) {
                break;
            }
        }
    }
    for (e = 0; e < n; ++e) {
        if (v[e] < x - r[e]) {
            v[e] = x - r[e];
        } else if (v[e] > x + r[e]) {
            v[e] = x + r[e];
        }
    }
    return x;
}

"""

_FRICTION_OPERATORS = """/* n friction operators (bpmid.effects._kernels.friction_step): parameters (r, mu, slip) per element in
 * a row, states f (friction pressure, Pa), previous input *xp_io. Returns the mean output for the input x,
 * the mean of x - f_e; with commit, the states and xp take the step. First step: unloaded (f = 0). */
static bpmid_real friction_mean(bpmid_real *f, const bpmid_real *pp, int n, bpmid_real *xp_io, bpmid_real x,
                                int first, int commit)
{
    bpmid_real acc = R(0.0);
    int e;
    for (e = 0; e < n; ++e) {
        bpmid_real fe = R(0.0);
        if (!first) {
            const bpmid_real w = pp[3 * e] + pp[3 * e + 1] * (x > R(0.0) ? x : R(0.0));
            const bpmid_real den = w + pp[3 * e + 2];
            fe = f[e];
            if (den > R(0.0)) {
                fe = fe + (x - *xp_io) * (w / den);
            }
            if (fe > w) {
                fe = w;
            } else if (fe < -w) {
                fe = -w;
            }
        }
        if (commit) {
            f[e] = fe;
        }
        acc += x - fe;
    }
    if (commit) {
        *xp_io = x;
    }
    return acc / (bpmid_real)n;
}

/* Returns the input x of the friction operators whose mean output is y, the states committed. The mean output never
 * falls as the input rises (sticking it moves by slip / (w + slip) of the input, sliding by 1 -+ mu), so
 * the input is bracketed from the previous one in the direction of y and bisected to the smallest move. */
static bpmid_real friction_inverse(bpmid_real *f, const bpmid_real *pp, int n, bpmid_real *xp_io, bpmid_real y,
                                   int first)
{
    bpmid_real lo, hi, step, g, xp = *xp_io;
    int it;
    if (first) {
        (void)friction_mean(f, pp, n, xp_io, y, 1, 1);
        return y;
    }
    g = friction_mean(f, pp, n, xp_io, xp, 0, 0);
    if (g == y) {
        (void)friction_mean(f, pp, n, xp_io, xp, 0, 1);
        return xp;
    }
    /* bracket: lo gives an output short of y, hi one at or beyond it */
    step = y - g;
    lo = xp;
    hi = xp + step;
    for (it = 0; it < 200; ++it) {
        g = friction_mean(f, pp, n, xp_io, hi, 0, 0);
        if (step > R(0.0) ? g >= y : g <= y) {
            break;
        }
        lo = hi;
        step = step * R(2.0);
        hi = xp + step;
    }
    for (it = 0; it < 200; ++it) {
        const bpmid_real mid = lo + (hi - lo) / R(2.0);
        if (mid == lo || mid == hi) {
            break;
        }
        g = friction_mean(f, pp, n, xp_io, mid, 0, 0);
        if (step > R(0.0) ? g >= y : g <= y) {
            hi = mid;
        } else {
            lo = mid;
        }
    }
    (void)friction_mean(f, pp, n, xp_io, hi, 0, 1);
    return hi;
}

"""


def _vbmm_description(cv: CausalVBMM, meta: dict) -> list[str]:
    m = cv.model
    mat = m.material
    out = [f"Model: VBMM, {m.closure} closure, {mat.n_branches} Prony branch(es), time constants "
           f"{'split' if mat.split else 'shared'}, recursive (exact) history.",
           f"Geometry (m, rad): th {m.geometry.th!r}, alpha0 {m.geometry.alpha0!r}, R0 {m.geometry.R0!r}, "
           f"l0 {m.geometry.l0!r}, n {m.geometry.n!r}.",
           f"Material (Pa, s): G_inf {mat.G_inf!r}, K_inf {mat.K_inf!r}"]
    for j in range(mat.n_branches):
        tau = f"tau {mat.tauG[j]!r}" if not mat.split else f"tauG {mat.tauG[j]!r}, tauK {mat.tau_K[j]!r}"
        out.append(f"  branch {j + 1}: G {mat.G[j]!r}, K {mat.K[j]!r}, {tau}")
    if cv.effect_ids:
        out.append(f"Effects (in the order they act): {', '.join(cv.effect_ids)}.")
        for op, v in cv.chain:
            if op == "lag":
                out.append(f"  pressure lag, tau {v!r} s")
            elif op == "plays":
                out.append(f"  braid friction: mean of {len(v)} play operator(s), dead bands {', '.join(repr(r) for r in v)} Pa")
            else:
                out.append(f"  braid friction: mean of {len(v) // 3} friction operator(s), sliding level r + mu max(p, 0) "
                           f"and elastic stick slip; (r Pa, mu, slip Pa) = "
                           + ", ".join(f"({v[j]!r}, {v[j + 1]!r}, {v[j + 2]!r})" for j in range(0, len(v), 3)))
        if m.fall_ratio != 1.0:
            out.append(f"  asymmetric relaxation: tau times {m.fall_ratio!r} while the angle falls")
        if m.stiffening != 0.0:
            out.append(f"  strain stiffening: moduli times 1 + {m.stiffening!r} eps1^2")
        if cv.thermal is not None:
            out.append(f"  thermal softening: moduli times 1 - {cv.thermal[0]!r} (1 - exp(-(t - t0) / {cv.thermal[1]!r} s))")
        if cv.offset_deg:
            out.append(f"  angle offset {cv.offset_deg!r} deg")
    else:
        out.append("Effects: none.")
    return out


# ---------------------------------------------------------------------------------------------
# Maxwell-slip
# ---------------------------------------------------------------------------------------------
@dataclasses.dataclass(frozen=True)
class MaxwellSlipMap:
    """out = s(in) + sign sum_i k_i d_i, d_i = clamp(d_i + in - in_prev, -D_i, D_i) (elements start at 0).

    direct : "forward" (in = gauge pressure in bar, out = angle in deg: the compare model) or "inverse"
        (in = angle in deg, out = gauge pressure in bar: the MS-PI feedforward)
    """

    poly: tuple
    k: tuple
    D: tuple
    sign: float
    direct: str
    source: str


def load_maxwell_slip(path: str | Path) -> MaxwellSlipMap:
    """The Maxwell-slip model of a ``bpmid.compare/1`` file (``models.maxwell-slip``) or the MS-PI
    feedforward of a ``bpmid.control/1`` file (``ms_feedforward``)."""
    from bpmid.io.results import read_result, require
    from bpmid.params import parse_param_entry

    path = Path(path)
    data = read_result(path, ("bpmid.compare/", "bpmid.control/"))
    if data["schema"].startswith("bpmid.compare/"):
        ms = require(data, "models", path).get("maxwell-slip") if isinstance(data.get("models"), dict) else None
        if not isinstance(ms, dict):
            raise InputError("the comparison holds no maxwell-slip model (run bpmid compare with --models "
                             "...,maxwell-slip)", path=path, key="models.maxwell-slip")
        prm = require(data, "models.maxwell-slip.parameters", path)
        st = require(data, "models.maxwell-slip.settings", path)
        if st.get("input_unit", "bar") != "bar" or st.get("output_unit", "deg") != "deg":
            raise InputError("expected a muscle model with input_unit bar and output_unit deg", path=path,
                             key="models.maxwell-slip.settings")

        def val(name):
            return parse_param_entry(require(data, f"models.maxwell-slip.parameters.{name}", path), path=path,
                                     key=f"models.maxwell-slip.parameters.{name}")[0]

        deg = int(st.get("poly_degree", sum(1 for n in prm if n.startswith("s") and n[1:].isdigit()) - 1))
        nel = int(st.get("n_elements", sum(1 for n in prm if n.startswith("k") and n[1:].isdigit())))
        poly = tuple(val(f"s{j}") for j in range(deg + 1))
        k = tuple(val(f"k{i + 1}") for i in range(nel))
        D = tuple(val(f"D{i + 1}") for i in range(nel))
        sign = val("loop_sign") if "loop_sign" in prm else 1.0
        out = MaxwellSlipMap(poly, k, D, float(sign), "forward", "compare: models.maxwell-slip")
    else:
        if "ms_feedforward" not in data:   # a run without the ms-pi controller writes none: not a cut-short file
            ran = sorted({str(r.get("controller")) for r in data.get("summary") or () if isinstance(r, dict)
                          and r.get("controller") is not None})
            raise InputError(f"this control run had no ms-pi controller ({', '.join(ran) or 'none'} ran), so it holds "
                             "no MS-PI feedforward to export: run bpmid control with ms-pi in --controller, or export "
                             "the Maxwell-slip model of a comparison (bpmid compare --models ...,maxwell-slip)",
                             path=path, key="ms_feedforward")
        ff = require(data, "ms_feedforward", path)
        if not isinstance(ff, dict):
            raise InputError("expected a mapping", path=path, key="ms_feedforward")
        poly = require(data, "ms_feedforward.poly_bar_per_deg_j", path)
        k = require(data, "ms_feedforward.k_bar_per_deg", path)
        D = require(data, "ms_feedforward.D_deg", path)
        for name, v in (("poly_bar_per_deg_j", poly), ("k_bar_per_deg", k), ("D_deg", D)):
            if not isinstance(v, list) or not all(isinstance(x, (int, float)) and not isinstance(x, bool) and
                                                  math.isfinite(x) for x in v):
                raise InputError("expected a list of finite numbers", path=path, key=f"ms_feedforward.{name}")
        if len(k) != len(D) or not poly:
            raise InputError("k_bar_per_deg and D_deg need one entry per element, poly at least one", path=path,
                             key="ms_feedforward")
        out = MaxwellSlipMap(tuple(map(float, poly)), tuple(map(float, k)), tuple(map(float, D)), 1.0, "inverse",
                             "control: ms_feedforward (MS-PI)")
    if any(v < 0 for v in out.D):
        raise InputError("slip limits must be >= 0", path=path)
    if len(out.poly) > 4:
        raise InputError("the static polynomial may have degree 3 at most", path=path)
    return out


def _ms_sources(ms: MaxwellSlipMap, meta: dict) -> dict[str, str]:
    n = len(ms.k)
    fwd = ms.direct == "forward"
    desc = [f"Model: Maxwell-slip ({ms.source}), {n} element(s), static polynomial of degree {len(ms.poly) - 1}.",
            ("Direct map: gauge pressure (bar) -> angle (deg); step_forward evaluates it, step_inverse solves it."
             if fwd else
             "Direct map: angle (deg) -> gauge pressure (bar), the MS-PI feedforward; step_inverse evaluates it, "
             "step_forward solves it."),
            "The map and its constants below are in bar, as fitted; the step functions take and return Pa (they "
            "divide by 1e5 going in and multiply by 1e5 coming out).",
            "  out = s(in) + sign sum_i k_i d_i,  d_i = clamp(d_i + in - in_prev, -D_i, D_i),  d_i = 0 at the start",
            f"  s coefficients: {', '.join(repr(v) for v in ms.poly)}",
            f"  k: {', '.join(repr(v) for v in ms.k)};  D: {', '.join(repr(v) for v in ms.D)};  sign {ms.sign!r}",
            "The solve takes the root nearest the previous input (exact where the map is strictly monotone)."]
    nn = max(n, 1)
    fields = [f"    bpmid_real d[{nn}];   /* element deflections (input unit) */",
              "    bpmid_real in_prev;  /* previous input of the direct map */"]
    consts = [f"#define NEL {n}", f"#define NPOLY {len(ms.poly)}", f"#define SIGN {_lit(ms.sign)}"]
    arrays = ("    static const bpmid_real poly[NPOLY] = {" + ", ".join(_lit(v) for v in ms.poly) + "};\n")
    if n:
        arrays += ("    static const bpmid_real kk[NEL] = {" + ", ".join(_lit(v) for v in ms.k) + "};\n"
                   "    static const bpmid_real DD[NEL] = {" + ", ".join(_lit(v) for v in ms.D) + "};\n")
    else:
        arrays += "    static const bpmid_real kk[1] = {R(0.0)};\n    static const bpmid_real DD[1] = {R(0.0)};\n"
    # no fitted range: the status flags what no rig gives, a gauge pressure below vacuum or a negative angle asked
    # of the inverse (as the VBMM's code does); the map is still evaluated
    vac = "pressure_gauge_pa < -101325.0"
    if fwd:
        forward_body = ("    const bpmid_real y = direct_map(s, (bpmid_real)(pressure_gauge_pa / 1e5), s->k == 0);\n"
                        f"    s->status = {vac} ? BPMID_STATUS_OUT_OF_RANGE : BPMID_STATUS_OK;\n"
                        "    s->out_prev = (double)y;\n    return s->out_prev;")
        inverse_body = ("    const bpmid_real x = solve_map(s, (bpmid_real)angle_deg, &s->status);\n"
                        "    s->out_prev = (double)x * 1e5;\n"
                        "    if (angle_deg < 0.0 || s->out_prev < -101325.0) {\n"
                        "        s->status = BPMID_STATUS_OUT_OF_RANGE;\n    }\n    return s->out_prev;")
    else:
        forward_body = ("    const bpmid_real x = solve_map(s, (bpmid_real)(pressure_gauge_pa / 1e5), &s->status);\n"
                        f"    if ({vac}) {{\n        s->status = BPMID_STATUS_OUT_OF_RANGE;\n    }}\n"
                        "    s->out_prev = (double)x;\n    return s->out_prev;")
        inverse_body = ("    const bpmid_real y = direct_map(s, (bpmid_real)angle_deg, s->k == 0);\n"
                        "    s->out_prev = (double)y * 1e5;\n"
                        "    s->status = angle_deg < 0.0 || s->out_prev < -101325.0 ? BPMID_STATUS_OUT_OF_RANGE\n"
                        "                                                          : BPMID_STATUS_OK;\n"
                        "    return s->out_prev;")
    subs = dict(meta, description=_comment(desc), state_fields="".join(f + "\n" for f in fields),
                constants="\n".join(consts) + "\n", arrays=arrays, forward_body=forward_body,
                inverse_body=inverse_body)
    return {"bpmid_model.h": _template("common.h.in").substitute(subs),
            "bpmid_model.c": _template("maxwell_slip.c.in").substitute(subs),
            "main.c": _template("main.c.in").substitute(subs)}


def rig_defines(data: dict, *, rate_dependent: bool = True) -> str:
    """The header's lines on the rig the constants belong to (:func:`fit_rig`): ``BPMID_FIT_STEP_S`` when every
    fitting log had one step, ``BPMID_FIT_ATMOSPHERE_PA`` when every absolute log was turned to gauge with one
    ambient and none was gauge already; a comment saying what the file records otherwise (``rate_dependent=False``:
    a rate-independent model, such as Maxwell-slip, says nothing of the step)."""
    steps, atm, gauge = fit_rig(data)
    out = []
    if not rate_dependent:
        pass
    elif steps and max(steps) <= min(steps) * (1.0 + STEP_SPREAD):
        step = statistics.median(steps)
        out += ["/* The fit's logs were sampled every BPMID_FIT_STEP_S seconds. The hereditary sum takes each pressure",
                " * step as a jump at its sample, so the constants hold for this step: call the step functions at it (a",
                " * much faster rate reads the branch moduli differently; the fit file's notes say by how much). */",
                f"#define BPMID_FIT_STEP_S {float(f'{step:.6g}')!r}"]
    elif steps:
        out += [f"/* The fit's logs were sampled at different steps ({', '.join(f'{s:.4g}' for s in sorted(set(steps)))} s;",
                " * BPMID_FIT_STEP_S is not defined): the constants hold for the step of the logs they were fitted on, so",
                " * run the model at the rate of the logs most like the controller's. */"]
    else:
        out += ["/* The fit file records no sampling step of its logs (BPMID_FIT_STEP_S is not defined): run the model at",
                " * the rate of the logs it was fitted on. */"]
    if len(atm) == 1 and not gauge:
        out += ["/* Gauge pressure is pressure above this ambient (Pa): the fit turned its logs' absolute pressures to gauge",
                " * with it; convert a log the same way (pressure_gauge_pa = pressure_abs_pa - BPMID_FIT_ATMOSPHERE_PA). */",
                f"#define BPMID_FIT_ATMOSPHERE_PA {float(atm[0])!r}"]
    elif atm:
        out += [f"/* The fit's absolute logs were turned to gauge with the ambient {', '.join(f'{a:.9g}' for a in atm)} Pa"
                + (" and some of its logs gave gauge pressure already" if gauge else "") + " (the fit file's",
                " * provenance.reading; BPMID_FIT_ATMOSPHERE_PA is not defined): feed the model pressure above the rig's",
                " * ambient. */"]
    elif gauge:
        out += ["/* The fit's logs gave gauge pressure already: feed the model gauge pressure as the rig measured it. */"]
    else:
        out += ["/* The fit file records no ambient pressure: feed the model pressure above the ambient of the rig. */"]
    span = fitted_pressure_span(data)
    if span is not None:
        out += ["/* The gauge pressures (Pa) the constants were fitted on. Beyond them the model extrapolates: the step",
                " * functions still answer with status 0 (they flag only what no rig gives), so a controller that must",
                " * stay where the model was measured checks its pressure against these (bpmid predict warns of a log",
                " * that goes more than three of these spans beyond them). */",
                f"#define BPMID_FIT_PRESSURE_MIN_PA {float(f'{span[0]:.9g}')!r}",
                f"#define BPMID_FIT_PRESSURE_MAX_PA {float(f'{span[1]:.9g}')!r}"]
    return "\n".join(out) + "\n"


# ---------------------------------------------------------------------------------------------
# the command
# ---------------------------------------------------------------------------------------------
def c_sources(fit_path: str | Path, model: str | None = None, *, command: str | None = None) -> dict[str, str]:
    """The three C files for ``fit_path`` as {file name: text}. ``model``: "vbmm" (default for a
    ``bpmid.vbmm/1`` file), "vbmm-fit" or "vbmm-mat" (that model of a ``bpmid.compare/1`` file) or
    "maxwell-slip" (a ``bpmid.compare/1`` or ``bpmid.control/1`` file)."""
    from bpmid import __version__
    from bpmid.io.results import command_line, read_result

    fit_path = Path(fit_path)
    if model is None:
        data = read_result(fit_path, ("bpmid.vbmm/", "bpmid.compare/", "bpmid.control/"))
        model = "vbmm" if data["schema"].startswith("bpmid.vbmm/") else "maxwell-slip"
    if model not in MODELS:
        raise InputError(f"unknown model {model!r} for --to c (known: {', '.join(MODELS)})", key="--model")
    safe_name = "".join(ch if ch.isprintable() else "?" for ch in fit_path.name).replace("*/", "* /")
    meta = {"version": __version__, "fit_name": safe_name, "fit_sha256": _sha256(fit_path),
            "command": "".join(ch if ch.isprintable() else " " for ch in (command or command_line())).replace("*/", "* /"),
            "rig": rig_defines(read_result(fit_path, ("bpmid.vbmm/", "bpmid.compare/", "bpmid.control/")),
                               rate_dependent=model != "maxwell-slip")}
    if model == "vbmm":
        cv = causal_vbmm(load_vbmm_fit(fit_path), fit_path)
        meta["title"] = "the fitted VBMM as C99"
        return _vbmm_sources(cv, meta)
    if model in ("vbmm-fit", "vbmm-mat"):
        cv = causal_vbmm(load_vbmm_from_compare(fit_path, model), fit_path)
        meta["title"] = f"the {model} model of a comparison as C99"
        return _vbmm_sources(cv, meta)
    ms = load_maxwell_slip(fit_path)
    meta["title"] = "the fitted Maxwell-slip model as C99"
    return _ms_sources(ms, meta)


def export_c(fit_path: str | Path, out_dir: str | Path, model: str | None = None, *,
             command: str | None = None) -> list[Path]:
    """Write ``bpmid_model.h``, ``bpmid_model.c`` and ``main.c`` for ``fit_path`` into ``out_dir``, whole or
    not at all. Returns the paths written."""
    from bpmid.io.atomic import staged_dir

    sources = c_sources(fit_path, model, command=command)
    out_dir = Path(out_dir)
    with staged_dir(out_dir) as tmp:
        for name in FILES:
            (tmp / name).write_text(sources[name], encoding="utf-8")
    return [out_dir / name for name in FILES]


# ---------------------------------------------------------------------------------------------
# building and loading the exported code (tests, benchmarks, a Python host through ctypes)
# ---------------------------------------------------------------------------------------------
STRICT_FLAGS = ("-std=c99", "-Wall", "-Wextra", "-Werror", "-pedantic", "-O2")


def find_cc() -> str | None:
    """A C compiler on PATH ($CC, cc, gcc or clang), or None."""
    import os
    import shutil

    for name in (os.environ.get("CC"), "cc", "gcc", "clang"):
        if name and shutil.which(name):
            return shutil.which(name)
    return None


def build_c(src_dir: str | Path, out: str | Path, *, shared: bool = False, single: bool = False,
            flags: Sequence[str] = STRICT_FLAGS, cc: str | None = None) -> Path:
    """Compile the exported folder: the stdin filter (``main.c`` + model) or, with ``shared``, a shared
    library of the model alone. ``single`` adds -DBPMID_FLOAT. Raises RuntimeError with the compiler's
    message when it fails."""
    import subprocess

    cc = cc or find_cc()
    if cc is None:
        raise RuntimeError("no C compiler found (cc, gcc or clang)")
    src_dir = Path(src_dir)
    srcs = [str(src_dir / "bpmid_model.c")] + ([] if shared else [str(src_dir / "main.c")])
    cmd = [cc, *flags, *(["-DBPMID_FLOAT"] if single else []), *(["-shared", "-fPIC"] if shared else []),
           *srcs, "-o", str(out), "-lm"]
    res = subprocess.run(cmd, capture_output=True, text=True)
    if res.returncode != 0:
        raise RuntimeError(f"{' '.join(cmd)} failed:\n{res.stderr}")
    return Path(out)


class CModel:
    """An exported model loaded from its shared library with ctypes: one state, stepped from Python.

    The system loader keeps a library per path for the life of the process: build each model to its own path
    (a library rebuilt at a path already loaded is not reloaded).

    >>> m = CModel("libbpmid.so")               # doctest: +SKIP
    >>> angle_deg = m.forward(0.0, 30000.0)    # gauge Pa in, deg out
    """

    def __init__(self, lib_path: str | Path):
        import ctypes

        self.lib = ctypes.CDLL(str(lib_path))
        self.lib.bpmid_state_bytes.restype = ctypes.c_int
        self.state_bytes = int(self.lib.bpmid_state_bytes())
        self._buf = ctypes.create_string_buffer(self.state_bytes)
        for name in ("bpmid_step_forward", "bpmid_step_inverse", "bpmid_step_feedforward"):
            fn = getattr(self.lib, name)
            fn.restype = ctypes.c_double
            fn.argtypes = [ctypes.c_void_p, ctypes.c_double, ctypes.c_double]
        self.lib.bpmid_status.restype = ctypes.c_int
        self.lib.bpmid_status.argtypes = [ctypes.c_void_p]
        self._ptr = ctypes.cast(self._buf, ctypes.c_void_p)
        self.lib.bpmid_init(self._ptr)

    def reset(self) -> None:
        self.lib.bpmid_reset(self._ptr)

    def forward(self, t: float, pressure_gauge_pa: float) -> float:
        return self.lib.bpmid_step_forward(self._ptr, t, pressure_gauge_pa)

    def inverse(self, t: float, angle_deg: float) -> float:
        return self.lib.bpmid_step_inverse(self._ptr, t, angle_deg)

    def feedforward(self, t: float, angle_deg: float) -> float:
        return self.lib.bpmid_step_feedforward(self._ptr, t, angle_deg)

    @property
    def status(self) -> int:
        return int(self.lib.bpmid_status(self._ptr))

    def run_forward(self, t, p):
        """Angles (deg) for a whole pressure history (gauge Pa), from a fresh state."""
        import numpy as np

        self.reset()
        return np.array([self.forward(float(a), float(b)) for a, b in zip(t, p)])

    def run_inverse(self, t, angle_deg):
        """Gauge pressures (Pa) for a whole angle history (deg), from a fresh state."""
        import numpy as np

        self.reset()
        return np.array([self.inverse(float(a), float(b)) for a, b in zip(t, angle_deg)])

    def run_feedforward(self, t, angle_deg):
        """The feedforward's gauge pressures (Pa) for a whole angle history (deg), from a fresh state."""
        import numpy as np

        self.reset()
        return np.array([self.feedforward(float(a), float(b)) for a, b in zip(t, angle_deg)])


__all__ = ["find_cc", "build_c", "CModel", "STRICT_FLAGS", "export_c", "c_sources", "load_vbmm_fit",
           "load_vbmm_from_compare", "causal_vbmm", "CausalVBMM",
           "load_maxwell_slip", "MaxwellSlipMap", "FILES", "MODELS", "EXPORTABLE_EFFECTS"]
