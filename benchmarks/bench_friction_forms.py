"""Which friction form on the pressure reproduces the out-of-family generator's braid friction (Dahl, Bouc-Wen,
Jenkins elements acting on the axial stress)?

For calibration cases of a sweep (never held-out ones), the case's muscle is simulated without and with its
friction (noise-free, no log-to-log variation, the generator's own continuous-time integration), and both angle
histories are turned back into the pressure bpmid's VBMM (the case's true constants and geometry) needs to make
them (``VBMM.inverse``). Their difference is the friction's pressure equivalent f(t) (Pa). Candidate forms of the
catalogue's braid_friction are then fitted to f directly (least squares on f, all logs at once):

- ``play``: the first release's play operator, a constant dead band +-r;
- ``play, band r + mu p``: a rigid stick with a pressure-proportional sliding level;
- ``friction r, mu, slip``: the catalogue's form now (pressure-proportional level and an elastic stick);
- ``Dahl on the pressure, level mu p``: an exponential (Dahl) approach to the sliding level over p_c.

Usage (the answers file of the sweep's calibration half holds each case's sized physics)::

    python benchmarks/bench_friction_forms.py --answers OUT/answers/calibration.yaml full-0045 full-0062 ...
"""
from __future__ import annotations

import argparse

import numpy as np
import yaml
from scipy.optimize import least_squares

from bpmid.effects import _kernels as K
from bpmid.models.vbmm.model import VBMM, Geometry, Material
from bpmid.validation.forms import merge
from bpmid.validation.generator import make_cases, simulate_spec
from bpmid.validation.sweep import load_sweep


def dahl_level(p, mu, pc):
    """f = mu p h, dh = (sgn(dp) - h)(1 - exp(-|dp| / pc)): a Dahl approach on the pressure."""
    h = np.zeros_like(p)
    for k in range(1, p.size):
        dp = p[k] - p[k - 1]
        s = 1.0 if dp > 0 else -1.0
        h[k] = h[k - 1] if dp == 0 else s + (h[k - 1] - s) * np.exp(-abs(dp) / pc)
    return mu * p * h


FORMS = {
    "play (constant band r)": (lambda p, x: p - K.play(p, abs(x[0])), [1000.0]),
    "play, band r + mu p": (lambda p, x: p - K.friction(p, abs(x[0]), abs(x[1]), 0.0), [100.0, 0.01]),
    "friction r, mu, slip": (lambda p, x: p - K.friction(p, abs(x[0]), abs(x[1]), abs(x[2])), [100.0, 0.01, 5000.0]),
    "Dahl on the pressure, level mu p": (lambda p, x: dahl_level(p, abs(x[0]), abs(x[1])), [0.01, 5000.0]),
}


def friction_equivalent(case, physics):
    """Per log: (gauge pressure Pa, friction pressure equivalent Pa)."""
    m, g = case.material, case.geometry.si()
    vb = VBMM(Material(m["G_inf"], m["K_inf"], m["G"], m["K"], m["tau"]),
              Geometry(th=g[0], alpha0=g[1], R0=g[2], l0=g[3], n=g[4]))
    plain, fric = simulate_spec(case), simulate_spec(case, merge([physics]))
    out = []
    for (t, p, b0), (_t, _p, b1) in zip(plain, fric):
        out.append((p, vb.inverse(t, np.radians(b0)) - vb.inverse(t, np.radians(b1))))
    return out


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("cases", nargs="+")
    ap.add_argument("--answers", required=True)
    ap.add_argument("--sweep", default="configs/sweeps/full.yaml")
    a = ap.parse_args(argv)
    cfg = load_sweep(a.sweep)
    cases = {c.id: c for c in make_cases(cfg.effective_generator, cfg.sweep.seed, prefix=cfg.sweep.name)}
    answers = yaml.safe_load(open(a.answers))
    answers = answers.get("cases", answers)
    print("| case | form | " + " | ".join(FORMS) + " |")
    print("|---|---|" + "---|" * len(FORMS))
    for cid in a.cases:
        if cases[cid].split != "calibration":
            raise SystemExit(f"{cid} is not a calibration case")
        eff = answers[cid]["truth"]["effects"][0]
        logs = friction_equivalent(cases[cid], eff["physics"])
        tot = float(np.mean(np.concatenate([f for _p, f in logs]) ** 2))
        cells = []
        for fn, x0 in FORMS.values():
            r = least_squares(lambda x: np.concatenate([fn(p, x) - f for p, f in logs]), x0, x_scale="jac")
            cells.append(f"{1 - float(np.mean(r.fun ** 2)) / tot:.2f}")
        ratio = np.median(np.concatenate([np.abs(f)[p > np.percentile(p, 80)] / p[p > np.percentile(p, 80)]
                                          for p, f in logs]))
        print(f"| {cid} | {eff['form']} (f / p at high p {ratio:.3f}) | " + " | ".join(cells) + " |")


if __name__ == "__main__":
    main()
