"""Workflow modules that are also the workflow's call.

``bpmid.compare``, ``bpmid.predict``, ``bpmid.control`` and ``bpmid.discover`` are modules (their science) and,
in the public API, functions (``bpmid.compare(train, test)``). Python binds a submodule to its package's
attribute on import, so the two cannot be separate objects under one name; instead the module is made callable
and its call is the public function of :mod:`bpmid.api`. ``bpmid.compare.CompareResult`` keeps working.
"""
from __future__ import annotations

import importlib
import sys
import types


class WorkflowModule(types.ModuleType):
    """A module whose call runs the public workflow function named in ``__bpmid_call__``."""

    def __call__(self, *args, **kwargs):
        return self.__bpmid_function__()(*args, **kwargs)

    @property
    def __signature__(self):
        """The workflow function's signature (``inspect.signature(bpmid.compare)``, notebook tooltips)."""
        import inspect

        return inspect.signature(self.__bpmid_function__())

    def __bpmid_function__(self):
        module, attr = self.__bpmid_call__.split(":")
        return getattr(importlib.import_module(module), attr)


def make_callable(module_name: str, target: str) -> None:
    """Make module ``module_name`` callable as ``target`` (``"bpmid.api:compare"``)."""
    mod = sys.modules[module_name]
    mod.__class__ = WorkflowModule
    mod.__bpmid_call__ = target
    # help(bpmid.compare) shows the module's docstring: lead it with the call a user makes (its signature and
    # parameters), then the module's own text
    try:
        import inspect

        fn = mod.__bpmid_function__()
        call = f"{module_name}{inspect.signature(fn)}"
        mod.__doc__ = (f"{call}\n\n{inspect.cleandoc(fn.__doc__ or '')}\n\n"
                       f"The module {module_name} (its science):\n\n{inspect.cleandoc(mod.__doc__ or '')}")
    except Exception:  # pragma: no cover - the docstring is a convenience; the call works without it
        pass

