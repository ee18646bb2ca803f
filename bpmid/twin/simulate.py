"""``bpmid simulate``: run a protocol on the digital twin of the test rig.

Motion protocols: the plant is the VBMM (paper constants unless ``--params``) with the rig's own effects
(``plant.effects``) and any injected catalogue effect (``effects`` in the protocol, ``--effect`` on the command
line), each replicate with its own draw of the constants (``plant.variation``); the sensors
(:mod:`bpmid.twin.sensors`) add noise, drift and quantisation. Reference protocols write angle signals
(``time_s, angle_deg``); relaxation protocols call :func:`bpmid.twin.relaxation.simulate_relaxation_test`.

Random draws: for motion logs, log number i (in file order) draws its constants from
``SeedSequence(seed, spawn_key=(i, 0))`` and its sensor errors from ``SeedSequence(seed, spawn_key=(i, 1))``
(numpy PCG64), so each file depends only on the seed and its own position. The seed and every drawn
constant are in the manifest. The injected effect is named in the manifest (or, for a ``blind`` protocol,
only in the separate answer), never in the CSV.

Everything is computed in memory first and written through :func:`bpmid.io.atomic.staged_dir`: a failure
leaves nothing half-written.
"""
from __future__ import annotations

import dataclasses
import hashlib
import math
import re
from pathlib import Path
from typing import Any, Mapping, Sequence

import numpy as np
import pandas as pd

from bpmid.effects import CATALOGUE, effect_class
from bpmid.effects.base import AugmentedVBMM, Effect, signal_path_order
from bpmid.errors import InputError
from bpmid.io.atomic import staged_dir, write_bytes
from bpmid.io.results import dump_yaml, provenance
from bpmid.models.vbmm import VBMM, Material, load_vbmm, vbmm_yaml_body
from bpmid.params import ParamSet
from bpmid.progress import Progress
from bpmid.twin import sensors as S
from bpmid.twin.protocol import Protocol, _extent, _first_level, load_protocol, render_at
from bpmid.units import ATMOSPHERE_PA, PA_PER_BAR

SCHEMA = "bpmid.simulation/1"
SYNTHETIC_NOTE = "bpmid digital twin; not a measurement"

def signal_path_key(effect_and_params) -> int:
    """Sort (effect, params) pairs in the order the effects act on the signal (``Effect.signal_order``)."""
    return signal_path_order(effect_and_params[0])


# ---------------------------------------------------------------------------------------------
# effects from text or YAML
# ---------------------------------------------------------------------------------------------
def _number(text: str, key: str):
    try:
        v = float(text)
    except ValueError:
        raise InputError(f"expected a number, found {text!r}", key=key) from None
    return int(v) if v.is_integer() and "." not in text and "e" not in text.lower() else v


def parse_effect_arg(text: str) -> tuple[str, dict]:
    """``ID[:key=value,...]`` -> (id, {key: number})."""
    eid, _, rest = text.partition(":")
    eid = eid.strip()
    values: dict[str, Any] = {}
    if rest.strip():
        for item in rest.split(","):
            k, eq, v = item.partition("=")
            k = k.strip()
            if not eq or not k:
                raise InputError(f"expected key=value, found {item!r}", key=f"--effect {text}")
            if k in values:   # the last would win silently
                raise InputError(f"{k} is given twice; give each key once", key=f"--effect.{eid}.{k}")
            values[k] = _number(v.strip(), f"--effect.{eid}.{k}")   # the key build_effect names too
    return eid, values


def build_effect(eid: str, values: Mapping[str, Any], where: str = "--effect", path=None) -> tuple[Effect, ParamSet]:
    """An effect and its parameters from ``{parameter or setting: value}`` (defaults for the rest)."""
    if eid not in CATALOGUE:
        raise InputError(f"unknown effect id (known: {', '.join(CATALOGUE)})", path=path, key=f"{where}.{eid}")
    cls = effect_class(eid)
    values = dict(values or {})
    if not isinstance(values, dict):
        raise InputError("expected a mapping of parameters and settings", path=path, key=f"{where}.{eid}")
    settings = {k: values.pop(k) for k in list(values) if k in getattr(cls, "SETTINGS", ())}
    try:
        effect = cls(**settings)
    except InputError as exc:
        raise InputError(exc.message, path=path, key=f"{where}.{exc.key or eid}") from None
    params = effect.default_params()
    for k, v in values.items():
        name = f"{eid}.{k}"
        if name not in params:
            known = [n.split(".", 1)[1] for n in params.names()] + list(getattr(cls, "SETTINGS", ()))
            raise InputError(f"unknown parameter of {eid} (known: {', '.join(known)})", path=path, key=f"{where}.{name}")
        p = params[name]
        if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v):
            raise InputError(f"expected a number, found {v!r}", path=path, key=f"{where}.{name}")
        if not (p.lower <= v <= p.upper):
            raise InputError(f"{v:g} (unit {p.unit}) is outside [{p.lower:g}, {p.upper:g}]", path=path, key=f"{where}.{name}")
        params = params.replace(name, value=float(v))
    return effect, params


