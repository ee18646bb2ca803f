"""Out-of-family validation of ``bpmid discover``: cases made by physics bpmid's catalogue does not contain.

The generator is written independently of the catalogue's model terms (it imports nothing from
``bpmid.effects``, ``bpmid.twin`` or ``bpmid.models``): the base muscle is re-implemented from the VBMM spec
(kinematics, Prony branches as internal state variables, the paper closure) and integrated in continuous time
on sub-steps, and every effect is a physical form of its own (:mod:`bpmid.validation.forms`):

====================== ===============================================================================
catalogue id           forms
====================== ===============================================================================
braid_friction         Dahl; Bouc-Wen; four or two Jenkins (spring + slider) elements
pressure_lag           two cascaded first-order lags; transport delay + first-order lag
second_relaxation      one or two slow Prony branches
strain_stiffening      exponential fibre recruitment; cubic polynomial
thermal_softening      exponential or linear in elapsed time
asymmetric_relaxation  slower or faster relaxation while deflating
angle_offset           constant; remounted (shifts slightly per log)
(out of catalogue)     payload inertia that rings (2nd order); Mullins softening; air leak (orifice)
====================== ===============================================================================

API
---
- ``make_cases(config, seed) -> list[Case]``: design cases (deterministic from ``seed``); ``config`` is a
  :class:`GeneratorConfig` or a mapping with its keys (unknown keys: InputError naming the key).
- ``Case.id``, ``Case.split`` (``calibration`` or ``heldout``, from a hash of the id alone),
  ``Case.truth`` (designed truth), ``Case.truth_label`` (confusion-matrix row: a catalogue id, ``none``,
  ``pair`` or ``out_of_catalogue``).
- ``realize(case) -> CaseData``: simulate (effects sized so that the true base model's held-out RMSE is the
  case's target multiple of the noise), ``CaseData.logs``, ``CaseData.truth`` (with the sized physics).
- ``write_case(case_or_data, dir) -> answer entry``: writes ``dir/<id>/fit/*.csv``, ``dir/<id>/holdout/*.csv``
  (the motion-log format bpmid reads, with ``# pressure_reference:`` and ``# synthetic:`` lines), ``case.yaml``
  (a bpmid config with the geometry) and ``init.yaml`` (starting constants, bpmid.vbmm/1). The truth is never
  written beside the logs: collect the returned entries and ``write_answers(entries, path)`` per split.
- ``case_paths(dir/<id>)``: the files to hand to ``bpmid discover``.

Every file is labelled synthetic with the generator name, the case id and its seed.
"""
from bpmid.validation.forms import CATALOGUE_IDS, FORMS, OUT_OF_CATALOGUE_IDS
from bpmid.validation.generator import (GENERATOR, GEOMETRIES, Case, CaseData, GeneratorConfig, GeometrySpec,
                                        answer_entry, case_paths, generator_config, make_cases, realize, simulate_spec,
                                        split_of,
                                        write_answers, write_case)

__all__ = ["CATALOGUE_IDS", "FORMS", "OUT_OF_CATALOGUE_IDS", "GENERATOR", "GEOMETRIES", "Case", "CaseData",
           "GeneratorConfig", "GeometrySpec", "answer_entry", "case_paths", "generator_config", "make_cases",
           "realize", "simulate_spec", "split_of", "write_answers", "write_case"]
