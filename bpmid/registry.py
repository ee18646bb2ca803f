"""Registries name classes as ``"module:Class"`` and import them on first use, so that a registry line is all
a new model family, catalogue effect or config section needs (and importing bpmid stays cheap)."""
from __future__ import annotations

import importlib
from typing import Mapping

from bpmid.errors import InputError


def lookup(registry: Mapping[str, str], name: str, *, what: str, key: str | None = None):
    """The object registered under ``name``; an InputError naming the known names otherwise.

    Parameters
    ----------
    registry : name -> ``"module:Class"``
    what : words for the message ("model", "effect id", "config section")
    key : the option or config key at fault, for the message
    """
    if name not in registry:
        raise InputError(f"unknown {what} {name!r} (known: {', '.join(registry)})", key=key)
    module, attr = registry[name].split(":")
    return getattr(importlib.import_module(module), attr)
