"""Checks of bpmid's model code on external, real, licensed data (not bending-muscle logs)."""
