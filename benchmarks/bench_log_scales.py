"""How far apart the logs of one muscle sit in scale, for discovery's caution on a log of another muscle
(:data:`bpmid.discover.cautions.LOG_SCALE_APART`, 0.2).

Synthetic cases of the out-of-family generator (``bpmid.validation``; nulls and singles with its 0-5 % log-to-log
variation of the constants, the ranges of a sweep config) are written, their base VBMM fitted as discovery fits it
(``fit_base``), and for each case the largest spread of one log's least-squares scale of the fitted model's
prediction onto its measured angle (both about their means) from the other logs' median is printed, with the
cautions the rule gives. Synthetic data: the config's generator ranges and ``--seed``.

    python benchmarks/bench_log_scales.py --config configs/sweeps/draw54.yaml --seed 977 --cases 30

Stop 47 (the command above): largest spread 10.2 % over 30 cases (95th percentile 7.8 %), no caution given.
"""
from __future__ import annotations

import argparse
import tempfile

import numpy as np
import yaml


def main() -> None:
    from bpmid.config import load_config
    from bpmid.discover.cautions import LOG_SCALE_APART, _scales_apart
    from bpmid.discover.model import ModelState, residuals
    from bpmid.discover.workflow import DiscoverConfig, fit_base
    from bpmid.io.motion_logs import read_motion_logs
    from bpmid.models.vbmm import starting_vbmm
    from bpmid.validation.generator import case_paths, generator_config, make_cases, write_case

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--config", default="configs/sweeps/draw54.yaml", help="sweep config whose generator ranges to use")
    ap.add_argument("--seed", type=int, default=977)
    ap.add_argument("--cases", type=int, default=30)
    a = ap.parse_args()
    g = dict(yaml.safe_load(open(a.config))["generator"])
    g.update(n_cases=max(a.cases, 4), mix={"single": 0.5, "null": 0.5})
    cases = make_cases(generator_config(g), seed=a.seed, prefix="sc")[:a.cases]
    spreads, said = [], 0
    with tempfile.TemporaryDirectory() as tmp:
        for case in cases:
            write_case(case, tmp)
            paths = case_paths(f"{tmp}/{case.id}")
            cfg = load_config(paths["config"])
            fit = read_motion_logs(paths["fit"], cfg.section("io"), require_angle=True)
            ho = read_motion_logs(paths["holdout"], cfg.section("io"), require_angle=True)
            state, _res, _ = fit_base(ModelState.start(starting_vbmm(paths["init"], cfg.section("model"))[0]), fit,
                                      DiscoverConfig())
            every = ([(lg, p, "fitting") for lg, p in zip(fit, residuals(state, fit))]
                     + [(lg, p, "held-out") for lg, p in zip(ho, residuals(state, ho))])
            sc = []
            for lg, p, _ in every:
                y = lg.angle_deg - np.mean(lg.angle_deg)
                s = p + lg.angle_deg
                s = s - np.mean(s)
                sc.append(float(s @ y) / float(s @ s))
            sc = np.array(sc)
            spread = max(abs(sc[i] / np.median(np.delete(sc, i)) - 1.0) for i in range(sc.size))
            n = len(_scales_apart(every))
            said += n
            spreads.append(spread)
            print(f"{case.id}  {case.kind:<7} variation {case.variation:.3f}  largest spread {spread:.3f}  "
                  f"cautions {n}", flush=True)
    print(f"{len(spreads)} cases (synthetic: bpmid.validation, {a.config}, seed {a.seed}): largest spread "
          f"{max(spreads):.3f}, 95th percentile {np.percentile(spreads, 95):.3f}; the caution's limit "
          f"{LOG_SCALE_APART}; cautions given {said}")


if __name__ == "__main__":
    main()
