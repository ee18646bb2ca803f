"""Stated resource limits, checked before any work starts (each one overridable).

A config or protocol that asks for an absurd amount of work (``compare.timing_repeats: 1e29``, a protocol
logging at ``sampling_hz: 1e8`` or running ``cycles: 100000000``) is refused at once with the estimated memory
and time, instead of running for days or dying with a MemoryError. Every limit is far above what a study
needs; one that is in the way is raised with an environment variable, e.g.
``BPMID_LIMIT_COMPARE_TIMING_REPEATS=5000`` or ``BPMID_MAX_SAMPLES=50000000``.

:data:`CONFIG_LIMITS` covers config keys (checked by :func:`bpmid.config.build_dataclass` for every section);
:func:`check_samples` covers the sample count of generated logs (protocols, control references).
"""
from __future__ import annotations

import dataclasses
import math
import os

from bpmid.errors import InputError


@dataclasses.dataclass(frozen=True)
class Limit:
    """The largest allowed value of one config key, and what one unit of it costs (for the message)."""

    maximum: float
    what: str
    seconds_per_unit: float = 0.0
    bytes_per_unit: float = 0.0

    def env_name(self, key: str) -> str:
        return "BPMID_LIMIT_" + "".join(c if c.isalnum() else "_" for c in key).upper()


#: config key (section.field) -> limit. Costs are rough figures for the shipped data on one core.
CONFIG_LIMITS: dict[str, Limit] = {
    "compare.timing_repeats": Limit(1000, "timed free-running simulations per model and test log", 0.05),
    "compare.figure_logs": Limit(200, "test logs drawn in the per-log figures", 0.5),
    "run.history_repeats": Limit(1000, "timed runs per point of the history-mode study", 0.5),
    "motion.max_nfev": Limit(100_000, "forward evaluations of the motion fit per round", 0.02),
    "motion.tau_grid": Limit(1000, "time-constant scale factors of the linear start", 0.05),
    "discover.base_max_nfev": Limit(100_000, "forward evaluations of the base fit", 0.02),
    "discover.confirm_max_nfev": Limit(100_000, "forward evaluations per augmented refit", 0.02),
    "discover.max_effects": Limit(50, "effects added one at a time", 30.0),
    "discover.n_confirm": Limit(200, "candidates refitted per round", 10.0),
    "control.rate_hz": Limit(100_000, "control steps per second of reference", 1e-5, 200.0),
    "control.ms_elements": Limit(1000, "Maxwell-slip elements of the feedforward", 0.01),
    "control.ms_poly_degree": Limit(50, "polynomial degree of the Maxwell-slip feedforward", 0.01),
}

#: most log files one protocol may generate (``BPMID_MAX_FILES`` overrides)
MAX_FILES = 10_000
#: most samples in one generated log, and in all logs of one command together
MAX_SAMPLES_PER_LOG = 5_000_000
MAX_SAMPLES_TOTAL = 10_000_000
#: cost of one generated sample (time, pressure, angle, noise, the CSV text; the VBMM forward solve), measured
#: with ``bpmid simulate`` on a 4.5-million-sample triangle log: ~130 bytes and ~2.7 us per sample (loaded machine)
BYTES_PER_SAMPLE = 150.0
SECONDS_PER_SAMPLE = 3e-6


def _env_number(name: str) -> float | None:
    raw = os.environ.get(name)
    if raw is None or not raw.strip():
        return None
    try:
        v = float(raw)
    except ValueError:
        raise InputError(f"expected a number, found {raw!r}", key=name) from None
    if not v > 0:
        raise InputError(f"expected a positive number, found {raw!r}", key=name)
    return v


def human_bytes(n: float) -> str:
    for unit in ("bytes", "kB", "MB", "GB", "TB", "PB"):
        if abs(n) < 1000 or unit == "PB":
            return f"{n:.3g} {unit}"
        n /= 1000.0
    return f"{n:.3g} PB"  # pragma: no cover


def human_seconds(s: float) -> str:
    if not math.isfinite(s):
        return "forever"
    for div, unit in ((3.156e7, "years"), (86400.0, "days"), (3600.0, "h"), (60.0, "min")):
        if s >= div:
            return f"{s / div:.3g} {unit}"
    return f"{s:.3g} s"


def maximum(key: str) -> float | None:
    """The limit of config key ``key`` (``section.field``), with its environment override; None: no limit."""
    lim = CONFIG_LIMITS.get(key)
    if lim is None:
        return None
    env = _env_number(lim.env_name(key))
    return env if env is not None else lim.maximum


def check_config_value(key: str, value, *, path=None, shown_key: str | None = None) -> None:
    """InputError when the number ``value`` of config key ``key`` is above its stated limit."""
    lim = CONFIG_LIMITS.get(key)
    if lim is None or isinstance(value, bool) or not isinstance(value, (int, float)):
        return
    top = maximum(key)
    if value > top:
        cost = []
        if lim.seconds_per_unit:
            cost.append(f"~{human_seconds(value * lim.seconds_per_unit)}")
        if lim.bytes_per_unit:
            cost.append(f"~{human_bytes(value * lim.bytes_per_unit)} of memory")
        est = f" (estimated {' and '.join(cost)} of work)" if cost else ""
        raise InputError(f"{value:g} {lim.what} is above the limit of {top:g}{est}; lower it, or raise the limit "
                         f"with the environment variable {lim.env_name(key)}=N", path=path, key=shown_key or key)


def check_samples(counts: dict[str, float], *, path=None, key: str | None = None, what: str = "log",
                  hint: str = "lower sampling_hz, the durations or the cycles", total_only: bool = False) -> None:
    """InputError when one log of ``counts`` (name -> samples) or all together exceed the sample limits.

    The message gives the estimated memory and time and the variables that raise the limits
    (``BPMID_MAX_SAMPLES`` per log, ``BPMID_MAX_SAMPLES_TOTAL`` for all)."""
    per_log = _env_number("BPMID_MAX_SAMPLES") or MAX_SAMPLES_PER_LOG
    total_max = _env_number("BPMID_MAX_SAMPLES_TOTAL") or max(MAX_SAMPLES_TOTAL, per_log)

    def cost(n):
        return (f"estimated {human_bytes(n * BYTES_PER_SAMPLE)} of memory and ~{human_seconds(n * SECONDS_PER_SAMPLE)}"
                f" of work")

    for name, n in ({} if total_only else counts).items():
        if not math.isfinite(n) or n > per_log:
            raise InputError(f"{what} {name!r} would have {n:.3g} samples, more than the limit of {per_log:,.0f} per "
                             f"{what} ({cost(n)}); {hint}, or raise the limit with BPMID_MAX_SAMPLES=N",
                             path=path, key=key)
    total = float(sum(counts.values()))
    if not math.isfinite(total) or total > total_max:
        raise InputError(f"the {what}s would have {total:.3g} samples together, more than the limit of "
                         f"{total_max:,.0f} ({cost(total)}); {hint}, or raise the limit with "
                         "BPMID_MAX_SAMPLES_TOTAL=N", path=path, key=key)


def check_file_count(n: float, *, path=None, key: str | None = None, what: str = "log files") -> None:
    """InputError when a protocol would write more than :data:`MAX_FILES` files (``BPMID_MAX_FILES``)."""
    top = _env_number("BPMID_MAX_FILES") or MAX_FILES
    if not math.isfinite(n) or n > top:
        raise InputError(f"{n:.3g} {what} would be written, more than the limit of {top:,.0f}; lower the replicates "
                         "or the number of logs, or raise the limit with BPMID_MAX_FILES=N", path=path, key=key)

