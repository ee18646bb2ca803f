"""Run `bpmid discover` on every case of out/blind2/sets as a user would, one case at a time, and score it.

    python benchmarks/blind2/run.py [--only A01,B07] [--sets A,B,C] [--rescore]

Per case: bpmid discover FIT... --holdout HO... [--config case.yaml] --out out/blind2/results/<set>/<case>
(the truth in out/blind2/answers is read only after discovery has run, for scoring). A case is right when a
single effect is named exactly (that id and nothing else), both effects of a pair are named, and nothing is
named on a null or an out-of-catalogue case. Prints a markdown table per set and writes out/blind2/summary.md.
"""
import argparse
import subprocess
import sys
import time
from pathlib import Path

import yaml

ROOT = Path(__file__).resolve().parents[2]
OUT = ROOT / "out" / "blind2"
PY = sys.executable  # the Python (and so the bpmid) this script runs under, as a user would


def run_case(set_name, cdir, rescore):
    ans = yaml.safe_load((OUT / "answers" / set_name / f"{cdir.name}.yaml").read_text())
    res = OUT / "results" / set_name / cdir.name
    cmd = [PY, "-m", "bpmid", "discover", *[str(cdir / f) for f in ans["fit_logs"]],
           "--holdout", *[str(cdir / f) for f in ans["holdout_logs"]]]
    if ans.get("config"):
        cmd += ["--config", str(cdir / ans["config"])]
    cmd += ["--out", str(res)]
    rec = {"case": cdir.name, "kind": ans["kind"], "truth": ans["truth"], "forms": ans["forms"],
           "oof": ans["out_of_catalogue"], "ratio": ans["achieved_ratio"], "sigma": ans["sigma_deg"]}
    if not (rescore and (res / "discovery.yaml").exists()):
        t0 = time.time()
        p = subprocess.run(cmd, capture_output=True, text=True, cwd=ROOT, timeout=900)
        rec["seconds"] = round(time.time() - t0, 1)
        rec["exit"] = p.returncode
        if p.returncode != 0:
            rec["error"] = (p.stderr.strip().splitlines() or ["?"])[-1][:300]
            rec["named"] = None
            rec["right"] = False
            return rec
        (res / "stderr.txt").write_text(p.stderr)
    d = yaml.safe_load((res / "discovery.yaml").read_text())
    named = list(d.get("named_effects") or [])
    gap = d.get("gap", {})
    rec.update(named=named, before=gap.get("before_rmse_deg"), after=gap.get("after_rmse_deg"),
               floor=gap.get("noise_floor_deg"), unexplained=d.get("unexplained"))
    truth = ans["truth"]
    if ans["kind"] == "single":
        rec["right"] = named == truth
    elif ans["kind"] == "pair":
        rec["right"] = all(t in named for t in truth)
    else:
        rec["right"] = not named
    rec["false_names"] = [n for n in named if n not in truth]
    return rec


def fmt(x, nd=3):
    return "-" if x is None else f"{x:.{nd}f}"


def table(set_name, recs):
    lines = [f"### set {set_name}: {sum(r['right'] for r in recs)} of {len(recs)} right", "",
             "| case | kind | truth (form) | named | right | before / after / floor (deg) | ratio | s |",
             "|---|---|---|---|---|---|---|---|"]
    for r in recs:
        truth = ", ".join(f"{t} ({f})" for t, f in zip(r["truth"], r["forms"])) if r["truth"] else (
            f"none ({r['oof']})" if r["oof"] else "none (null)")
        named = "ERROR: " + r["error"] if r.get("error") else (", ".join(r["named"]) or "nothing")
        lines.append(f"| {r['case']} | {r['kind']} | {truth} | {named} | {'yes' if r['right'] else 'NO'} | "
                     f"{fmt(r.get('before'))} / {fmt(r.get('after'))} / {fmt(r.get('floor'))} | "
                     f"{r['ratio']:.2f} | {r.get('seconds', '-')} |")
    by = {}
    for r in recs:
        k = r["kind"]
        by.setdefault(k, [0, 0])
        by[k][0] += bool(r["right"])
        by[k][1] += 1
    fp = sum(len(r.get("false_names") or []) for r in recs)
    fp_cases = sum(1 for r in recs if r["kind"] in ("null", "out_of_catalogue") and r.get("named"))
    lines += ["", "counts: " + ", ".join(f"{k} {a}/{b}" for k, (a, b) in by.items())
              + f"; false names (ids named that are not in the truth): {fp}; nulls/out-of-catalogue with a name: "
              f"{fp_cases}", ""]
    return "\n".join(lines), fp


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--only", default="")
    ap.add_argument("--sets", default="A,B,C")
    ap.add_argument("--rescore", action="store_true", help="score existing results without rerunning")
    a = ap.parse_args()
    only = set(x for x in a.only.split(",") if x)
    out, total_fp, all_recs = [], 0, {}
    for s in a.sets.split(","):
        recs = []
        for cdir in sorted((OUT / "sets" / s).iterdir()):
            if only and cdir.name not in only:
                continue
            r = run_case(s, cdir, a.rescore)
            print(f"{s}/{r['case']}: truth {r['truth'] or r['oof'] or 'null'} named {r.get('named')} "
                  f"{'right' if r['right'] else 'WRONG'} ({r.get('seconds', '-')} s)", file=sys.stderr, flush=True)
            recs.append(r)
        all_recs[s] = recs
        txt, fp = table(s, recs)
        total_fp += fp
        out.append(txt)
    out.append(f"total false names: {total_fp}")
    text = "\n".join(out)
    print(text)
    if not only:
        (OUT / "summary.md").write_text(text + "\n")
        (OUT / "results" / "records.yaml").write_text(yaml.safe_dump(all_recs, sort_keys=False))


if __name__ == "__main__":
    main()
