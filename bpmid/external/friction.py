"""External check on real friction hysteresis: Maxwell-slip and GPI on a 3D-printed pneumatic piston.

Data: ``datasets/reference/friction/Kidney_lc_{1..7}bar.csv`` (CC0; source in that folder's README).
A piston at constant supply pressure is moved back and forth over about 0-37 mm while a load cell
reads the force: displacement in (mm), force out (N), a dry-friction hysteresis loop. This is not
bending-muscle data; it checks that the hysteresis code paths (play and stop operator kernels,
variable-projection fits) fit a real, rate-independent hysteresis and predict a stroke they did not
see.

Protocol (:func:`external_check`): the record is cut into strokes at the displacement reversals
(dead band 1 mm). The models are fitted on every sample before the held-out strokes (the last
``n_test_strokes`` complete strokes, by default one extension and one retraction), then simulated over
the whole record from the start, so that the operator states at the held-out strokes come from the
input history alone, and scored on the held-out strokes. The loop height (median force while
extending minus median force while retracting, mid-stroke samples) puts the errors in scale.
"""
from __future__ import annotations

import dataclasses
from pathlib import Path
from typing import Sequence

import numpy as np

from bpmid import data as _shipped, metrics
from bpmid.errors import InputError
from bpmid.models._hysteresis_kernels import direction_with_deadband
from bpmid.models.gpi import GPIModel
from bpmid.models.maxwell_slip import MaxwellSlipModel

#: the copied data set (repository checkout)
DATA_DIR = (_shipped.root() / "datasets" / "reference" / "friction").resolve()
#: displacement change (mm) that counts as a stroke reversal (the laser jitters by about 0.01 mm)
REVERSAL_DEADBAND_MM = 1.0


@dataclasses.dataclass(frozen=True)
class FrictionLog:
    """One friction run.

    Attributes
    ----------
    name : file stem (``Kidney_lc_4bar``)
    path : source file
    time_s : (N,) s, from the ms column
    displacement_mm : (N,) piston displacement (laser), mm
    pressure_bar : (N,) supply pressure, bar gauge
    force_n : (N,) load-cell force, N
    """

    name: str
    path: Path
    time_s: np.ndarray
    displacement_mm: np.ndarray
    pressure_bar: np.ndarray
    force_n: np.ndarray

    @property
    def n(self) -> int:
        return int(self.time_s.size)


def friction_files(data_dir: str | Path | None = None) -> list[Path]:
    """The ``Kidney_lc_*bar.csv`` files, sorted by pressure (1..7 bar)."""
    d = Path(data_dir) if data_dir is not None else DATA_DIR
    files = sorted(d.glob("Kidney_lc_*bar.csv"), key=lambda p: int(p.stem.split("_")[-1].removesuffix("bar")))
    if not files:
        raise InputError("no Kidney_lc_*bar.csv files found", path=d)
    return files


def read_friction_log(path: str | Path) -> FrictionLog:
    """Read one file (tab-separated, no header, CRLF, 7 columns: ms, 3 raw V, mm, bar gauge, N)."""
    path = Path(path)
    try:
        data = np.loadtxt(path, dtype=float, ndmin=2)
    except (OSError, ValueError) as exc:
        raise InputError(f"cannot read a friction log: {exc}", path=path) from exc
    if data.shape[1] != 7:
        raise InputError(f"expected 7 tab-separated columns (ms, 3 raw V, mm, bar, N), found {data.shape[1]}",
                         path=path)
    t = data[:, 0] / 1e3
    if data.shape[0] < 2 or np.any(np.diff(t) <= 0):
        bad = int(np.argmax(np.diff(t) <= 0)) + 2 if data.shape[0] >= 2 else 1
        raise InputError("time (column 1, ms) must increase strictly", path=path, line=bad)
    return FrictionLog(path.stem, path, t, data[:, 4].copy(), data[:, 5].copy(), data[:, 6].copy())


