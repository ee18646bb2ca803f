"""Exports of fitted models to other tools (C code, finite-element input files)."""
