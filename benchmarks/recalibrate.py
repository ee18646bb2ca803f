"""Calibrate the discovery gate from the calibration halves of one or more finished sweeps and write the thresholds.

    python benchmarks/recalibrate.py out/sweep-full/records.jsonl out/sweep-draw13/records.jsonl \\
        [--rerun out/pair-trials/records.jsonl] --configs configs/sweeps/full.yaml configs/sweeps/draw13.yaml [--write]

Reads every record run with the permissive calibration settings (``bpmid calibrate ... --split calibration``, or
``--split pool`` for both halves of a draw whose held-out half was already looked at and so can no longer score a
gate; they stream to ``OUT/records.jsonl``), pools them (the cases of different draws are different data sets) and
runs :func:`bpmid.discover.calibrate.thresholds_from_records`; prints the chosen gate and its in-sample outcome per
case kind; with ``--write`` writes ``bpmid/discover/thresholds.yaml`` (the file bpmid ships). Records scored with a
gate (a held-out half) are never read: the draw that scores the shipped gate must not be among the inputs. Synthetic data: :mod:`bpmid.validation`, with the sweep configs and seeds named in the file written.
"""
from __future__ import annotations

import argparse
from collections import Counter
from pathlib import Path


def _halves(recs, name: str) -> str:
    """Which halves of the sweep ``name`` the records cover, in words."""
    got = {r["split"] for r in recs if r["id"].startswith(name + "-")}
    return {frozenset({"calibration", "heldout"}): "both halves", frozenset({"heldout"}): "held-out half",
            frozenset({"calibration"}): "calibration half"}.get(frozenset(got), "no case")


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("records", nargs="+", type=Path, help="records.jsonl of finished sweeps")
    ap.add_argument("--configs", nargs="+", required=True, help="the sweep configs the records were made with")
    ap.add_argument("--rerun", nargs="*", type=Path, default=[],
                    help="records.jsonl of cases rerun with more recorded (benchmarks/record_pair_trials.py): each "
                         "replaces the same case's record; cases not among RECORDS are ignored")
    ap.add_argument("--later-only", action="store_true",
                    help="hold the shipped first stage (gain, share, alpha, fitting share and its waiver) and choose "
                         "only the later stages: for a change that touches only later rounds, on records regenerated "
                         "with it; prints the shipped later stages' outcome on the same records beside")
    ap.add_argument("--write", action="store_true", help="write bpmid/discover/thresholds.yaml")
    a = ap.parse_args(argv)

    from bpmid.discover.calibrate import (_case_outcome, case_records, floor_drops, later_stages_from_records,
                                          load_thresholds, pair_records, thresholds_from_records, write_thresholds)
    from bpmid.validation.sweep import GENERATOR, calibration_records, load_sweep

    if a.later_only and a.write:
        ap.error("--later-only compares later stages with the shipped ones; --write needs a full recalibration "
                 "(drop --later-only)")
    missing = [str(p) for p in [*a.records, *a.rerun] if not p.is_file()]
    if missing:
        ap.error(f"records file not found: {', '.join(missing)} (a finished sweep's OUT/records.jsonl)")
    cfgs = [load_sweep(c) for c in a.configs]
    by_id = calibration_records(a.records)
    replaced: dict[str, int] = {}
    for path in a.rerun:   # a case rerun (e.g. with more recorded) replaces its record; others ignored
        for i, r in calibration_records([path]).items():
            if i in by_id:
                by_id[i] = r
                replaced[str(path)] = replaced.get(str(path), 0) + 1
    recs = list(by_id.values())
    if a.rerun:
        print("cases taken from the reruns (a later file's record of a case replaces an earlier one): "
              + ", ".join(f"{n} from {p}" for p, n in replaced.items()) + f", of {len(recs)}")
    R = [x for rec in recs for x in case_records(rec)]
    P = [q for rec in recs for q in pair_records(rec)]
    if a.later_only:
        shipped = load_thresholds()
        values = later_stages_from_records(R, P, shipped)
    else:
        values = thresholds_from_records(R, P)
    def outcome(v: dict, title: str) -> None:
        """Each case kind's right decisions and names counted against under the thresholds ``v``."""
        gate = dict(g=v["heldout_gain_min_sigma"], share=v["gap_share_min"], alpha=v["family_alpha"],
                    fit_share=v["fit_share_min"], waive=v["fit_share_waived_above_sigma"],
                    g_later=v["heldout_gain_min_sigma_later"], to_floor=floor_drops(v),
                    pair_share=v["pair_share_min"], pair_gain=v["pair_gain_min_sigma"],
                    pair_over=v["pair_over_single_min_sigma"], pair_over_gain=v["pair_over_gain_min_sigma"])
        tally = Counter()
        for rec in recs:
            rs = case_records(rec)
            if rs:
                right, wrong = _case_outcome(rs, **gate, pairs=pair_records(rec))
                tally[(rec["kind"], "cases")] += 1
                tally[(rec["kind"], "right")] += right
                tally[(rec["kind"], "wrong")] += wrong
        print(title)
        for kind in ("single", "pair", "null", "out_of_catalogue"):
            print(f"  {kind:<17} right {tally[(kind, 'right')]:>3} of {tally[(kind, 'cases')]:>3}, "
                  f"names counted against {tally[(kind, 'wrong')]}")

    print({k: values[k] for k in values})
    outcome(values, "chosen" + (" (the shipped first stage held)" if a.later_only else "") + ":")
    if a.later_only:
        print("later stages chosen against shipped: " + ", ".join(
            f"{k} {values[k]:g} vs {shipped[k]:g}" for k in ("heldout_gain_min_sigma_later", "to_floor_drop_min_sigma",
                                                         "pair_share_min", "pair_gain_min_sigma",
                                                         "pair_over_single_min_sigma", "pair_over_gain_min_sigma"))
              + f"; drops by effect {values['to_floor_drop_by_effect']} vs {shipped.get('to_floor_drop_by_effect')}")
        outcome(shipped, "the shipped thresholds on the same records:")
    if a.write:
        meta = {"produced_by": "python benchmarks/recalibrate.py " + " ".join(str(p) for p in a.records)
                + (" --rerun " + " ".join(str(p) for p in a.rerun) if a.rerun else "")
                + " --configs " + " ".join(a.configs) + " --write",
                "data": f"{len(recs)} out-of-family cases ({GENERATOR}), run with the permissive calibration "
                        "settings: " + ", ".join(
                            f"{c.sweep.name} (seed {c.sweep.seed}, " + _halves(recs, c.sweep.name) + ")" for c in cfgs)
                        + "; pairs included; the draw that scores the gate is not among them"
                        + ("; rerun with more recorded (a later file's record of a case replaces an earlier one): "
                           + ", ".join(f"{n} from {p}" for p, n in replaced.items())
                           + " (cases rerun by benchmarks/record_pair_trials.py, record_rivals.py or "
                             "record_pool.py --only, with the same permissive settings)" if a.rerun else ""),
                "method": "gaps above the noise in quadrature (sqrt(RMSE^2 - floor^2)); per-log nuisance factors on "
                          "K_inf, branch moduli and time constants (held-out logs' mean within 2.5 standard "
                          "errors of the fitting logs' spread, at most 10 %, bounded jointly: the mean within those "
                          "bounds that costs the held-out error least); friction with a pressure-proportional "
                          "band and an elastic stick; pairs scored (round 1 names one, round 2 the other)",
                "rule": "thresholds_from_records: no null named; out-of-catalogue names within the 90 % upper bound "
                        "of a 20 % rate; the most right decisions minus twice the wrong names minus the "
                        "out-of-catalogue names; ties to the stricter gate; the 10 best first-stage gates each then "
                        "get the gain asked of a further effect (at most the first round's), the drop asked on the "
                        "path to the noise floor (a round where nothing passes), then each effect's own drop there "
                        "(kept at the common drop unless its own scores better), the joint share and the gain of "
                        "each beside the other asked on the path for two effects at once (a first round where nothing "
                        "passes either path), and the margin over the single effect and the gain of each beside the "
                        "other asked of two effects named at once over the one a first round would name, each by the "
                        "same score within the same bounds; the best final score wins; the rivals outside the "
                        "catalogue (a ringing payload, an air leak through an orifice) withhold as in discovery",
                "generator": cfgs[0].effective_generator.to_yaml()}
        print("wrote", write_thresholds(values, meta))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
