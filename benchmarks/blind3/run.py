"""Run `bpmid discover` on every blind3 case as a user would, then score against the answers.

    .venv/bin/python benchmarks/blind3/run.py [--only set1/case03,...] [--rescore] [--jobs 1]

Per case: bpmid discover <case>/fit_*.csv --holdout <case>/holdout_*.csv [--config <case>/case.yaml]
          --out out/blind3/runs/set{S}/case{NN}     (timeout 300 s; stdout/stderr kept beside the output)
Answers (out/blind3/answers/) are read only for scoring. Writes out/blind3/results.json and out/blind3/summary.md.
"""
import argparse
import glob
import json
import os
import shlex
import subprocess
import time
from concurrent.futures import ThreadPoolExecutor

import yaml

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.abspath(os.path.join(HERE, "..", ".."))
OUT = os.path.join(ROOT, "out", "blind3")
BPMID = os.path.join(ROOT, ".venv", "bin", "bpmid")
TIMEOUT = 300


def case_dirs():
    return sorted(glob.glob(os.path.join(OUT, "sets", "set*", "case*")))


def command(cdir):
    rel = os.path.relpath(cdir, ROOT)
    s, c = rel.split(os.sep)[-2:]
    fit = sorted(glob.glob(os.path.join(rel, "fit_*.csv"), root_dir=ROOT))
    hold = sorted(glob.glob(os.path.join(rel, "holdout_*.csv"), root_dir=ROOT))
    cmd = [BPMID, "discover", *fit, "--holdout", *hold]
    if os.path.exists(os.path.join(cdir, "case.yaml")):
        cmd += ["--config", os.path.join(rel, "case.yaml")]
    cmd += ["--out", os.path.join("out", "blind3", "runs", s, c)]
    return cmd, "%s/%s" % (s, c)


def run_case(cdir):
    cmd, key = command(cdir)
    logdir = os.path.join(OUT, "runlogs")
    os.makedirs(logdir, exist_ok=True)
    t0 = time.time()
    try:
        p = subprocess.run(cmd, cwd=ROOT, capture_output=True, text=True, timeout=TIMEOUT)
        rc, so, se = p.returncode, p.stdout, p.stderr
    except subprocess.TimeoutExpired as e:
        rc, so, se = "timeout", (e.stdout or b"").decode() if isinstance(e.stdout, bytes) else (e.stdout or ""), \
            (e.stderr or b"").decode() if isinstance(e.stderr, bytes) else (e.stderr or "")
    el = time.time() - t0
    tag = key.replace("/", "_")
    with open(os.path.join(logdir, tag + ".stdout"), "w") as fh:
        fh.write(so)
    with open(os.path.join(logdir, tag + ".stderr"), "w") as fh:
        fh.write(se)
    with open(os.path.join(logdir, tag + ".meta.json"), "w") as fh:
        json.dump(dict(cmd=" ".join(shlex.quote(x.replace(ROOT + "/", "")) for x in cmd), rc=rc,
                       elapsed_s=el), fh)
    print("%s rc=%s %.1fs" % (key, rc, el), flush=True)
    return key


