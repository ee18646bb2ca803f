#!/usr/bin/env python
"""Per case: base-fit convergence, noise floor, and for misses the gate's record of the true effects' candidates."""
import glob, os, sys, json, yaml
res = sys.argv[1] if len(sys.argv) > 1 else "out/blind/results"
ansd = sys.argv[2] if len(sys.argv) > 2 else "out/blind/answers"
summ = {r["case"]: r for r in json.load(open(os.path.join(res, "summary.json")))}
for key, r in summ.items():
    s, c = key.split("_")
    d = yaml.safe_load(open(os.path.join(res, s, c, "discovery.yaml")))
    ans = yaml.safe_load(open(os.path.join(ansd, s, f"{c}.yaml")))
    bf = d.get("base_fit", {})
    nf = d.get("noise_floor", {})
    print(f"=== {key} truth={ans['truth']} ooc={ans.get('out_of_catalogue')} named={d['named_effects']} verdict={r['verdict']}")
    print(f"  base_fit converged={bf.get('converged')} msg={bf.get('message')!r} rmse={bf.get('rmse_deg')} at_start={bf.get('rmse_at_given_start_deg')} evals={bf.get('evaluations')}"
          f" | floor={nf.get('sigma_deg')} rho={nf.get('noise_lag1_correlation')} white_reading={nf.get('white_noise_reading_deg')} caution={nf.get('caution')}")
    print(f"  gap: {d['gap'].get('before_rmse_deg')} -> {d['gap'].get('after_rmse_deg')} (raw {d['gap'].get('raw_before_rmse_deg')} -> {d['gap'].get('raw_after_rmse_deg')}); unexplained={d.get('unexplained')}; warnings={d.get('warnings')}")
    if r["verdict"] == "right" and "-v" not in sys.argv:
        continue
    for i, rd in enumerate(d.get("rounds", [])):
        scr = [(x["effect"], x.get("explained_fraction")) for x in rd.get("screening", [])]
        print(f"  round {i}: screening {scr}")
        for cand in rd.get("confirmed", []):
            print(f"    {cand['effect']}: accepted={cand.get('accepted')} tested={cand.get('tested')} not_tested={cand.get('not_tested_reason')} "
                  f"gain={cand.get('heldout_gain_in_noise_floors')} share={cand.get('share_of_heldout_gap_removed')} fitshare={cand.get('share_of_fitting_gap_removed')} "
                  f"p_holm={cand.get('likelihood_ratio_p_holm')} ident={cand.get('identifiable')} after={cand.get('heldout_rmse_after_deg')}")
            print(f"       rejected: {cand.get('reasons_rejected')} refused_by={cand.get('refused_by_the_gate_because')} named_by={cand.get('named_by')}")
            print(f"       params: { {k: (round(v['value'],5) if isinstance(v,dict) and v.get('value') is not None else v) for k,v in (cand.get('parameters') or {}).items()} }")
        for k in ("rival_outside_catalogue", "pairs_refitted_together", "pairs", "verdict"):
            if k in rd:
                print(f"  round {i} {k}: {json.dumps(rd[k], default=str)[:1500]}")
    for k in ("rivals_outside_catalogue",):
        if k in d: print(f"  {k}: {json.dumps(d[k], default=str)[:1500]}")
