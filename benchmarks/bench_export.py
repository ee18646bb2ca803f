"""Benchmark of ``bpmid export --to c``: ns per step of the exported C and the state size in bytes, beside
bpmid's own us/step on the same samples, plus the measured error of the single-precision build.

    python benchmarks/bench_export.py            # needs a C compiler (cc, gcc or clang)

The C timing harness (written here, not shipped) reads the samples from a binary file, steps the model over
them ``repeats`` times (reset between passes) and prints the best ns/step, timed with clock_gettime. The
samples are every shipped motion log, back to back (each log from a fresh state). Timings on a shared
machine: compare the ratios, not the absolute numbers.
"""
from __future__ import annotations

import glob
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

HARNESS = r"""
#define _POSIX_C_SOURCE 199309L
#include <stdio.h>
#include <stdlib.h>
#include <time.h>
#include "bpmid_model.h"

static double now_ns(void) { struct timespec ts; clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &ts); return ts.tv_sec * 1e9 + ts.tv_nsec; }

int main(int argc, char **argv)
{
    /* file: n, then n triples (start_of_log flag, t, x) as doubles; argv[2]: repeats; argv[3]: 0 forward, 1 inverse */
    FILE *f = fopen(argv[1], "rb");
    double nd, *buf, best = 1e300, sink = 0.0;
    long n, i;
    int r, reps = atoi(argv[2]), inv = atoi(argv[3]);
    bpmid_state s;
    if (!f || fread(&nd, sizeof nd, 1, f) != 1) return 1;
    n = (long)nd;
    buf = malloc(sizeof(double) * 3 * n);
    if (fread(buf, sizeof(double), 3 * n, f) != (size_t)(3 * n)) return 1;
    fclose(f);
    bpmid_init(&s);
    for (r = 0; r < reps; ++r) {
        double t0 = now_ns(), t1;
        for (i = 0; i < n; ++i) {
            if (buf[3 * i] != 0.0) bpmid_reset(&s);
            sink += inv ? bpmid_step_inverse(&s, buf[3 * i + 1], buf[3 * i + 2])
                        : bpmid_step_forward(&s, buf[3 * i + 1], buf[3 * i + 2]);
        }
        t1 = now_ns();
        if ((t1 - t0) / n < best) best = (t1 - t0) / n;
    }
    printf("%.3f %d %.17g\n", best, (int)sizeof(bpmid_state), sink);
    return 0;
}
"""


def shipped_logs():
    from bpmid.io.motion_logs import read_motion_logs

    return read_motion_logs(sorted(glob.glob(str(REPO / "datasets" / "motion" / "*" / "*.csv"))))


def time_c(src_dir: Path, logs, values, *, inverse: bool = False, repeats: int = 20, single: bool = False,
           work: Path | None = None) -> tuple[float, int]:
    """Best ns/step of the exported model in ``src_dir`` over ``logs`` (inputs ``values``: one array per log),
    and sizeof(bpmid_state)."""
    from bpmid.export.c import find_cc

    work = Path(work or tempfile.mkdtemp())
    (work / "harness.c").write_text(HARNESS)
    exe = work / ("harness_f" if single else "harness")
    subprocess.run([find_cc(), "-std=c99", "-O2", *(["-DBPMID_FLOAT"] if single else []), f"-I{src_dir}",
                    str(work / "harness.c"), str(src_dir / "bpmid_model.c"), "-o", str(exe), "-lm"], check=True)
    rows = []
    for lg, v in zip(logs, values):
        start = np.zeros(lg.n)
        start[0] = 1.0
        rows.append(np.column_stack([start, lg.time_s, v]))
    data = np.vstack(rows)
    (work / "data.bin").write_bytes(np.concatenate([[float(len(data))], data.ravel()]).astype("<f8").tobytes())
    out = subprocess.run([str(exe), str(work / "data.bin"), str(repeats), "1" if inverse else "0"],
                         capture_output=True, text=True, check=True).stdout.split()
    return float(out[0]), int(out[1])


def time_bpmid_forward(model, logs, repeats: int = 5) -> float:
    """Best us/step of bpmid's compiled forward model over the logs (one call per log)."""
    model.forward(logs[0].time_s[:5], logs[0].pressure_pa[:5])
    best = np.inf
    n = sum(lg.n for lg in logs)
    for _ in range(repeats):
        t0 = time.process_time()
        for lg in logs:
            model.forward(lg.time_s, lg.pressure_pa)
        best = min(best, time.process_time() - t0)
    return 1e6 * best / n