def score(key):
    s, c = key.split("/")
    ans = yaml.safe_load(open(os.path.join(OUT, "answers", "%s_%s.yaml" % (s, c))))
    tag = key.replace("/", "_")
    meta = json.load(open(os.path.join(OUT, "runlogs", tag + ".meta.json")))
    stderr = open(os.path.join(OUT, "runlogs", tag + ".stderr")).read()
    row = dict(case=key, kind=ans["kind"], truth=ans["truth_ids"],
               forms=[e["form"] for e in ans["effects"]] or ["none"],
               ratios=[round(e["achieved_ratio"], 2) for e in ans["effects"]],
               combined_ratio=ans["combined_ratio"], sigma=ans["sigma_deg"], phi=ans["ar1_phi"],
               variation=ans["variation_sd"], rc=meta["rc"], elapsed=meta["elapsed_s"], cmd=meta["cmd"],
               stderr=stderr.strip())
    dy = os.path.join(OUT, "runs", s, c, "discovery.yaml")
    if meta["rc"] != 0 or not os.path.exists(dy):
        row.update(named=None, right=False, false=[], error=True)
        return row
    d = yaml.safe_load(open(dy))
    named = list(d.get("named_effects") or [])
    g = d.get("gap", {})
    truth = set(ans["truth_ids"])
    if ans["kind"] == "single":
        right = named == list(truth)
    elif ans["kind"] == "pair":
        right = truth <= set(named)
    else:
        right = not named
    steps = d.get("steps") or []
    named_by = [st.get("named_by", st.get("evidence", {}).get("named_by", "")) if isinstance(st, dict) else ""
                for st in steps]
    row.update(named=named, right=right, false=[x for x in named if x not in truth], error=False,
               before=g.get("before_rmse_deg"), after=g.get("after_rmse_deg"), floor=g.get("noise_floor_deg"),
               raw_before=g.get("raw_before_rmse_deg"), raw_after=g.get("raw_after_rmse_deg"),
               unexplained=d.get("unexplained"), elapsed_internal=d.get("elapsed_s"),
               lag1=(d.get("noise_floor") or {}).get("noise_lag1_correlation"),
               caution=(d.get("noise_floor") or {}).get("caution"),
               warnings=(d.get("provenance") or {}).get("warnings"),
               named_by=named_by,
               rival=[r.get("rival_outside_catalogue") for r in (d.get("rounds") or []) if isinstance(r, dict)
                      and r.get("rival_outside_catalogue")])
    # how the truth's candidates fared in the first round (for the misses table)
    detail = []
    for r_i, rd in enumerate(d.get("rounds") or []):
        for x in rd.get("confirmed") or []:
            if isinstance(x, dict) and (x.get("effect") in truth or x.get("effect") in row["false"]):
                detail.append(dict(round=r_i, effect=x.get("effect"), accepted=x.get("accepted"),
                                   gain_sigma=x.get("heldout_gain_in_noise_floors"),
                                   share=x.get("share_of_heldout_gap_removed"),
                                   before=x.get("heldout_rmse_before_deg"), after=x.get("heldout_rmse_after_deg"),
                                   identifiable=x.get("identifiable"), named_by=x.get("named_by"),
                                   rejected=x.get("reasons_rejected")))
    row["candidates"] = detail
    row["rivals_withheld"] = [rd.get("rival_outside_catalogue") for rd in (d.get("rounds") or [])
                              if isinstance(rd, dict) and rd.get("rival_outside_catalogue")]
    return row


def fmt(x, p=3):
    return "-" if x is None else ("%.*f" % (p, x))


def absorbed():
    """case -> held-out ratio left after the true base model's per-log factors (benchmarks/blind3/absorb.py)."""
    out = {}
    f = os.path.join(OUT, "absorb.txt")
    if os.path.exists(f):
        for line in open(f):
            parts = line.split()
            if parts:
                out[parts[0]] = parts[-4]
    return out


