"""Does the refitted base VBMM absorb a short pressure lag? (calibration cases of the out-of-family sweep only)

For each case: the base fit of ``bpmid discover`` (multi-start, per-log gains), then the base refitted with the
case's TRUE pressure path put in as the catalogue's pressure_lag (a cascade as tau = tau1 + tau2 and
share = min/total; a transport delay plus a lag as two equal lags of the same total) and held there, started from
the fitted base and from the given constants; and the lag refitted freely (with the base) from the truth and from
a few samples' worth (0.01 s, two equal lags). Printed: fitting RMSE, held-out RMSE (each held-out log's gain
fitted, as discovery scores), the lag and the base branch's time constant.

    python benchmarks/bench_lag_absorption.py CASES_DIR ANSWERS.yaml full-0187 full-0063 ...
"""
from __future__ import annotations

import dataclasses
import glob
import sys

import yaml

from bpmid.api import _config, _motion_logs
from bpmid.discover.model import ModelState, fit_state, scored_rmse
from bpmid.discover.workflow import DiscoverConfig, fit_base
from bpmid.effects import get_effect
from bpmid.models.vbmm import starting_vbmm


def main(argv):
    root, answers, ids = argv[0], argv[1], argv[2:]
    ans = yaml.safe_load(open(answers))
    ans = ans.get("cases", ans)
    dcfg = DiscoverConfig()
    for c in ids:
        d = f"{root}/{c}"
        cfg = _config(f"{d}/case.yaml")
        fit, _ = _motion_logs(sorted(glob.glob(f"{d}/fit/*.csv")), cfg, require_angle=True)
        ho, _ = _motion_logs(sorted(glob.glob(f"{d}/holdout/*.csv")), cfg, require_angle=True)
        base, _, _ = starting_vbmm(f"{d}/init.yaml", cfg.section("model"))
        s0 = ModelState.start(base)
        sb, rb, _ = fit_base(s0, fit, dcfg)
        ph = ans[c]["truth"]["effects"][0]["physics"]["pressure"]
        if ph["kind"] == "cascade":
            tt = ph["tau1"] + ph["tau2"]
            sh = min(ph["tau1"], ph["tau2"]) / tt
        else:
            tt, sh = ph["delay"] + ph["tau"], 0.5
        print(f"{c} truth {ph}; base alone: fit {rb.rmse:.4f} held-out {scored_rmse(sb, ho, per_log_gain=True):.4f} "
              f"deg, tau_1 {sb.params.value('vbmm.tau_1'):.4f} s")
        e = get_effect("pressure_lag")
        truth = {"pressure_lag.tau": tt, "pressure_lag.share": sh}
        for label, st0, vals, fixed in [("true lag held, base from its fit", sb, truth, True),
                                        ("true lag held, base from the given", s0, truth, True),
                                        ("lag free from the truth", sb, truth, False),
                                        ("lag free from 0.01 s, share 0.5", sb,
                                         {"pressure_lag.tau": 0.01, "pressure_lag.share": 0.5}, False)]:
            st = st0.with_effect(e)
            ps = st.params.with_values(vals)
            if fixed:
                ps = ps.replace("pressure_lag.tau", fixed=True).replace("pressure_lag.share", fixed=True)
            st = dataclasses.replace(st, params=ps)
            if st0 is s0:
                st, r, _ = fit_base(st, fit, dcfg)
            else:
                st, r = fit_state(st, fit, max_nfev=60, check_identifiability=False, per_log_gain=True)
            h = scored_rmse(st, ho, per_log_gain=True)
            print(f"  {label:36s} fit {r.rmse:.4f} held-out {h:.4f} deg; lag tau {st.params.value('pressure_lag.tau'):.4f}"
                  f" s share {st.params.value('pressure_lag.share'):.2f}; tau_1 {st.params.value('vbmm.tau_1'):.4f} s")


if __name__ == "__main__":
    main(sys.argv[1:])
