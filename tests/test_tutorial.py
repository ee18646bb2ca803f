"""docs/tutorial.md runs as written: every ```python block, in order, in one namespace."""
import re
from pathlib import Path

import matplotlib.pyplot as plt

TUTORIAL = Path(__file__).resolve().parents[1] / "docs" / "tutorial.md"


def test_tutorial_runs(tmp_path, monkeypatch, capsys):
    blocks = re.findall(r"```python\n(.*?)```", TUTORIAL.read_text(), flags=re.S)
    assert len(blocks) >= 7
    monkeypatch.chdir(tmp_path)
    (tmp_path / "tutorial_out").mkdir()
    ns = {"__name__": "__tutorial__"}
    for i, code in enumerate(blocks):
        exec(compile(code, f"{TUTORIAL.name}[block {i + 1}]", "exec"), ns)
    plt.close("all")
    out = capsys.readouterr().out
    assert "refused:" in out and "pressure_unit" in out
    assert (tmp_path / "tutorial_out" / "VBMM.yaml").is_file() and (tmp_path / "tutorial_out" / "sim").is_dir()
    assert ns["same"] == ns["fit"] and ns["found"].named_effects is not None