def summary(rows):
    ab = absorbed()
    L = ["# blind3: `bpmid discover` on three independently generated synthetic sets", "",
         "R achieved: the held-out RMSE of the true base model (same per-log constants) over the true sigma, with "
         "the effect alone (pairs: each alone). 'R after f' (from absorb.py): the same after the true base model "
         "gets three free per-log factors (G_inf&K_inf, G1&K1, tau1), the kind of factors bpmid fits per log: "
         "near 1 means the effect is nearly invisible to a per-log-factor scoring.", ""]
    for S in ("set1", "set2", "set3"):
        rs = [r for r in rows if r["case"].startswith(S)]
        if not rs:
            continue
        k = sum(1 for r in rs if r["right"])
        L += ["## %s: %d of %d right" % (S, k, len(rs)), "",
              "| case | kind | truth (form) | R achieved | R after f | named | right | held-out before / after (deg) | floor / true sigma | raw before / after | time (s) |",
              "|---|---|---|---|---|---|---|---|---|---|---|"]
        for r in rs:
            truth = ", ".join("%s (%s)" % (i, f) for i, f in zip(r["truth"] or ["-"] * len(r["forms"]), r["forms"])) \
                if r["truth"] else r["forms"][0]
            named = "ERROR rc=%s" % r["rc"] if r["error"] else (", ".join(r["named"]) or "(nothing)")
            L.append("| %s | %s | %s | %s | %s | %s | %s | %s / %s | %s / %.3f%s | %s / %s | %.1f |" % (
                r["case"].split("/")[1], r["kind"], truth, ", ".join("%.2f" % x for x in r["ratios"]) or "-",
                ab.get(r["case"], "-"),
                named, "yes" if r["right"] else "**no**", fmt(r.get("before")), fmt(r.get("after")),
                fmt(r.get("floor")), r["sigma"], " (AR phi %.2f)" % r["phi"] if r["phi"] else "",
                fmt(r.get("raw_before")), fmt(r.get("raw_after")), r["elapsed"]))
        L.append("")
    fp = [(r["case"], x) for r in rows for x in (r.get("false") or [])]
    L += ["## False names", ""] + (["- %s: %s" % f for f in fp] or ["none"]) + [""]
    L += ["## Truth / false candidates per round (misses and false names)", ""]
    for r in rows:
        if r["error"] or r["right"]:
            continue
        L.append("- %s (%s; named %s):" % (r["case"], ", ".join(r["truth"]) or r["kind"], r["named"] or "nothing"))
        for c in r.get("candidates") or []:
            L.append("  - round %d %s: accepted %s, held-out gain %s floors, share %s, %s -> %s deg, identifiable %s, named_by %s; rejected: %s" % (
                c["round"], c["effect"], c["accepted"], fmt(c["gain_sigma"], 2), fmt(c["share"], 2),
                fmt(c["before"]), fmt(c["after"]), c["identifiable"], c["named_by"], "; ".join(c["rejected"] or []) or "-"))
        if r.get("rivals_withheld"):
            L.append("  - rival withheld a name: %s" % str(r["rivals_withheld"])[:300])
    L.append("")
    errs = [r for r in rows if r["error"]]
    L += ["## Errors / load failures", ""]
    L += ["- %s rc=%s: `%s`\n\n  ```\n  %s\n  ```" % (r["case"], r["rc"], r["cmd"], r["stderr"][-1500:]) for r in errs] or ["none"]
    L += ["", "## stderr of successful runs (non-empty)", ""]
    for r in rows:
        if not r["error"] and r["stderr"]:
            L.append("- %s: %s" % (r["case"], r["stderr"][:600].replace("\n", " / ")))
    L += ["", "## Commands", ""] + ["- `%s`" % r["cmd"] for r in rows]
    return "\n".join(L) + "\n"


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--only", default="")
    ap.add_argument("--rescore", action="store_true")
    ap.add_argument("--jobs", type=int, default=1)
    a = ap.parse_args()
    dirs = case_dirs()
    if a.only:
        want = set(a.only.split(","))
        dirs = [d for d in dirs if "/".join(d.split(os.sep)[-2:]) in want]
    if not a.rescore:
        with ThreadPoolExecutor(a.jobs) as ex:
            list(ex.map(run_case, dirs))
    keys = ["/".join(d.split(os.sep)[-2:]) for d in case_dirs()]
    keys = [k for k in keys if os.path.exists(os.path.join(OUT, "runlogs", k.replace("/", "_") + ".meta.json"))]
    rows = [score(k) for k in keys]
    json.dump(rows, open(os.path.join(OUT, "results.json"), "w"), indent=1, default=str)
    md = summary(rows)
    open(os.path.join(OUT, "summary.md"), "w").write(md)
    print(md)


if __name__ == "__main__":
    main()
