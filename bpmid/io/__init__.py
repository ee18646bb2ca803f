"""Readers for relaxation and motion logs, unit handling, and atomic writers with provenance."""
