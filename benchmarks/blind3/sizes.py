"""Per-log size of each case's hidden effect (noise-free RMS against the true base model, and the ratio
sqrt(sigma^2 + rms^2)/sigma) on fitting and held-out logs, without writing any file."""
import os, sys
sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import gen
for S in gen.SETS:
    for i in range(1, len(gen.SETS[S]) + 1):
        r = gen.build_case(S, i, dry=True)
        fit = [x["ratio"] for x in r["per_log"] if x["role"] == "fit"]
        ho = [x["ratio"] for x in r["per_log"] if x["role"] == "holdout"]
        print("%s sigma %.2f  fit-log ratios %s  held-out %s" % (r["case"], r["sigma"],
              " ".join("%.1f" % x for x in fit), " ".join("%.1f" % x for x in ho)), flush=True)
