"""The source paper's published numbers (spec/EXPERIMENTS.md): QUOTED, measured by the paper's authors on
their own muscle and rig. The report keeps them in panels of their own, never mixed with bpmid's numbers."""
from __future__ import annotations

PAPER_SOURCE = ("Published figures of the source paper (seed 000, section V), as listed in spec/EXPERIMENTS.md; "
                "measured by the paper's authors on their own muscle and test rig.")
PAPER_RELAX = {"E_inf": 0.0272e6, "E_1": 0.0549e6, "tau_1": 0.399}
#: (experiment, quantity, value, unit)
PAPER_ROWS = [
    ("Relaxation fit (one term)", "E_inf", 0.0272, "MPa"),
    ("Relaxation fit (one term)", "E_1", 0.0549, "MPa"),
    ("Relaxation fit (one term)", "tau_1", 0.399, "s"),
    ("Relaxation fit (one term)", "RMSE", 0.00192, "MPa"),
    ("Relaxation fit (one term)", "R²", 0.873, "1"),
    ("Relaxation fit (one term)", "MAPE", 5.472, "%"),
    ("1a variable amplitude, VBMM-fit", "RMSE", 2.122, "°"),
    ("1a variable amplitude, VBMM-fit", "MAPE", 3.339, "%"),
    ("1a variable amplitude, VBMM-fit", "R²", 0.936, "1"),
    ("1a variable amplitude, VBMM-mat.", "RMSE", 3.388, "°"),
    ("1a variable amplitude, VBMM-mat.", "MAPE", 5.459, "%"),
    ("1a variable amplitude, VBMM-mat.", "R²", 0.836, "1"),
    ("1b variable rate, VBMM-fit", "RMSE", 2.137, "°"),
    ("1b variable rate, VBMM-fit", "MAPE", 3.686, "%"),
    ("1b variable rate, VBMM-fit", "R²", 0.928, "1"),
    ("1b variable rate, VBMM-mat.", "RMSE", 3.416, "°"),
    ("1b variable rate, VBMM-mat.", "MAPE", 6.021, "%"),
    ("1b variable rate, VBMM-mat.", "R²", 0.815, "1"),
    ("2 long term, full history", "RMSE", 2.148, "°"),
    ("2 long term, window (T_win = 20 s)", "RMSE", 2.148, "°"),
    ("2 long term, window (T_win = 20 s)", "cost per step", 4.0, "µs (about)"),
    ("2 long term, window vs full", "cost reduction", 97.0, "%"),
]
#: experiment 3 (closed-loop control, the paper's Fig. 18): (controller, quantity, value, unit)
PAPER_CONTROL_SOURCE = ("Experiment 3 of the source paper (Fig. 18; VBMM-PI of eq. 20 with P = 0.04, I = 0.01): "
                        "steps 45-75° in 15° increments, sawtooth 15°/30° amplitude, sines 0.042/0.083 Hz, "
                        "on the paper's muscle and rig.")
PAPER_CONTROL = [
    ("PI", "RMSE", 5.116, "°"),
    ("VBMM-PI", "RMSE", 2.411, "°"),
    ("VBMM-PI vs PI", "RMSE reduction", 52.9, "%"),
]
#: test-set names of the run config that correspond to the paper's experiments 1a and 1b
SET_1A = ("variable_amplitude", "exp1a", "1a")
SET_1B = ("variable_rate", "exp1b", "1b")
