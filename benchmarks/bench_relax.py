"""Benchmark of ``bpmid fit relax``: the measured pyvisco master curve against peer fits, and ramp vs step mode;
the DMTA frequency-domain data (storage and loss modulus) against pyvisco 2.1.3 and the ANSYS reference table, and
the shift factors of the raw sweeps against pyvisco's.

Run ``python benchmarks/bench_relax.py`` (everything) or ``python benchmarks/bench_relax.py --freq`` (the frequency
part only). The frequency part installs pyvisco 2.1.3 into a throwaway venv under /tmp (``pip install
pyvisco==2.1.3``; never a bpmid dependency), runs it on the same files with its default settings and removes the
venv; set ``BPMID_PYVISCO_VENV`` to an existing venv with pyvisco to reuse it. Without network access it falls back
to the pyvisco outputs shipped in datasets/reference/pyvisco-frequency/ (and says so). Time-domain peers' RMSE are
recomputed here from their shipped term files; their times are the ones measured when they were run
(datasets/reference/pyvisco/README.md).
"""
from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from bpmid.io.relax_logs import RelaxLog, read_relax_log  # noqa: E402
from bpmid.relax import fit_relaxation  # noqa: E402
from bpmid.twin.relaxation import PronyTruth, paper_protocol, simulate_relaxation_test  # noqa: E402

REF = ROOT / "datasets" / "reference" / "pyvisco"
FREF = ROOT / "datasets" / "reference" / "pyvisco-frequency"

#: what pyvisco runs (its default pipeline, as in its verification notebooks; RefT = -5 C for the raw sets)
PYVISCO_SCRIPT = r"""
import json, sys, time, warnings
warnings.filterwarnings("ignore")
import matplotlib
matplotlib.use("Agg")
import numpy as np
import pyvisco as visco
R = sys.argv[1]
out = {}
t0 = time.perf_counter()
data = visco.load.file(R + "/freq_user_master.csv")
df_master, units = visco.load.user_master(data, "freq", -5, "E")
df_master = visco.master.smooth(df_master, win=1)
df_dis = visco.prony.discretize(df_master)
prony, _ = visco.prony.fit(df_dis, df_master)
out["master_seconds"] = time.perf_counter() - t0
out["master"] = dict(E_0=float(prony["E_0"]), tau=prony["df_terms"]["tau_i"].tolist(),
                     alpha=prony["df_terms"]["alpha_i"].tolist())
t0 = time.perf_counter()
dict_prony, N_opt, err = visco.opt.nprony(df_master, prony, window="min")
out["nprony_seconds"] = time.perf_counter() - t0
p = dict_prony[N_opt]
out["nprony"] = dict(E_0=float(p["E_0"]), tau=p["df_terms"]["tau_i"].tolist(), alpha=p["df_terms"]["alpha_i"].tolist())
for name in ("freq_user_raw.csv", "freq_Eplexor_raw.xls"):
    data = visco.load.file(R + "/" + name)
    t0 = time.perf_counter()
    if name.endswith(".xls"):
        df_raw, _, units = visco.load.Eplexor_raw(data, "E")
    else:
        df_raw, _, units = visco.load.user_raw(data, "freq", "E")
    df_aT, _ = visco.master.get_aT(df_raw, -5)
    w = visco.shift.fit_WLF(-5, df_aT).iloc[0]
    out[name] = dict(seconds=time.perf_counter() - t0, T=df_aT["T"].tolist(), log_aT=df_aT["log_aT"].tolist(),
                     C1=float(w["C1"]), C2=float(w["C2"]))
print("JSON" + json.dumps(out))
"""


def prony_rmse(t, E, E_inf, Ei, tau):
    model = E_inf + np.exp(-t[:, None] / tau[None, :]) @ Ei
    return float(np.sqrt(np.mean((E - model) ** 2)))