def _effects_block(effects: Sequence[tuple[Effect, ParamSet]]) -> list[dict]:
    out = []
    for e, ps in effects:
        entry = {"id": e.id, "meaning": e.meaning,
                 "params": {p.name.split(".", 1)[1]: {"value": p.value, "unit": p.unit} for p in ps}}
        settings = {k: getattr(e, k) for k in getattr(e, "SETTINGS", ())}
        if settings:
            entry["settings"] = settings
        out.append(entry)
    return out


# ---------------------------------------------------------------------------------------------
# the simulation
# ---------------------------------------------------------------------------------------------
@dataclasses.dataclass
class Simulation:
    """What one protocol run produces, in memory: file name -> bytes, the manifest, the answer (blind)."""

    files: dict[str, bytes]
    manifest: dict
    answer: dict | None = None

    def write(self, out_dir: str | Path, *, answer_name: str | None = "ANSWER.yaml") -> Path:
        """The logs and manifest.yaml into ``out_dir``; a blind case's answer beside the folder, not in it
        (``<out_dir>_ANSWER.yaml``: whoever gets the folder to judge does not get the answer with it)."""
        out_dir = Path(out_dir)
        with staged_dir(out_dir) as tmp:
            for name, data in self.files.items():
                write_bytes(tmp / name, data)
            write_bytes(tmp / "manifest.yaml", dump_yaml(self.manifest).encode())
        if self.answer is not None and answer_name:
            from bpmid.io.atomic import write_text

            write_text(self.answer_path(out_dir, answer_name), dump_yaml(self.answer))
        return out_dir

    @staticmethod
    def answer_path(out_dir: str | Path, answer_name: str = "ANSWER.yaml") -> Path:
        out_dir = Path(out_dir).resolve()   # '--out .' has no name of its own: its real one, and its parent
        return out_dir.parent / f"{out_dir.name}_{answer_name}"


def _base_model(proto: Protocol, params_path) -> tuple[VBMM, dict]:
    if params_path is not None:
        from bpmid.effects.fitfile import refuse_effects_list

        refuse_effects_list(params_path, "bpmid simulate --params",
                            "inject them with --effect ID:key=value or the protocol's effects section")
        model = load_vbmm(params_path)
        from bpmid.config import stated_keys

        if "closure" in stated_keys(proto.plant) and proto.plant.closure != model.closure:
            # --params replaces the protocol's material preset (documented), never silently its closure
            raise InputError(f"the protocol's plant.closure ({proto.plant.closure}) differs from the fit "
                             f"{params_path}'s ({model.closure}); the closure is part of the fitted model: remove "
                             f"plant.closure from the protocol, or simulate with a fit made with that closure",
                             path=proto.path, key="plant.closure")
        return _as_continuous(model, params_path, proto)
    material = Material.paper_fit() if proto.plant.material == "paper_fit" else Material.paper_mat()
    return VBMM(material=material, closure=proto.plant.closure), {"material_preset": proto.plant.material}


