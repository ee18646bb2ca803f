"""Check core.py against the golden values of shared/spec/VBMM.md section 8 (paper closure, VBMM-fit constants)."""
import math
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).parent))
from core import ATM, PAPER_FIT, PAPER_GEOM, Muscle, relaxed_pressure  # noqa: E402

EQ = [(5, -0.015743, 0.007449, -0.000941, 6345.526), (15, -0.047556, 0.022326, -0.002843, 19376.498),
      (30, -0.096090, 0.044587, -0.005744, 39784.019), (45, -0.145591, 0.066782, -0.008702, 61242.679),
      (60, -0.196050, 0.088907, -0.011718, 83772.320), (75, -0.247458, 0.110963, -0.014791, 107392.445),
      (90, -0.299804, 0.132945, -0.017920, 132122.161)]
TRACE = [14.4704, 23.4078, 36.3049, 49.7918, 63.0009, 59.9460, 49.2895, 36.3243, 22.2985, 25.4904, 36.8467,
         49.9296, 63.0352, 67.9364, 69.1477, 69.4468, 69.5207]


def main():
    worst_p = 0.0
    for b, u, e1, e2, P in EQ:
        p, u3, a1, a2 = relaxed_pressure(PAPER_GEOM, PAPER_FIT, math.radians(b))
        assert abs(u3 * 1e3 - u) < 6e-7 and abs(a1 - e1) < 6e-7 and abs(a2 - e2) < 6e-7, b
        worst_p = max(worst_p, abs(p - P))
    t = np.round(np.arange(0, 16.0001, 0.1), 10)
    pa = np.where(t <= 4, 1.2 + 0.2 * t, np.where(t <= 8, 2.0 - 0.2 * (t - 4),
                  np.where(t <= 12, 1.2 + 0.2 * (t - 8), 2.0)))
    beta = np.degrees(Muscle(PAPER_GEOM, PAPER_FIT).run(t, pa * 1e5 - ATM))
    d = np.abs(beta[::10] - np.array(TRACE)).max()
    print(f"equilibrium table: max |P - golden| = {worst_p:.2e} Pa (golden printed to 1e-3 Pa)")
    print(f"forward trace: max |beta - golden| = {d:.2e} deg (spec asks 1e-3)")
    assert worst_p < 2e-3 and d < 1e-3
    print("golden values: OK")


if __name__ == "__main__":
    main()
