"""Relaxation-test fits: Prony series by variable projection, in ramp or step mode.

Public API
----------
- :class:`RelaxConfig` (config section ``relax``) and :class:`SpecimenConfig`
- :func:`fit_relaxation` logs -> :class:`RelaxFit` (constants with standard errors, metrics, term selection)
- :func:`hold_curve` the step-mode reduction of a ramp-and-hold log to a modulus curve
- :func:`relax_fit_body` / :func:`write_relax_fit` the ``bpmid.relax/1`` YAML; :func:`load_relax_fit` reads it back
- :func:`run_fit_relax` what ``bpmid fit relax`` does (read, fit, write YAML and figure)
- :func:`fit_frequency` storage and loss modulus -> :class:`FreqFit` (one Prony series fitted to both)
- :func:`fit_material` frequency sweeps or raw sets at several temperatures -> :class:`MaterialFit` (shift factors,
  WLF and polynomial shift functions, master-curve fit; :mod:`bpmid.relax.tts`)
"""
from __future__ import annotations

import dataclasses
from typing import Literal, Mapping, Optional, Union

from bpmid.errors import InputError

#: Poisson's ratio that reproduces the paper's printed K_inf = 6.753 and K_1 = 13.639 MPa from E_inf = 0.0272 and
#: E_1 = 0.0549 MPa (0.499329 and 0.499329; the rounded 0.4993 gives K values 4 % lower)
PAPER_POISSON = 0.49933


@dataclasses.dataclass(frozen=True)
class SpecimenConfig:
    """Specimen geometry for load/extension logs (``relax.specimen``).

    Attributes
    ----------
    gauge_length_mm : gauge length (mm), strain = extension / gauge length
    cross_section_mm2 : initial cross-section (mm^2), nominal stress = load / cross-section
    """

    gauge_length_mm: Optional[float] = None
    cross_section_mm2: Optional[float] = None


@dataclasses.dataclass(frozen=True)
class RelaxConfig:
    """Config section ``relax``: how relaxation logs are read and fitted.

    Attributes
    ----------
    specimen : geometry for load/extension logs
    columns : file header -> bpmid column name (``{"Kraft (N)": "load_n"}``)
    terms : number of Prony terms, or ``auto`` (chosen by ``criterion``)
    max_terms : the largest number of terms ``auto`` considers
    mode : ``ramp`` (hereditary integral of each log's strain history), ``step`` (modulus curve of the hold),
        or null: ramp when every log has a strain history, step otherwise
    poisson : Poisson's ratio for G and K (must be below 0.5)
    criterion : information criterion of ``auto``: ``bic`` or ``aicc``
    patience : ``auto`` stops walking in one direction after this many candidates that do not improve it
    grid_per_decade : density of the log-spaced time-constant grid of the NNLS start
    tau_span_factor : time constants may lie this factor beyond the data's time range (each side)
    hold_window_s : step mode uses this much of each hold (s; the paper used the first 10 s); null = all
    freq_weighting : frequency-domain residuals: ``complex`` (storage and loss residual over |E*|, the relative
        error of the complex modulus) or ``component`` (each modulus relative to itself); see :mod:`bpmid.relax.freq`
    max_error_pct : if set, the fewest terms whose RMS relative error (%) meets it (on E' and E'' in the frequency
        domain, on the modulus or stress in the time domain) instead of the criterion
    max_gap_factor : a time step of a stress/strain or load/extension log longer than this many median steps is
        refused as a gap in the log (lost samples bias the hereditary integral); null (default) uses
        ``io.max_gap_factor`` (5). Modulus curves are not gap-checked (master curves are log-spaced in time).
    """

    specimen: SpecimenConfig = SpecimenConfig()
    columns: Mapping[str, str] = dataclasses.field(default_factory=dict)
    terms: Union[int, Literal["auto"]] = "auto"
    max_terms: int = 32
    mode: Optional[Literal["ramp", "step"]] = None
    poisson: float = PAPER_POISSON
    criterion: Literal["bic", "aicc"] = "bic"
    patience: int = 3
    grid_per_decade: int = 6
    tau_span_factor: float = 10.0
    hold_window_s: Optional[float] = 10.0
    max_gap_factor: Optional[float] = None
    freq_weighting: Literal["complex", "component"] = "complex"
    max_error_pct: Optional[float] = None

    def validate(self, where: str = "relax", path=None) -> None:
        from bpmid.viscoelastic import check_poisson

        check_poisson(self.poisson, key=f"{where}.poisson", path=path)
        sp = self.specimen
        for name in ("gauge_length_mm", "cross_section_mm2"):
            v = getattr(sp, name)
            if v is not None and not v > 0:
                raise InputError(f"must be positive, found {v:g}", path=path, key=f"{where}.specimen.{name}")
        if isinstance(self.terms, int) and not 1 <= self.terms <= 200:
            raise InputError(f"terms must be between 1 and 200 (or auto), found {self.terms}", path=path,
                             key=f"{where}.terms")
        if not 1 <= self.max_terms <= 200:
            raise InputError(f"must be between 1 and 200, found {self.max_terms}", path=path, key=f"{where}.max_terms")
        if not 1 <= self.grid_per_decade <= 50:
            raise InputError(f"must be between 1 and 50, found {self.grid_per_decade}", path=path,
                             key=f"{where}.grid_per_decade")
        if not 1 <= self.patience <= 100:
            raise InputError(f"must be between 1 and 100, found {self.patience}", path=path, key=f"{where}.patience")
        if not self.tau_span_factor >= 1:
            raise InputError(f"must be at least 1, found {self.tau_span_factor:g}", path=path,
                             key=f"{where}.tau_span_factor")
        if self.max_gap_factor is not None and not self.max_gap_factor > 1.0:
            raise InputError(f"must be above 1 (a multiple of the usual time step) or null, found "
                             f"{self.max_gap_factor:g}", path=path, key=f"{where}.max_gap_factor")
        if self.freq_weighting not in ("complex", "component"):
            raise InputError(f"must be complex or component, found {self.freq_weighting!r}", path=path,
                             key=f"{where}.freq_weighting")
        if self.max_error_pct is not None and not self.max_error_pct > 0:
            raise InputError(f"must be a positive percentage or null, found {self.max_error_pct:g}", path=path,
                             key=f"{where}.max_error_pct")
        if self.hold_window_s is not None and not self.hold_window_s > 0:
            raise InputError(f"must be positive or null, found {self.hold_window_s:g}", path=path,
                             key=f"{where}.hold_window_s")


from bpmid.relax.fit import HoldCurve, RelaxFit, fit_relaxation, hold_curve  # noqa: E402
from bpmid.relax.result import (RelaxParameters, load_relax_fit, relax_fit_body, run_fit_relax,  # noqa: E402
                                write_relax_fit)

from bpmid.relax.freq import FreqFit, fit_frequency  # noqa: E402
from bpmid.relax.material import MaterialFit, fit_material  # noqa: E402

__all__ = ["RelaxConfig", "SpecimenConfig", "PAPER_POISSON", "fit_relaxation", "hold_curve", "HoldCurve", "RelaxFit",
           "relax_fit_body", "write_relax_fit", "load_relax_fit", "RelaxParameters", "run_fit_relax", "fit_frequency",
           "FreqFit", "fit_material", "MaterialFit"]
