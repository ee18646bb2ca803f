"""Probe a case: regenerate it (same seed) with one generator setting changed, into out/blind2/probe/<case>_<variant>/,
and run bpmid discover on it. Diagnostics only; the sets themselves are made by gen.py.

    python benchmarks/blind2/probe.py A04 as_generated no_variation log_rate_truth only_K_inf ...

variants: as_generated; no_variation; log_rate_truth (the truth integrated at the log rate, the spec's discrete
recursion, instead of 100 Hz); only_<constant> (only that constant varies log to log).
"""
import subprocess
import sys

import yaml

import gen

ALL = ("G_inf", "K_inf", "G1", "K1", "tau1")


def main():
    case, variants = sys.argv[1], sys.argv[2:] or ["as_generated"]
    sn = case[0]
    si = list(gen.CASES).index(sn)
    ci, spec = [(i, c) for i, c in enumerate(gen.CASES[sn]) if c[0] == case][0]
    var0 = spec[4] if spec[4] is not None else gen.SETS[sn]["var"]
    for name in variants:
        gen.DT_SIM, gen.VARY = 1e-2, ALL
        s = list(spec)
        if name == "no_variation":
            s[4] = 0.0
        elif name == "log_rate_truth":
            gen.DT_SIM = 1.0 / gen.SETS[sn]["fs"]
        elif name.startswith("only_"):
            gen.VARY = (name[5:],)
            s[4] = var0
        gen.OUT = gen.ROOT / "out" / "blind2" / "probe" / f"{case}_{name}"
        gen.make_case(sn, tuple(s), gen.BASE_SEED + 100 * si + ci)
        cdir = gen.OUT / "sets" / sn / case
        ans = yaml.safe_load((gen.OUT / "answers" / sn / f"{case}.yaml").read_text())
        res = gen.OUT / "result"
        cmd = [sys.executable, "-m", "bpmid", "discover", *[str(cdir / f) for f in ans["fit_logs"]], "--holdout",
               *[str(cdir / f) for f in ans["holdout_logs"]], "--out", str(res)]
        if ans.get("config"):
            cmd += ["--config", str(cdir / ans["config"])]
        subprocess.run(cmd, capture_output=True, cwd=gen.ROOT, check=True)
        d = yaml.safe_load((res / "discovery.yaml").read_text())
        g = d["gap"]
        print(f"{case} {name}: truth {ans['truth'] or ans['out_of_catalogue'] or 'null'} named {d['named_effects']} "
              f"held-out {g['before_rmse_deg']:.3f} -> {g['after_rmse_deg']:.3f}, floor {g['noise_floor_deg']:.3f} "
              f"(sigma {ans['sigma_deg']}, ratio {ans['achieved_ratio']})", flush=True)


if __name__ == "__main__":
    main()
