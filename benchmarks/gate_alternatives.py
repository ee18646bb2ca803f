"""Gate variants tried on recorded sweeps, not shipped: what each would have named (round 1 and the later round).

Reads ``records.jsonl`` files of ``bpmid calibrate`` (permissive calibration runs: every candidate's statistics
recorded; held-out runs: the shipped gate's path) and replays, case by case:

- ``shipped``: the gate of ``bpmid/discover/thresholds.yaml``, its path to the noise floor included (first round
  only, on every record file);
- ``heldout-LR T``: the shipped gate, but a candidate whose held-out error drop is significant may pass without the
  gain in noise floors, and with no held-out gap above the floor its share is not asked. The statistic is
  ``n_ho log(SSE_before / SSE_after)`` on the held-out logs, with ``n_ho`` approximated as half the fitting logs'
  effective sample size (the records keep no held-out one): a test of the drop, not of its size;
- ``later share S``: the shipped gate, with the share of the held-out gap asked of a further effect lowered to S
  (a pair's second effect; singles gaining an extra name count against it);
- ``later gain G``: the shipped gate, with the held-out gain asked of a further effect set to G (noise floors; a
  change that touches only later rounds, such as how they are scored, is checked this way on records regenerated
  with it).

    python benchmarks/gate_alternatives.py out/pool-draw12/records.jsonl ... [--heldout d16/records.jsonl ...]
"""
from __future__ import annotations

import collections
import json
import math
import sys

from bpmid.discover.calibrate import _case_outcome, _first_passing, case_records, floor_drops, load_thresholds
from bpmid.discover.confirm import excess_deg, gap_share


def load(paths):
    out = []
    for path in paths:
        for line in open(path, encoding="utf-8"):
            rec = json.loads(line)
            if not rec.get("error"):
                out.append(rec)
    return out


def first_named_ho_lr(rec, thr, t_min):
    """Round 1 of the held-out likelihood-ratio variant (see module docstring)."""
    f = rec["noise_floor_deg"]
    best, best_t = None, -math.inf
    for c in rec["candidates"]:
        if c["round"] != 1 or not c["tested"] or not c["identifiable"]:
            continue
        b, a = c["heldout_rmse_before_deg"], c["heldout_rmse_after_deg"]
        g = (excess_deg(b, f) - excess_deg(a, f)) / f
        share = gap_share(b, a, f)
        fs = gap_share(c["fit_rmse_before_deg"], c["fit_rmse_after_deg"], f)
        t = 0.5 * c["n_eff"] * math.log(b * b / (a * a))
        p = c["likelihood_ratio_p_holm"] if c["likelihood_ratio_p_holm"] is not None else c["likelihood_ratio_p"]
        ok = ((g >= thr["heldout_gain_min_sigma"] or t >= t_min)
              and (share >= thr["gap_share_min"] or math.isnan(share)) and p < thr["family_alpha"]
              and (g > thr["fit_share_waived_above_sigma"] or fs >= thr["fit_share_min"] or math.isnan(fs)))
        if ok and t > best_t:
            best, best_t = c["effect"], t
    return best


def first_named_shipped(rec, thr):
    recs = case_records(rec)
    return _first_passing([r for r in recs if r.round == 1], thr["heldout_gain_min_sigma"], thr["gap_share_min"],
                          thr["family_alpha"], thr["fit_share_min"], thr["fit_share_waived_above_sigma"],
                          floor_drops(thr), thr["to_floor_ratio_max"])


def round1_table(recs, namer):
    t = collections.Counter()
    for rec in recs:
        kind, truth, named = rec["kind"], rec["truth_ids"], namer(rec)
        t[kind, "n"] += 1
        if kind == "single":
            t[kind, "ok"] += named == truth[0]
            t[kind, "wrong"] += named is not None and named != truth[0]
        elif kind == "pair":
            t[kind, "ok"] += named in truth
            t[kind, "wrong"] += named is not None and named not in truth
        else:
            t[kind, "ok"] += named is None
            t[kind, "wrong"] += named is not None
    return t