def export_model(model, work: Path, name: str, effects=None, model_kind=None, path=None) -> Path:
    from bpmid.export.c import export_c
    from bpmid.io.results import dump_yaml
    from bpmid.models.vbmm import vbmm_yaml_body

    if path is None:
        body = {"schema": "bpmid.vbmm/1", **vbmm_yaml_body(model)}
        if effects:
            body["effects"] = effects
        path = work / f"{name}.yaml"
        path.write_text(dump_yaml(body))
    export_c(path, work / name, model_kind, command="benchmarks/bench_export.py")
    return work / name


def main() -> None:
    from bpmid.export.c import CModel, build_c, find_cc, load_vbmm_fit
    from bpmid.models.vbmm import VBMM, Material

    if find_cc() is None:
        print("no C compiler (cc, gcc or clang): nothing to measure")
        return
    logs = shipped_logs()
    n = sum(lg.n for lg in logs)
    work = Path(tempfile.mkdtemp(prefix="bench_export_"))
    cases = {
        "VBMM, 1 branch (paper's refit constants)": (VBMM(Material.paper_fit()), None),
        "VBMM, 3 branches, split tau": (VBMM(Material(9000.0, 6.0e6, (15000.0, 4000.0, 2000.0), (1.2e7, 3.0e6, 1e6),
                                                       (0.3, 6.0, 40.0), (0.25, 9.0, 50.0))), None),
        "VBMM, 1 branch + pressure lag + braid friction + offset": (VBMM(Material.paper_fit()), [
            {"id": "pressure_lag", "parameters": {"tau": 0.2}},
            {"id": "braid_friction", "parameters": {"r": 2500.0}},
            {"id": "angle_offset", "parameters": {"offset": 1.0}}]),
        # the friction discovery names: 3 elements with a pressure-proportional band and an elastic stick (the
        # inverse bisects the friction operators' mean output)
        "VBMM, 1 branch + lag + friction (3 el., mu, slip) + offset": (VBMM(Material.paper_fit()), [
            {"id": "pressure_lag", "parameters": {"tau": 0.2}},
            {"id": "braid_friction", "settings": {"elements": 3},
             "parameters": {"r": 1500.0, "mu": 0.02, "slip": 8000.0}},
            {"id": "angle_offset", "parameters": {"offset": 1.0}}]),
    }
    print(f"{n} samples ({len(logs)} shipped motion logs); times on a shared 2-core machine")
    print(f"{'model':58s} {'C fwd ns/step':>13s} {'C inv ns/step':>13s} {'state B':>8s} {'bpmid fwd us/step':>17s} "
          f"{'ratio':>6s}")
    for i, (label, (model, fx)) in enumerate(cases.items()):
        src = export_model(model, work, f"m{i}", fx)
        fwd_ns, size = time_c(src, logs, [lg.pressure_pa for lg in logs], work=work)
        ang = [load_vbmm_fit(work / f"m{i}.yaml").simulate_deg(lg.time_s, lg.pressure_pa) for lg in logs]
        inv_ns, _ = time_c(src, logs, ang, inverse=True, work=work)
        if fx:   # the base kernel's timing helper runs no effects: those rows time the C alone
            print(f"{label:58s} {fwd_ns:13.1f} {inv_ns:13.1f} {size:8d} {'not timed':>17s} {'-':>6s}")
            continue
        us = time_bpmid_forward(model, logs)
        print(f"{label:58s} {fwd_ns:13.1f} {inv_ns:13.1f} {size:8d} {us:17.3f} {1e3 * us / fwd_ns:6.1f}")
    # single precision: the error against the double build over every shipped log
    src = export_model(VBMM(Material.paper_fit()), work, "single")
    lib_d = CModel(build_c(src, work / "libd.so", shared=True))
    lib_f = CModel(build_c(src, work / "libf.so", shared=True, single=True))
    err_fwd = max(float(np.max(np.abs(lib_f.run_forward(lg.time_s, lg.pressure_pa)
                                      - lib_d.run_forward(lg.time_s, lg.pressure_pa)))) for lg in logs)
    err_inv = max(float(np.max(np.abs(lib_f.run_inverse(lg.time_s, lg.angle_deg)
                                      - lib_d.run_inverse(lg.time_s, lg.angle_deg)))) for lg in logs)
    fns, fsize = time_c(src, logs, [lg.pressure_pa for lg in logs], single=True, work=work)
    print(f"single precision (-DBPMID_FLOAT), 1 branch: forward max error {err_fwd:.2e} deg, inverse max error "
          f"{err_inv:.2e} Pa against the double build; {fns:.1f} ns/step, state {fsize} B")


if __name__ == "__main__":
    main()
