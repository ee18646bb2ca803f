"""(Re)generate the shipped synthetic relaxation logs in ``datasets/relaxation/``.

The paper's protocol (EXPERIMENTS.md): crosshead 300 and 400 mm/min, strain levels 15-40 %, 60 s
hold, 50 mm gauge length, logged at 50 Hz with load-cell noise. The specimen follows the paper's
one-term fit (E_inf = 0.0272 MPa, E_1 = 0.0549 MPa, tau_1 = 0.399 s); each test's moduli and time
constant vary by a few per cent (the paper reports a 6.5 % coefficient of variation between tests).
Every file says it is synthetic and carries its own truth and the seed.

Run ``python -m bpmid.twin.make_relaxation_dataset [OUT_DIR] [--seed N]``.
"""
from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

from bpmid.io.atomic import staged_file, write_text
from bpmid.twin.relaxation import PronyTruth, paper_protocol, simulate_relaxation_test

SEED = 14062025
#: the paper's one-term fit (seed 000, section V.A)
PAPER_TRUTH = PronyTruth(E_inf_mpa=0.0272, E_mpa=(0.0549,), tau_s=(0.399,))
#: test-to-test variation (lognormal sigma) of the moduli and of the time constant
MODULUS_SPREAD = 0.05
TAU_SPREAD = 0.05


def make_relaxation_dataset(out_dir: str | Path, seed: int = SEED, truth: PronyTruth = PAPER_TRUTH,
                            modulus_spread: float = MODULUS_SPREAD, tau_spread: float = TAU_SPREAD) -> list[Path]:
    """Write one CSV per test (``time_s,strain,stress_mpa``) and a README into ``out_dir``.

    Parameters
    ----------
    out_dir : folder to write
    seed : seed of the numpy Generator (recorded in every file)
    truth : the population's relaxation modulus
    modulus_spread, tau_spread : lognormal sigma of each test's modulus and time-constant factors

    Returns
    -------
    the CSV paths written
    """
    out_dir = Path(out_dir)
    rng = np.random.default_rng(seed)
    written, rows = [], []
    for test in paper_protocol():
        fm = float(np.exp(modulus_spread * rng.standard_normal()))
        ft = float(np.exp(tau_spread * rng.standard_normal()))
        tt = truth.scaled(fm, ft)
        df = simulate_relaxation_test(test, tt, rng)
        name = f"relax_{test.crosshead_mm_per_min:.0f}mmmin_{round(test.strain_level * 100):d}pct.csv"
        head = [
            "# synthetic: true",
            f"# generator: bpmid.twin.make_relaxation_dataset, seed {seed}",
            f"# crosshead_mm_per_min: {test.crosshead_mm_per_min:g}",
            f"# strain_level: {test.strain_level:g}",
            f"# gauge_length_mm: {test.gauge_length_mm:g}",
            f"# cross_section_mm2: {test.cross_section_mm2:g}",
            f"# truth_E_inf_mpa: {tt.E_inf_mpa:.6g}",
            f"# truth_E_mpa: {', '.join(f'{e:.6g}' for e in tt.E_mpa)}",
            f"# truth_tau_s: {', '.join(f'{t:.6g}' for t in tt.tau_s)}",
        ]
        body = df[["time_s", "strain", "stress_mpa"]].to_csv(index=False, float_format="%.8g", lineterminator="\n")
        path = out_dir / name
        with staged_file(path) as tmp:
            tmp.write_text("\n".join(head) + "\n" + body)
        written.append(path)
        rows.append(f"| {name} | {test.crosshead_mm_per_min:g} | {test.strain_level:.2f} | {test.ramp_s:.2f} | "
                    f"{tt.E_inf_mpa:.5f} | {tt.E_mpa[0]:.5f} | {tt.tau_s[0]:.4f} |")
    t0 = paper_protocol()[0]
    readme = f"""# Synthetic relaxation logs (not measured data)

Made by `python -m bpmid.twin.make_relaxation_dataset datasets/relaxation --seed {seed}`
(code: `bpmid/twin/relaxation.py`, `bpmid/twin/make_relaxation_dataset.py`). No measured logs of the
paper are public; these follow its protocol (seed 000, section V.A; spec/EXPERIMENTS.md).

- uniaxial ramp and hold: crosshead 300 and 400 mm/min, strain levels 15-40 %, 60 s hold, 0.5 s at rest
  before the ramp; gauge length {t0.gauge_length_mm:g} mm (strain rates 0.1 and 0.133 1/s, ramps 1.1-4 s),
  cross-section {t0.cross_section_mm2:g} mm^2; logged at {t0.rate_hz:g} Hz
- stress from the linear-viscoelastic hereditary integral of the ramp, in closed form
- the machine logs: extension quantised to {t0.extension_resolution_mm:g} mm; load with load-cell noise of
  {t0.load_noise_n * 1e3:g} mN standard deviation, lag-1 correlation {t0.load_noise_corr:g} (filtered), quantised to
  {t0.load_resolution_n * 1e3:g} mN; the files hold strain = extension / gauge length and nominal stress = load / cross-section
- population truth: the paper's one-term fit E_inf = {truth.E_inf_mpa} MPa, E_1 = {truth.E_mpa[0]} MPa,
  tau_1 = {truth.tau_s[0]} s; each test scales the moduli and the time constant by lognormal factors
  (sigma {modulus_spread:g} and {tau_spread:g}) to mimic test-to-test variation; seed {seed}

Each file's own truth (also in its `# truth_...` header lines):

| file | crosshead (mm/min) | strain | ramp (s) | E_inf (MPa) | E_1 (MPa) | tau_1 (s) |
|---|---|---|---|---|---|---|
""" + "\n".join(rows) + "\n"
    write_text(out_dir / "README.md", readme)
    return written


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("out_dir", nargs="?", default="datasets/relaxation")
    ap.add_argument("--seed", type=int, default=SEED)
    a = ap.parse_args(argv)
    paths = make_relaxation_dataset(a.out_dir, a.seed)
    print(f"wrote {len(paths)} logs and README.md to {a.out_dir} (seed {a.seed})")


if __name__ == "__main__":
    main()