def peers(t, E):
    rows = []
    a = np.loadtxt(REF / "ansys_reference_prony_terms_KPf_MD.csv", delimiter=",", comments="#")
    E0 = 1739.03
    rows.append(("ANSYS reference (tau fixed, 1/decade)", a.shape[0],
                 prony_rmse(t, E, E0 * (1 - a[:, 0].sum()), E0 * a[:, 0], a[:, 1]), None))
    p = np.loadtxt(REF / "pyvisco_2.1.3_default_fit_time_user_master.csv", delimiter=",", skiprows=2)
    E0 = p[0, 3]
    rows.append(("pyvisco 2.1.3 defaults", p.shape[0], prony_rmse(t, E, E0 * (1 - p[:, 2].sum()), p[:, 4], p[:, 1]), 1.1))
    rows.append(("pyvisco 2.1.3 term selection (reported)", 26, 3.10, 14.6))
    return rows


def timed(fn, repeat=5):
    best, out = np.inf, None
    for _ in range(repeat):
        t0 = time.perf_counter()
        out = fn()
        best = min(best, time.perf_counter() - t0)
    return out, best


def master_curve():
    log = read_relax_log(REF / "time_user_master.csv")
    t, E = log.time_s, log.modulus_mpa
    print(f"== pyvisco master curve: {log.n} points, {np.log10(t[-1] / t[0]):.1f} decades, "
          f"{os.cpu_count()} cores ==")
    print(f"{'fit':44s} {'terms':>5s} {'RMSE MPa':>9s} {'time s':>7s}")
    fit, sec = timed(lambda: fit_relaxation([log]))
    print(f"{'bpmid, terms auto (BIC, max 32)':44s} {fit.m:5d} {fit.rmse_mpa:9.3f} {sec:7.2f}")
    fit31, sec31 = timed(lambda: fit_relaxation([log], terms=31))
    print(f"{'bpmid, 31 terms':44s} {fit31.m:5d} {fit31.rmse_mpa:9.3f} {sec31:7.2f}")
    for name, m, rmse, sec in peers(t, E):
        print(f"{name:44s} {m:5d} {rmse:9.3f} {'' if sec is None else f'{sec:7.2f}'}")
    crit = ", ".join(f"{c['terms']}: {c['criterion']:.1f}" for c in fit.selection)
    print(f"criterion per candidate (terms: BIC): {crit}")
    print(f"bpmid auto: R2 {fit.r2:.7f}, MAPE {fit.mape_pct:.3f} %, E_inf {fit.E_inf:.2f} MPa, "
          f"largest residual {max(np.max(np.abs(lg.y - lg.y_fit)) for lg in fit.logs):.2f} MPa (segment joins)")


def synthetic(truth: PronyTruth, seed: int, label: str):
    rng = np.random.default_rng(seed)
    logs = []
    for i, test in enumerate(paper_protocol()):
        df = simulate_relaxation_test(test, truth, rng)
        logs.append(RelaxLog(f"t{i}", df.time_s.to_numpy(), df.strain.to_numpy(), df.stress_mpa.to_numpy()))
    true = np.concatenate([[truth.E_inf_mpa], truth.E_mpa, truth.tau_s])
    names = ["E_inf"] + [f"E_{j + 1}" for j in range(len(truth.E_mpa))] + [f"tau_{j + 1}" for j in range(len(truth.tau_s))]
    print(f"== {label}: 12 ramp-and-hold logs (300/400 mm/min, 15-40 %, 50 Hz, 2 mN load noise), seed {seed} ==")
    print(f"{'constant':8s} {'truth':>9s} {'ramp':>9s} {'err %':>7s} {'+-se':>9s} {'step':>9s} {'err %':>7s}")
    fits = {}
    for mode in ("ramp", "step"):
        fits[mode], sec = timed(lambda: fit_relaxation(logs, mode=mode, terms=len(truth.E_mpa)), repeat=1)
        fits[mode + "_auto"] = fit_relaxation(logs, mode=mode)
        fits[mode + "_sec"] = sec
    r, s = fits["ramp"], fits["step"]
    rv = np.concatenate([[r.E_inf], r.E, r.tau])
    rse = np.concatenate([[r.se_E_inf], r.se_E, r.se_tau])
    sv = np.concatenate([[s.E_inf], s.E, s.tau])
    for n, tv, a, se, b in zip(names, true, rv, rse, sv):
        print(f"{n:8s} {tv:9.4g} {a:9.4g} {100 * (a / tv - 1):+7.2f} {se:9.2g} {b:9.4g} {100 * (b / tv - 1):+7.2f}")
    print(f"auto terms: ramp {fits['ramp_auto'].m}, step {fits['step_auto'].m} (truth {len(truth.E_mpa)}); "
          f"fit time ramp {fits['ramp_sec']:.2f} s, step {fits['step_sec']:.2f} s")