def _as_continuous(model: VBMM, params_path, proto: Protocol) -> tuple[VBMM, dict]:
    """The fit's model as the twin's muscle. A motion fit's constants are those of the sum sampled at its logs' step;
    a muscle run in continuous time (``plant.integration: continuous``) that acts as the fitted model did has each
    branch modulus times :func:`~bpmid.models.vbmm.model.continuous_factor` (step, its tau), so logged at the fit's
    rate it is what the fit predicts. A fit that records no step (or ``log_rate``) is taken as it is."""
    from bpmid.effects.fitfile import fit_body
    from bpmid.models.vbmm.model import material_from_step
    from bpmid.models.vbmm.rig import fit_rig

    info = {"params_file": str(params_path)}
    steps = fit_rig(fit_body(Path(params_path))[0])[0] if proto.plant.integration == "continuous" else []
    if not steps or not model.material.time_constants:
        return model, info
    dt = float(np.median(steps))
    info["params_as_continuous_time"] = (
        f"the fit's constants hold for its logs' step, {dt:.4g} s; the muscle in continuous time that acts as they "
        f"did has each branch modulus times (dt/tau) / (1 - exp(-dt/tau)) (the constants below)")
    return model.replace(material=material_from_step(model.material, dt)), info


def _rng(seed: int, i: int, stream: int) -> np.random.Generator:
    return np.random.Generator(np.random.PCG64(np.random.SeedSequence(seed, spawn_key=(i, stream))))


def _csv(head: Sequence[str], frame: pd.DataFrame) -> bytes:
    return ("\n".join(head) + "\n" + frame.to_csv(index=False, lineterminator="\n")).encode()


def simulate(protocol: Protocol | str | Path, *, params_path: str | Path | None = None,
             effects: Sequence[str] = (), seed: int | None = None, command: str | None = None,
             timestamp: bool = True) -> Simulation:
    """Run a protocol on the twin (nothing is written; see :meth:`Simulation.write`).

    Parameters
    ----------
    protocol : a loaded :class:`Protocol` or the path of a protocol file
    params_path : a ``bpmid.vbmm/1`` file with the plant's VBMM constants (default: the protocol's preset)
    effects : ``ID[:key=value,...]`` texts of catalogue effects to inject (on top of the protocol's ``effects``)
    seed : overrides the protocol's seed
    command : the command line recorded in the manifest (default: sys.argv)
    timestamp : record the creation time (False for byte-reproducible datasets)
    """
    if not isinstance(protocol, Protocol):
        preset = load_protocol(protocol)   # its plant preset first: the pressure limit is that material's
        material = getattr(getattr(preset, "plant", None), "material", "paper_fit")
        protocol = load_protocol(protocol, max_gauge_pa=_max_gauge_pa(params_path, material))
    proto = protocol
    seed = proto.seed if seed is None else int(seed)
    if seed < 0:
        raise InputError(f"a seed is a non-negative whole number, found {seed}", key="--seed")
    if proto.blind and effects:   # the command would name the hidden effects: their values are left out
        from bpmid.io.results import command_line

        command = re.sub(r"(--effect[ =])(\S+)", lambda m: m.group(1) + "<hidden>", command or command_line())
    prov = provenance(() if params_path is None else (params_path,), seed=seed, command=command, timestamp=timestamp,
                      extra={"protocol": {"path": proto.path, "sha256": proto.sha256}})
    if proto.kind != "motion" and (params_path is not None or effects):
        raise InputError(f"--params and --effect apply to motion protocols, this one is kind {proto.kind}",
                         path=proto.path, key="kind")
    if proto.kind == "reference":
        return _simulate_reference(proto, prov)
    if proto.kind == "relaxation":
        from bpmid.twin.relaxation_protocol import simulate_relaxation_protocol

        files, body = simulate_relaxation_protocol(proto, seed)
        return Simulation(files, {"schema": SCHEMA, "synthetic": True, "note": SYNTHETIC_NOTE,
                                  **_protocol_block(proto), "seed": seed, **body, "provenance": prov})
    return _simulate_motion(proto, params_path, effects, seed, prov)


def _max_gauge_pa(params_path, material: str = "paper_fit") -> float:
    """The largest gauge pressure the plant takes: the one that holds it near 4 pi rad relaxed (its material: the
    fit file's, else the protocol's preset; the softer preset reached its limit below the other's)."""
    if params_path is not None:
        model = load_vbmm(params_path)
    else:
        model = VBMM(material=Material.paper_fit() if material == "paper_fit" else Material.paper_mat())
    return float(model.equilibrium_pressure(4.0 * math.pi * 0.99)[0])


def _protocol_block(proto: Protocol) -> dict:
    return {"protocol": {"name": proto.name, "kind": proto.kind, "description": proto.description,
                         "path": proto.path, "sha256": proto.sha256}}


