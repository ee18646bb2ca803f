"""bpmid: identify models of bending pneumatic muscles (BPMs).

Data flows one way: files -> logs (``bpmid.io``) -> model + parameters (``bpmid.models``)
-> simulation -> metrics (``bpmid.metrics``) -> results (``bpmid.io.results``) -> report.
"""
__version__ = "0.1.0"

from bpmid.errors import InputError  # noqa: E402

__all__ = ["__version__", "InputError"]
