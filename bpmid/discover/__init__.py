"""Discrepancy discovery: find where the VBMM and the measurement disagree, name the missing catalogue effect,
add it, and show the held-out gap shrink (how it decides: docs/discover.md and the README's Discovery section).

Modules: :mod:`.diagnose` (residual diagnostics, noise floor), :mod:`.screen` (rank every catalogue effect by
its signature), :mod:`.confirm` (refit, held-out score, penalised criteria, identifiability),
:mod:`.workflow` (the loop, config, verdict), :mod:`.calibrate` (thresholds from simulated data).
"""
from bpmid.discover.workflow import DiscoverConfig, DiscoveryResult, discover

__all__ = ["DiscoverConfig", "DiscoveryResult", "discover"]

# ``bpmid.discover(...)`` is the public workflow (bpmid.api.discover)
from bpmid._callable import make_callable as _make_callable  # noqa: E402

_make_callable(__name__, "bpmid.api:discover")