def _simulate_reference(proto: Protocol, prov: dict) -> Simulation:
    files, logs = {}, []
    for name, spec, _k in proto.runs():
        t, x = proto.render(spec)
        frame = pd.DataFrame({"time_s": np.round(t, 6), "angle_deg": np.round(x, 6)})
        head = [f"# source: reference signal for control (bpmid simulate, protocol {proto.name}); not a measurement"]
        files[f"{name}.csv"] = _csv(head, frame)
        logs.append({"file": f"{name}.csv", "samples": int(t.size), "duration_s": float(t[-1]),
                     "angle_range_deg": [float(x.min()), float(x.max())],
                     "sha256": hashlib.sha256(files[f"{name}.csv"]).hexdigest()})
    manifest = {"schema": SCHEMA, "synthetic": True, "note": "designed reference signals (angle, deg)",
                **_protocol_block(proto), "sampling_hz": proto.sampling_hz, "logs": logs, "provenance": prov}
    return Simulation(files, manifest)


def _collect_effects(proto: Protocol, effect_args: Sequence[str]):
    rig = [build_effect(eid, v, "plant.effects", proto.path) for eid, v in proto.plant.effects.items()]
    injected = [build_effect(eid, v, "effects", proto.path) for eid, v in proto.effects.items()]
    given = ["plant.effects"] * len(rig) + ["effects"] * len(injected)
    for text in effect_args:
        eid, values = parse_effect_arg(text)
        injected.append(build_effect(eid, values, "--effect"))
        given.append("--effect")
    ids = [e.id for e, _p in rig + injected]
    dup = sorted({i for i in ids if ids.count(i) > 1})
    if dup:
        where = [w for i, w in zip(ids, given) if i == dup[0]]
        key = f"{where[0]}.{dup[0]}"
        if where[0] == "--effect":   # every one on the command line: nothing in the protocol to edit
            raise InputError(f"effect {dup[0]} is given twice (--effect and --effect): give it once, with all its "
                             f"keys in one argument (--effect {dup[0]}:key=value,key=value)", key=key)
        raise InputError(f"effect {dup[0]} is given twice ({' and '.join(where)}; the rig's plant.effects, the "
                         f"protocol's effects and --effect must not repeat an id). To change it, edit {key} "
                         f"instead of adding it again (a copy of the protocol for its own keys)", path=proto.path,
                         key=key)
    return rig, injected


#: a simulated motion log shorter than this is refused (a 1-sample log was written and then refused by fit motion)
MIN_LOG_SAMPLES = 2


def _plant_grid(proto: Protocol, spec, t: np.ndarray, p_cmd: np.ndarray):
    """The times and commanded levels the muscle runs on, and every how many of them a log sample falls: the log's own
    (``plant.integration: log_rate``), or ``plant.substeps`` internal steps per log step (``continuous``: the program
    sampled on a finer grid that holds every log time; the log keeps the muscle at those times)."""
    every = proto.plant.substeps(proto.sampling_hz)
    if every == 1:
        return t, p_cmd, 1
    start = spec.start if spec.start is not None else _first_level(spec.program)
    t_run = np.arange((t.size - 1) * every + 1) / (proto.sampling_hz * every)   # index k * every: log sample k
    return t_run, render_at(spec.program, start, t_run), every


def _integration_block(proto: Protocol) -> dict:
    """How the muscle was integrated, for the manifest (``internal_step_s``: the step it ran on)."""
    every = proto.plant.substeps(proto.sampling_hz)
    return {"integration": proto.plant.integration, "internal_step_s": float(f"{1.0 / (proto.sampling_hz * every):.6g}"),
            "substeps_per_sample": every}


