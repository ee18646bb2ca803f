"""The shipped configs and datasets, as package data (see :mod:`bpmid.data`).

In the source tree ``configs`` and ``datasets`` here are links to the top-level folders; an installed
bpmid (``pip install .``) carries copies of them.
"""
