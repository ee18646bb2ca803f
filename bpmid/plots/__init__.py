"""Figures: functions that take results and return matplotlib figures; they never write files
(:func:`bpmid.plots.common.save_figure` does, atomically). One module per topic."""
