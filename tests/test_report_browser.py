"""report.html opens in a real browser (headless Chromium) and every figure loads.

The report itself has no scripts. This test renders a COPY of it with one injected script that, after the
page has loaded, writes each image's load state and natural size into the DOM; ``--dump-dom`` prints it.
The test installs nothing: it is skipped, with the reason, only when no Chromium is on this machine
(``.ci/run`` installs Debian's ``chromium`` package).
"""
from __future__ import annotations

import re
import shutil
import subprocess
from pathlib import Path

import pytest


CANDIDATES = ("/usr/bin/chromium", "chromium", "chromium-browser", "google-chrome")
CHECK = """<script>
window.addEventListener('load', function () {
  var out = [];
  for (var i = 0; i < document.images.length; i++) {
    var im = document.images[i];
    out.push((im.complete ? 1 : 0) + ':' + im.naturalWidth + 'x' + im.naturalHeight);
  }
  var d = document.createElement('pre');
  d.id = 'img-check';
  d.textContent = 'IMGCHECK[' + out.join(',') + ']';
  document.body.appendChild(d);
});
</script>"""


def find_browser() -> str | None:
    for c in CANDIDATES:
        p = shutil.which(c) if not c.startswith("/") else (c if Path(c).is_file() else None)
        if p:
            return p
    return None


BROWSER = find_browser()


@pytest.mark.skipif(BROWSER is None, reason="no Chromium on this machine (apt-get install chromium; .ci/run does) - "
                    "the report cannot be rendered in a browser here")
def test_report_renders_in_headless_chromium_with_every_image_loaded(tmp_path, timed_small_study):
    out = timed_small_study  # the small study, run once per session with timing on (tests/conftest.py)
    page = (out / "report.html").read_text()
    n_img = len(re.findall(r"<img ", page))
    assert n_img >= 10
    # render a copy in an empty folder: nothing next to it to load, so only embedded data can show
    iso = tmp_path / "isolated"
    iso.mkdir()
    probe = iso / "report_probe.html"
    probe.write_text(page.replace("</body>", CHECK + "</body>"))
    profile = tmp_path / "profile"
    cmd = [BROWSER, "--headless", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
           "--disable-background-networking", "--disable-component-update", "--disable-sync",
           f"--user-data-dir={profile}", "--virtual-time-budget=15000", "--dump-dom", probe.as_uri()]
    proc = subprocess.run(cmd, capture_output=True, text=True, timeout=180)
    m = re.search(r'<pre id="img-check">IMGCHECK\[([^\]]*)\]</pre>', proc.stdout)
    assert m, f"the page did not finish loading in Chromium (exit {proc.returncode}): {proc.stderr[-2000:]}"
    states = [s for s in m.group(1).split(",") if s]
    assert len(states) == n_img
    for i, s in enumerate(states):
        done, size = s.split(":")
        w, h = (int(v) for v in size.split("x"))
        assert done == "1" and w > 100 and h > 100, f"image {i} did not load: {s}"
    # the DOM Chromium built has the sections of the report
    for heading in ("Provenance: what was run", "Model comparison", "History modes on the long-term run"):
        assert heading in proc.stdout