def _simulate_motion(proto: Protocol, params_path, effect_args, seed: int, prov: dict) -> Simulation:
    base, base_info = _base_model(proto, params_path)
    rig, injected = _collect_effects(proto, effect_args)
    chain = sorted(rig + injected, key=signal_path_key)
    effects = tuple(e for e, _p in chain)
    params = ParamSet([p for _e, ps in chain for p in ps])
    var, sens = proto.plant.variation, proto.sensors
    col = f"pressure_{proto.unit}"
    files, logs = {}, []
    runs = list(proto.runs())
    for spec in proto.logs:   # before any work: a log bpmid's own readers would refuse is not written
        n = math.floor(_extent(spec.program, spec.start if spec.start is not None else _first_level(spec.program))[0]
                       * proto.sampling_hz + 1e-9) + 1   # as render counts them
        if n < MIN_LOG_SAMPLES:
            raise InputError(f"log {spec.name!r} would have {n} sample(s) at {proto.sampling_hz:g} Hz, fewer than the "
                             f"{MIN_LOG_SAMPLES} bpmid's fits need: raise sampling_hz or the log's duration",
                             path=proto.path, key="sampling_hz")
    with Progress(len(runs), f"simulate {proto.name}") as bar:
        for i, (name, spec, rep) in enumerate(runs):
            t, p_cmd = proto.render(spec)
            t_run, p_run, every = _plant_grid(proto, spec, t, p_cmd)
            rv = _rng(seed, i, 0)
            fm = float(np.exp(var.modulus_cv * rv.standard_normal()))
            ft = float(np.exp(var.tau_cv * rv.standard_normal()))
            m = base.material.scaled(fm)
            m = dataclasses.replace(m, tauG=tuple(x * ft for x in m.tauG),
                                    tauK=None if m.tauK is None else tuple(x * ft for x in m.tauK))
            plant = AugmentedVBMM(base.replace(material=m), effects, params)
            angle = plant.simulate_deg(t_run, proto.to_gauge_pa(p_run), name=name, path=proto.path)[::every][:t.size]
            rs = _rng(seed, i, 1)
            unit_bar = proto.unit_pa / PA_PER_BAR
            p_log = S.read_pressure(p_cmd * unit_bar, sens, rs) / unit_bar
            a_log = S.read_angle(t, angle, sens, rs)
            frame = pd.DataFrame({"time_s": np.round(t, 6), col: np.round(p_log, 6), "angle_deg": np.round(a_log, 6)})
            head = [f"# pressure_reference: {proto.pressure_reference}",
                    # an ambient pressure other than the standard one the absolute values were made with, so the
                    # file reads back the same (a reader assumes the standard atmosphere without this line)
                    *([f"# atmosphere_pa: {proto.atmosphere_bar * PA_PER_BAR:.10g}"]
                      if proto.pressure_reference == "absolute"
                      and abs(proto.atmosphere_bar * PA_PER_BAR - ATMOSPHERE_PA) > 1e-6 else []),
                    f"# synthetic: true ({SYNTHETIC_NOTE})",
                    f"# protocol: {proto.name} (log {spec.name}, replicate {rep + 1}), seed {seed}; see manifest.yaml",
                    *([f"# plant constants: {Path(params_path).name} (--params), not the protocol's material preset"]
                      if params_path is not None else [])]
            files[f"{name}.csv"] = _csv(head, frame)
            logs.append({"file": f"{name}.csv", "log": spec.name, "replicate": rep + 1, "samples": int(t.size),
                         "duration_s": float(t[-1]), "modulus_factor": round(fm, 6), "tau_factor": round(ft, 6),
                         "sha256": hashlib.sha256(files[f"{name}.csv"]).hexdigest()})
            bar.advance()
    plant_block = {"family": "VBMM", **base_info, **vbmm_yaml_body(base), **_integration_block(proto),
                   "rig_effects": _effects_block(sorted(rig, key=signal_path_key)),
                   "effect_order": [e.id for e in effects if not proto.blind or any(e is r for r, _p in rig)],
                   "variation": dataclasses.asdict(var)}
    injected_block = _effects_block(injected)
    manifest = {"schema": SCHEMA, "synthetic": True, "note": SYNTHETIC_NOTE, **_protocol_block(proto),
                "seed": seed, "random_streams": "numpy PCG64; log i: SeedSequence(seed, spawn_key=(i, 0)) draws "
                "modulus_factor then tau_factor, (i, 1) the sensor errors (pressure noise, angle drift, angle noise)",
                "sampling_hz": proto.sampling_hz,
                "pressure": {"unit": proto.unit, "reference": proto.pressure_reference,
                             "atmosphere_bar": proto.atmosphere_bar},
                "plant": plant_block,
                "effects": "hidden (blind test: see the separate answer file)" if proto.blind else injected_block,
                "sensors": {**dataclasses.asdict(sens), "angle_noise_floor_deg": round(sens.noise_floor_deg(), 6)},
                "logs": logs, "provenance": prov}
    answer = None
    if proto.blind:
        answer = {"protocol": proto.name, "effects": injected_block}
    return Simulation(files, manifest, answer)
