#!/usr/bin/env python
"""Run `bpmid discover` on every generated case as a user would, then score against the answers.

Usage: python run.py --sets out/blind/sets --answers out/blind/answers --out out/blind/results [--only set1_c01,...]
       python run.py ... --score-only      (re-score existing outputs)
"""
import argparse, glob, os, subprocess, sys, time, json
import yaml

#: the bpmid this Python has (python -m bpmid), as a user would run it
BPMID = [sys.executable, "-m", "bpmid"]


def run_case(cdir, ans, outdir):
    fit = sorted(os.path.join(cdir, l["file"]) for l in ans["logs"] if l["role"] == "fit")
    ho = sorted(os.path.join(cdir, l["file"]) for l in ans["logs"] if l["role"] == "holdout")
    cmd = [*BPMID, "discover", *fit, "--holdout", *ho]
    cfg = os.path.join(cdir, "case.yaml")
    if os.path.exists(cfg):
        cmd += ["--config", cfg]
    cmd += ["--out", outdir]
    t0 = time.time()
    p = subprocess.run(cmd, capture_output=True, text=True)
    dt = time.time() - t0
    os.makedirs(outdir, exist_ok=True)
    with open(os.path.join(outdir, "_run.json"), "w") as f:
        json.dump(dict(cmd=cmd, rc=p.returncode, seconds=dt, stdout=p.stdout[-20000:], stderr=p.stderr[-20000:]), f, indent=1)
    return p.returncode, dt


def score(ans, disc):
    truth = ans["truth"]
    named = disc.get("named_effects") or [] if disc else None
    if named is None:
        return "crash", None
    if not truth:
        return ("right" if not named else "FP"), named
    if len(truth) == 1:
        return ("right" if named == truth else "wrong"), named
    return ("right" if set(truth) <= set(named) and len(named) == len(truth) else
            ("partial" if set(named) & set(truth) else "wrong")), named


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--sets", default="out/blind/sets")
    ap.add_argument("--answers", default="out/blind/answers")
    ap.add_argument("--out", default="out/blind/results")
    ap.add_argument("--only", default="")
    ap.add_argument("--score-only", action="store_true")
    a = ap.parse_args()
    rows = []
    for ansf in sorted(glob.glob(os.path.join(a.answers, "set*", "c*.yaml"))):
        ans = yaml.safe_load(open(ansf))
        key = f"{ans['set']}_{ans['case']}"
        if a.only and key not in a.only.split(",") and ans["set"] not in a.only.split(","):
            continue
        cdir = os.path.join(a.sets, ans["set"], ans["case"])
        odir = os.path.join(a.out, ans["set"], ans["case"])
        if not a.score_only:
            rc, dt = run_case(cdir, ans, odir)
            print(f"{key}: rc={rc} {dt:.1f}s", file=sys.stderr, flush=True)
        rj = json.load(open(os.path.join(odir, "_run.json")))
        dpath = os.path.join(odir, "discovery.yaml")
        disc = yaml.safe_load(open(dpath)) if os.path.exists(dpath) else None
        verdict, named = score(ans, disc)
        gap = (disc or {}).get("gap", {}) or {}
        rows.append(dict(case=key, truth=ans["truth"] or ([f"none (OOC: {ans['out_of_catalogue']})"] if ans.get("out_of_catalogue") else ["none"]),
                         form=ans["form"], named=named, verdict=verdict, rc=rj["rc"], seconds=round(rj["seconds"], 1),
                         noise_floor=gap.get("noise_floor_deg"), true_sigma=ans["angle_noise"]["sigma_deg"],
                         before=gap.get("before_rmse_deg"), after=gap.get("after_rmse_deg"),
                         raw_effect_over_sigma=round(ans["raw_effect_over_sigma"], 2), unexplained=(disc or {}).get("unexplained")))
    with open(os.path.join(a.out, "summary.json"), "w") as f:
        json.dump(rows, f, indent=1)
    for s in sorted(set(r["case"].split("_")[0] for r in rows)):
        rs = [r for r in rows if r["case"].startswith(s)]
        print(f"\n## {s}: {sum(r['verdict']=='right' for r in rs)} of {len(rs)} right; false positives: "
              f"{sum(r['verdict']=='FP' for r in rs)}")
        print("| case | truth | named | verdict | floor / sigma | held-out before / after | raw/sigma | s |")
        print("|---|---|---|---|---|---|---|---|")
        for r in rs:
            f = lambda x: "-" if x is None else f"{x:.3f}"
            print(f"| {r['case']} | {', '.join(r['truth'])} | {', '.join(r['named']) if r['named'] else ('none' if r['named'] is not None else 'CRASH')} | "
                  f"{r['verdict']} | {f(r['noise_floor'])} / {r['true_sigma']} | {f(r['before'])} / {f(r['after'])} | {r['raw_effect_over_sigma']} | {r['seconds']} |")


if __name__ == "__main__":
    main()
