"""The ``effects`` list of a ``bpmid.vbmm/1`` file: the catalogue effects a fitted VBMM carries, in the order they
act, with their constants. Every command that runs a fit file as the model runs them (``bpmid predict``,
``bpmid export --to c``) or refuses the file (``bpmid control``, ``bpmid simulate --params``, which take only its
constants), so a fit is never run without its effects. A file given as starting values (``--init`` of
``fit motion`` and ``discover``) gives only its constants, as a start should: those commands fit the effects.
"""
from __future__ import annotations

from pathlib import Path

from bpmid.errors import InputError


def effects_from_yaml(block, path=None):
    """The optional ``effects`` list of a ``bpmid.vbmm/1`` file: the effects and one ParamSet of their constants.

    Each entry is ``{id: <catalogue id>, parameters: {<name>: {value, stderr, unit}}, settings: {...}}``
    (parameter names with or without the ``<id>.`` prefix; ``settings`` optional), in the order the
    effects act. Returns (effects tuple, ParamSet).
    """
    from bpmid.effects import CATALOGUE, get_effect
    from bpmid.params import ParamSet, parse_param_entry

    if block is None:
        return (), ParamSet([])
    if not isinstance(block, list):
        raise InputError("effects must be a list of {id, parameters, settings}", path=path, key="effects")
    effects, params, seen = [], [], set()
    for i, entry in enumerate(block):
        key = f"effects[{i}]"
        if not isinstance(entry, dict):
            raise InputError("expected a mapping {id, parameters, settings}", path=path, key=key)
        for k in entry:
            if k not in ("id", "parameters", "settings"):
                raise InputError("unknown key (known: id, parameters, settings)", path=path, key=f"{key}.{k}")
        eid = entry.get("id")
        if not isinstance(eid, str) or eid not in CATALOGUE:
            raise InputError(f"unknown effect {eid!r} (known: {', '.join(CATALOGUE)})", path=path, key=f"{key}.id")
        if eid in seen:
            raise InputError(f"effect {eid} is listed twice", path=path, key=f"{key}.id")
        seen.add(eid)
        settings = entry.get("settings") or {}
        if not isinstance(settings, dict):
            raise InputError("settings must be a mapping", path=path, key=f"{key}.settings")
        try:
            effect = get_effect(eid, **settings)
        except InputError as exc:
            raise InputError(exc.message, path=path, key=f"{key}.settings") from None
        except TypeError:
            known = ", ".join(getattr(type(get_effect(eid)), "SETTINGS", ())) or "none"
            raise InputError(f"unknown setting for {eid} (known: {known})", path=path, key=f"{key}.settings") from None
        defaults = effect.default_params()
        given = entry.get("parameters")
        if not isinstance(given, dict):
            raise InputError("parameters must be a mapping name -> {value, stderr, unit}", path=path,
                             key=f"{key}.parameters")
        values = {}
        for name, val in given.items():
            full = name if str(name).startswith(eid + ".") else f"{eid}.{name}"
            pkey = f"{key}.parameters.{name}"
            if full not in defaults:
                known = ", ".join(n.split(".", 1)[1] for n in defaults.names())
                raise InputError(f"unknown parameter of {eid} (known: {known})", path=path, key=pkey)
            v, _se, unit = parse_param_entry(val, path=path, key=pkey)
            if unit is not None and unit != defaults[full].unit:
                raise InputError(f"unit {unit!r} where {defaults[full].unit!r} is expected", path=path, key=pkey)
            values[full] = v
        # parameters added to an effect later (``OPTIONAL_PARAMS``: their default keeps the older form) may be
        # absent from files written before they existed
        optional = {f"{eid}.{n}" for n in getattr(effect, "OPTIONAL_PARAMS", ())}
        for name in defaults.names():
            if name not in values and name not in optional:
                raise InputError("missing key", path=path, key=f"{key}.parameters.{name.split('.', 1)[1]}")
        effects.append(effect)
        params.extend(defaults.with_values(values))
    return tuple(effects), ParamSet(params)


def effects_to_yaml(effects, params) -> list[dict]:
    """The ``effects`` list of a ``bpmid.vbmm/1`` file for ``effects`` (in the order they act) and a ParamSet
    holding their ``<id>.<name>`` constants: the writer :func:`effects_from_yaml` reads back. Each entry carries
    the effect's settings (``SETTINGS``) and its constants as ``{value, stderr, unit}`` with any verdict."""
    out = []
    for e in effects:
        entry = {"id": e.id}
        settings = {s: getattr(e, s) for s in getattr(type(e), "SETTINGS", ())}
        if settings:
            entry["settings"] = settings
        entry["parameters"] = {n.split(".", 1)[1]: params[n].to_yaml() for n in e.default_params().names()
                               if n in params}
        out.append(entry)
    return out


def settings_words(effect_id: str, settings) -> str:
    """An effects-list entry's settings in words with their units ("dead_time = 0 s"); "" for none. An id or
    setting the catalogue does not know is shown as written, without a unit."""
    from bpmid.effects import CATALOGUE, effect_class

    if not isinstance(settings, dict):
        return ""
    units = getattr(effect_class(effect_id), "SETTING_UNITS", {}) if effect_id in CATALOGUE else {}

    def word(k, v):
        num = isinstance(v, (int, float)) and not isinstance(v, bool)
        return (f"{k} = {v:g}" if num else f"{k} = {v}") + (f" {units[k]}" if k in units else "")

    return ", ".join(word(k, v) for k, v in settings.items())


def fit_body(fit) -> tuple[dict, str | Path | None]:
    """The mapping of a fit and its file: read from a ``bpmid.vbmm/1`` path, or a loaded result's (``to_dict``,
    ``source``) or a mapping."""
    if isinstance(fit, (str, Path)):
        from bpmid.io.results import read_result

        return read_result(Path(fit), "bpmid.vbmm/"), fit
    body = fit.to_dict() if hasattr(fit, "to_dict") else fit
    return (body if isinstance(body, dict) else {}), getattr(fit, "source", None)


def augmented_from_file(base, fit):
    """``base`` (the fit's VBMM, as loaded with the caller's model settings) with the effects of the fit (a
    ``bpmid.vbmm/1`` path, a loaded :class:`~bpmid.results.VBMMFitResult` or its mapping): an
    :class:`~bpmid.effects.base.AugmentedVBMM`, or ``base`` itself when the fit lists none."""
    from bpmid.effects.base import AugmentedVBMM

    data, where = fit_body(fit)
    effects, params = effects_from_yaml(data.get("effects"), where)
    return AugmentedVBMM(base, effects, params) if effects else base


def refuse_effects_list(fit, command: str, instead: str) -> None:
    """``command`` takes only a fit's VBMM constants: a fit (a ``bpmid.vbmm/1`` path, a loaded result or its
    mapping; None: nothing to check) whose ``effects`` list is not empty is refused (InputError naming the file and
    the key, with ``instead``: where that command takes effects), never run silently without them."""
    if fit is None:
        return
    data, path = fit_body(fit)
    if data.get("effects"):
        ids = ", ".join(str(e.get("id")) if isinstance(e, dict) else "?" for e in data["effects"])
        raise InputError(f"{command} uses only the VBMM constants of this file, and it lists effects ({ids}) that "
                         f"would be left out; {instead}, or give a file without the effects list",
                         path=path, key="effects")