def run_pyvisco() -> tuple[dict | None, str]:
    """pyvisco 2.1.3 on the frequency files, in a throwaway venv; (results, how) or (None, why not)."""
    venv = os.environ.get("BPMID_PYVISCO_VENV")
    made = None
    try:
        if not venv:
            made = tempfile.mkdtemp(prefix="bpmid-pyvisco-", dir="/tmp")
            venv = made
            subprocess.run([sys.executable, "-m", "venv", venv], check=True, capture_output=True, timeout=300)
            r = subprocess.run([f"{venv}/bin/pip", "install", "-q", "pyvisco==2.1.3"], capture_output=True, text=True,
                               timeout=1200)
            if r.returncode != 0:
                return None, f"pip install pyvisco==2.1.3 failed ({r.stderr.strip().splitlines()[-1:]})"
        script = Path(venv) / "bench_pyvisco.py"
        script.write_text(PYVISCO_SCRIPT)
        r = subprocess.run([f"{venv}/bin/python", str(script), str(FREF)], capture_output=True, text=True,
                           timeout=1200, env={**os.environ, "OMP_NUM_THREADS": "1", "OPENBLAS_NUM_THREADS": "1"})
        line = next((ln for ln in r.stdout.splitlines() if ln.startswith("JSON")), None)
        if r.returncode != 0 or line is None:
            return None, f"pyvisco run failed: {r.stderr.strip().splitlines()[-1:]}"
        return json.loads(line[4:]), f"pyvisco 2.1.3 run now in {'a throwaway venv' if made else venv}"
    except (OSError, subprocess.SubprocessError) as exc:
        return None, f"could not run pyvisco ({exc})"
    finally:
        if made:
            shutil.rmtree(made, ignore_errors=True)


def shipped_pyvisco() -> dict:
    """The pyvisco 2.1.3 outputs shipped with the data (fallback when pyvisco cannot be installed)."""
    from bpmid.relax.tts import read_shift_file

    p = np.loadtxt(FREF / "pyvisco_2.1.3_default_fit_freq_user_master.csv", delimiter=",", skiprows=2)
    out = {"master": dict(E_0=float(p[0, 3]), tau=p[:, 1].tolist(), alpha=p[:, 2].tolist()), "master_seconds": None}
    for name, stem in (("freq_user_raw.csv", "freq_user_raw"), ("freq_Eplexor_raw.xls", "freq_Eplexor_raw")):
        f = FREF / f"pyvisco_2.1.3_shift_factors_{stem}.csv"
        T, a = read_shift_file(f)
        c = [ln for ln in f.read_text().splitlines() if ln.startswith("# WLF")][0]
        C1, C2 = (float(x.split("=")[1].split()[0].rstrip(",")) for x in c.split(",")[:2])
        out[name] = dict(seconds=None, T=T.tolist(), log_aT=a.tolist(), C1=C1, C2=C2)
    return out