def later_table(recs, thr, share_later, g_later=None):
    """Singles: right first and nothing further; pairs: both named (the recorded round 2 after the gate's first).
    ``g_later``: the held-out gain asked in the later round (None: the shipped one)."""
    g, sh, a = thr["heldout_gain_min_sigma"], thr["gap_share_min"], thr["family_alpha"]
    fs, w = thr["fit_share_min"], thr["fit_share_waived_above_sigma"]
    gl = thr["heldout_gain_min_sigma_later"] if g_later is None else g_later
    d, q = floor_drops(thr), thr["to_floor_ratio_max"]
    t = collections.Counter()
    for rec in recs:
        rs = case_records(rec)
        if not rs or rec["kind"] not in ("single", "pair"):
            continue
        first = _first_passing([r for r in rs if r.round == 1], g, sh, a, fs, w, d, q)
        truth = set(rec["truth_ids"])
        if first is None or first not in truth:
            continue
        later = [r for r in rs if r.round == 2 and r.named_before == first]
        second = _first_passing(later, gl, share_later, a, fs, w, d, q) if later else None
        if rec["kind"] == "single":
            t["single extra name" if second else "single right, nothing further"] += 1
        else:
            t["pair both" if second in truth - {first} else ("pair wrong second" if second else "pair one")] += 1
    return t


def later_score(recs, thr, share_later, g_later=None):
    """Right decisions minus twice the wrong names over every case (the calibration's score; round 1 the shipped
    gate, later rounds asked ``share_later`` and ``g_later``, None: the shipped gain): what
    ``thresholds_from_records`` would weigh."""
    gl = thr["heldout_gain_min_sigma_later"] if g_later is None else g_later
    score = 0
    for rec in recs:
        rs = case_records(rec)
        if rs:
            right, wrong = _case_outcome(rs, thr["heldout_gain_min_sigma"], thr["gap_share_min"],
                                         thr["family_alpha"], thr["fit_share_min"],
                                         thr["fit_share_waived_above_sigma"], gl, share_later, floor_drops(thr))
            score += right - 2 * wrong
    return score


def show(title, t):
    print(f"  {title:28s} " + "  ".join(f"{k[:6]} {t[k, 'ok']}/{t[k, 'n']} (-{t[k, 'wrong']})"
                                      for k in ("single", "pair", "null", "out_of_catalogue")))


def main(argv):
    if "--heldout" in argv:
        i = argv.index("--heldout")
        cal, ho = argv[:i], argv[i + 1:]
    else:
        cal, ho = argv, []
    thr = load_thresholds()
    for name, paths in (("calibration records", cal), ("held-out records", ho)):
        if not paths:
            continue
        recs = load(paths)
        print(f"{name}: {len(recs)} cases; round 1 (right/cases, wrong names or names where nothing is true)")
        show("shipped", round1_table(recs, lambda r: first_named_shipped(r, thr)))
        for t_min in (40.0, 60.0, 100.0):
            show(f"heldout-LR T >= {t_min:g}", round1_table(recs, lambda r, t_min=t_min: first_named_ho_lr(r, thr, t_min)))
        for s in sorted({thr["gap_share_min"], 0.30, 0.25, 0.20, 0.15}, reverse=True):   # each value once
            lt = later_table(recs, thr, s)
            print(f"  later share {s:.2f}: score {later_score(recs, thr, s)}; "
                  + ", ".join(f"{k} {v}" for k, v in sorted(lt.items())))
        for gl in sorted({0.04, 0.06, 0.08, thr["heldout_gain_min_sigma_later"], thr["heldout_gain_min_sigma"]}):
            lt = later_table(recs, thr, thr["gap_share_min"], gl)
            print(f"  later gain {gl:.2f}: score {later_score(recs, thr, thr['gap_share_min'], gl)}; "
                  + ", ".join(f"{k} {v}" for k, v in sorted(lt.items())))


if __name__ == "__main__":
    main(sys.argv[1:])