def strokes(displacement_mm: np.ndarray, deadband_mm: float = REVERSAL_DEADBAND_MM) -> list[tuple[int, int]]:
    """Strokes as ``(start, stop)`` index ranges between displacement reversals.

    A reversal is the extremum before the displacement has moved ``deadband_mm`` the other way. The
    last range runs to the end of the record and may be incomplete.
    """
    x = np.ascontiguousarray(displacement_mm, float)
    direction = direction_with_deadband(x, deadband_mm)
    flips = np.flatnonzero(np.diff(direction) != 0) + 1
    cuts = [0]
    for j, f in enumerate(flips):
        prev = cuts[-1]
        seg = x[prev:f + 1]
        # the dead band sees a reversal late: cut at the extremum itself
        cuts.append(prev + int(np.argmin(seg) if direction[f] > 0 else np.argmax(seg)))
    cuts.append(x.size)
    return [(a, b) for a, b in zip(cuts[:-1], cuts[1:]) if b > a]


def loop_height(displacement_mm: np.ndarray, force_n: np.ndarray, deadband_mm: float = REVERSAL_DEADBAND_MM) -> float:
    """Median force while extending minus median force while retracting (N), mid-stroke samples only.

    Mid-stroke: displacement inside the middle half of its range, where the loop is flat.
    """
    x = np.asarray(displacement_mm, float)
    direction = direction_with_deadband(np.ascontiguousarray(x), deadband_mm)
    lo, hi = np.percentile(x, [25, 75])
    mid = (x > lo) & (x < hi)
    up, dn = mid & (direction > 0), mid & (direction < 0)
    if not (up.any() and dn.any()):
        raise InputError("the record has no mid-stroke samples in both directions")
    return float(np.median(force_n[up]) - np.median(force_n[dn]))


def default_models() -> dict:
    """The two checked families, set up for displacement in mm and force in N."""
    return {"maxwell-slip": MaxwellSlipModel(n_elements=4, poly_degree=2, input_unit="mm", output_unit="N"),
            "gpi": GPIModel(n_operators=10, envelope="linear", threshold_grid="quadratic", input_unit="mm",
                           output_unit="N")}


def external_check(path: str | Path, *, models: dict | None = None, n_test_strokes: int = 2) -> dict:
    """Fit on the strokes before the held-out ones, score the held-out strokes (see module docstring).

    Parameters
    ----------
    path : one ``Kidney_lc_*bar.csv``
    models : name -> model with ``fit_arrays``/``simulate_arrays`` (default :func:`default_models`)
    n_test_strokes : number of complete strokes held out at the end of the record

    Returns
    -------
    dict
        ``file``, ``n_train``, ``n_test`` (samples), ``loop_height_n``, ``force_range_n`` and, per model,
        ``{rmse_n, max_abs_err_n, train_rmse_n, r2, fit_pct}`` on the held-out strokes.
    """
    log = read_friction_log(path)
    pieces = strokes(log.displacement_mm)
    complete = pieces[:-1]  # the last piece runs to the end of the record and may be cut short
    if len(complete) < n_test_strokes + 2:
        raise InputError(f"{len(complete)} complete strokes are too few: need {n_test_strokes} held out and at "
                         f"least 2 to fit", path=log.path)
    test_start, test_stop = complete[-n_test_strokes][0], complete[-1][1]
    x, f = log.displacement_mm, log.force_n
    out = {"file": log.name, "n_train": int(test_start), "n_test": int(test_stop - test_start),
           "loop_height_n": loop_height(x[:test_start], f[:test_start]),
           "force_range_n": float(np.ptp(f[test_start:test_stop])), "models": {}}
    for name, model in (models or default_models()).items():
        res = model.fit_arrays([x[:test_start]], [f[:test_start]])
        pred = model.simulate_arrays(res.params, x)
        y, yh = f[test_start:test_stop], pred[test_start:test_stop]
        out["models"][name] = {"rmse_n": metrics.rmse(y, yh), "max_abs_err_n": metrics.max_abs_err(y, yh),
                               "train_rmse_n": res.rmse, "r2": metrics.r2(y, yh), "fit_pct": metrics.fit_pct(y, yh)}
    return out


def external_check_all(files: Sequence[str | Path] | None = None, **kw) -> list[dict]:
    """:func:`external_check` on each file (default: all seven pressure levels)."""
    return [external_check(p, **kw) for p in (files or friction_files())]