def ansys_terms(path):
    vals = {}
    for line in open(path):
        if line.upper().startswith("TBDATA"):
            parts = line.strip().split(",")[1:]
            for k, v in enumerate(parts[1:]):
                vals[int(parts[0]) + k] = float(v)
    arr = np.array([vals[k] for k in sorted(vals)])
    return arr[0::2], arr[1::2]


def frequency(pv: dict | None, how: str):
    from bpmid.io.material_files import read_material_file
    from bpmid.relax import RelaxConfig
    from bpmid.relax.freq import complex_modulus, fit_frequency, rms_rel_pct
    from bpmid.relax.material import fit_material
    from bpmid.relax.tts import fit_wlf, overlap_rms, read_shift_file, shift_from_user

    if pv is None:
        print(f"pyvisco could not be run ({how}); comparing with the shipped pyvisco 2.1.3 outputs instead")
        pv, how = shipped_pyvisco(), "shipped pyvisco 2.1.3 outputs (datasets/reference/pyvisco-frequency)"
    d = read_material_file(FREF / "freq_user_master.csv")
    f, s, l = d.x, d.storage, d.loss
    print(f"== DMTA master curve freq_user_master.csv: {d.n} frequencies, {np.log10(f.max() / f.min()):.0f} decades; "
          f"peer: {how}; loaded machine, times are wall-clock ==")
    print("fit".ljust(52), "terms", "RMS rel E' %".rjust(13), "RMS rel E'' %".rjust(14), "time s".rjust(7))

    def row(name, m, sf, lf, sec):
        print(f"{name:52s} {m:5d} {rms_rel_pct(s, sf):13.3f} {rms_rel_pct(l, lf):14.2f} "
              f"{'' if sec is None else f'{sec:7.2f}'}")

    a, tau = ansys_terms(FREF / "ansys_prony_terms_freq_user_master.MPL")
    E0 = s[np.argmax(f)]
    row("ANSYS reference table (E0 = E' at f_max)", a.size, *complex_modulus(f, E0 * (1 - a.sum()), E0 * a, tau), None)
    for key, label in (("master", "pyvisco 2.1.3 default (1 term/decade)"),
                       ("nprony", "pyvisco 2.1.3 opt.nprony (term minimisation)")):
        if key in pv:
            p = pv[key]
            al, ta = np.array(p["alpha"]), np.array(p["tau"])
            row(label, al.size, *complex_modulus(f, p["E_0"] * (1 - al.sum()), p["E_0"] * al, ta),
                pv.get(f"{key}_seconds"))
    n_pv = len(pv["master"]["alpha"])
    for label, kw in ((f"bpmid, terms = {n_pv} (pyvisco's count)", dict(terms=n_pv)),
                      ("bpmid, terms auto (BIC, max 32)", dict()),
                      ("bpmid, terms auto (AICc, max 32)", dict(config=RelaxConfig(criterion="aicc"))),
                      ("bpmid, --max-error 7.5 (RMS |E*| error %)", dict(max_error_pct=7.5)),
                      ("bpmid, component weighting, terms auto", dict(config=RelaxConfig(freq_weighting="component")))):
        fit, sec = timed(lambda: fit_frequency(f, s, l, **kw), repeat=1)
        row(label, fit.m, fit.storage_fit, fit.loss_fit, sec)
        if label.startswith("bpmid, terms auto (BIC"):
            crit = ", ".join(f"{c['terms']}: {c['criterion']:.0f}" for c in fit.selection)
            auto_line = f"BIC per candidate (terms: BIC): {crit}"
    print(auto_line)
    print()
    for name, ship in (("freq_user_raw.csv", None), ("freq_Eplexor_raw.xls", "freq_Eplexor_raw__shift_factors.csv")):
        d = read_material_file(FREF / name)
        mf, sec = timed(lambda: fit_material([d], ref_temp=-5.0, terms=20), repeat=1)
        sh = mf.shift
        p = pv[name]
        want = shift_from_user(sh.T, np.array(p["T"]), np.array(p["log_aT"]), -5.0, name)
        cols = f"{'T C':>5s} {'bpmid':>8s} {'pyvisco':>8s} {'diff':>6s}"
        if ship:
            Ts, As = read_shift_file(FREF / ship)
            file_vals = shift_from_user(sh.T, Ts, As, -5.0, ship)
            cols += f" {'file':>8s} {'diff':>6s}"
        print(f"== shift factors log10 aT of {name} at T_ref = -5 C ({len(sh.T)} sets); bpmid shift + WLF + "
              f"20-term fit {sec:.2f} s" + (f", pyvisco get_aT + WLF {p['seconds']:.2f} s" if p.get("seconds") else "")
              + " ==")
        print(cols)
        o = np.argsort(sh.T)
        for i in o:
            line = f"{sh.T[i]:5.0f} {sh.log_aT[i]:8.2f} {want[i]:8.2f} {sh.log_aT[i] - want[i]:+6.2f}"
            if ship:
                line += f" {file_vals[i]:8.2f} {sh.log_aT[i] - file_vals[i]:+6.2f}"
            print(line)
        dev = np.max(np.abs(sh.log_aT - want))
        extra = ""
        if ship:
            extra = (f"; vs the shipped file {np.max(np.abs(sh.log_aT - file_vals)):.2f} (pyvisco 2.1.3 itself "
                     f"{np.max(np.abs(want - file_vals)):.2f})")
        print(f"largest |bpmid - pyvisco| {dev:.2f} decades{extra}")
        w = sh.wlf
        print(f"WLF at T_ref -5 C: bpmid C1 = {w['C1']:.2f} +- {w['se_C1']:.2f}, C2 = {w['C2']:.1f} +- {w['se_C2']:.1f} C "
              f"(RMSE {w['rmse']:.2f} decades); pyvisco C1 = {p['C1']:.2f}, C2 = {p['C2']:.1f} C")
        print(f"master-curve fit (20 terms): RMS rel E' {mf.fit.rms_rel_storage_pct:.2f} %, E'' "
              f"{mf.fit.rms_rel_loss_pct:.1f} %")
        if ship:
            wf = fit_wlf(sh.T, file_vals, -5.0)
            print(f"WLF fitted to the shipped file: C1 = {wf['C1']:.2f} +- {wf['se_C1']:.2f}, C2 = {wf['C2']:.1f} +- "
                  f"{wf['se_C2']:.1f} C (RMSE {wf['rmse']:.2f} decades)")
            print("superposition of neighbouring sets: RMS of log10 E' difference over their overlap (decades)")
            print(f"{'pair C':>12s} {'bpmid':>8s} {'pyvisco':>8s} {'file':>8s}")
            sets = d.sets()
            k_of = {float(t): i for t, i in sets}
            lx = {t: np.log10(d.x[i]) for t, i in k_of.items()}
            ly = {t: np.log10(d.storage[i]) for t, i in k_of.items()}
            Ts_sorted = sh.T[o]
            for a_, b_ in zip(Ts_sorted[:-1], Ts_sorted[1:]):
                ia, ib = int(np.flatnonzero(sh.T == a_)[0]), int(np.flatnonzero(sh.T == b_)[0])
                vals = [overlap_rms(lx[a_] + v[ia], ly[a_], lx[b_] + v[ib], ly[b_])[0]
                        for v in (sh.log_aT, want, file_vals)]
                print(f"{a_:5.0f}..{b_:5.0f} " + " ".join(f"{v:8.4f}" for v in vals))
        print()


def main():
    if "--freq" not in sys.argv:
        master_curve()
        print()
        synthetic(PronyTruth(0.0272, (0.0549,), (0.399,)), 11, "one-branch truth (the paper's constants)")
        print()
        synthetic(PronyTruth(0.0272, (0.0549, 0.0200), (0.399, 6.0)), 12, "two-branch truth")
        print()
    pv, how = run_pyvisco()
    frequency(pv, how)


if __name__ == "__main__":
    main()
