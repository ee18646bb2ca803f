"""report.html opens in a real browser (headless Chromium) at 1400 px and 800 px wide.

The report itself has no scripts. This test renders a COPY of it with one injected script that, after the
page has loaded, writes what it measured into the DOM (``--dump-dom`` prints it): the id of the first and the
last section, the page's scroll width against the window width (horizontal overflow), and each image's load
state and natural size. Screenshots of the first screen at both widths are written to a folder
(``BPMID_SCREENSHOTS`` or a temporary one, printed) for a person to look at.
The test installs nothing: it is skipped, with the reason, only when no Chromium is on this machine
(``.ci/run`` installs Debian's ``chromium`` package).
"""
from __future__ import annotations

import json
import os
import re
import shutil
import subprocess
from pathlib import Path

import pytest


CANDIDATES = ("/usr/bin/chromium", "chromium", "chromium-browser", "google-chrome")
CHECK = """<script>
window.addEventListener('load', function () {
  var imgs = [];
  for (var i = 0; i < document.images.length; i++) {
    var im = document.images[i];
    imgs.push([im.complete ? 1 : 0, im.naturalWidth, im.naturalHeight]);
  }
  var secs = document.querySelectorAll('body > section');
  var wide = [];
  document.querySelectorAll('body *').forEach(function (e) {
    var r = e.getBoundingClientRect();
    if (r.right > window.innerWidth + 1 && wide.length < 5) wide.push(e.tagName + '.' + e.className);
  });
  var svgs = document.querySelectorAll('figure > svg');
  var svgOk = 0;
  svgs.forEach(function (s) { var r = s.getBoundingClientRect(); if (r.width > 100 && r.height > 100) svgOk++; });
  var out = {first: secs.length ? secs[0].id : '', last: secs.length ? secs[secs.length - 1].id : '',
             lastDetails: secs.length ? !!secs[secs.length - 1].querySelector('details') : false,
             scroll: document.documentElement.scrollWidth, inner: window.innerWidth, wide: wide,
             imgs: imgs, svgs: svgs.length, svgOk: svgOk, math: document.querySelectorAll('math').length};
  var d = document.createElement('pre');
  d.id = 'probe';
  d.textContent = 'PROBE' + JSON.stringify(out) + 'END';
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
needs_browser = pytest.mark.skipif(BROWSER is None, reason="no Chromium on this machine (apt-get install chromium; "
                                   ".ci/run does) - the report cannot be rendered in a browser here")


def _chromium(args, profile: Path, timeout=120):
    cmd = [BROWSER, "--headless", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
           "--disable-background-networking", "--disable-component-update", "--disable-sync", "--hide-scrollbars",
           f"--user-data-dir={profile}", *args]
    return subprocess.run(cmd, capture_output=True, text=True, timeout=timeout)


def _probe(page: str, folder: Path, width: int) -> dict:
    """Render a copy of ``page`` in an empty folder (only embedded data can show) at ``width`` px."""
    folder.mkdir(parents=True, exist_ok=True)
    probe = folder / f"probe_{width}.html"
    probe.write_text(page.replace("</body>", CHECK + "</body>"))
    proc = _chromium([f"--window-size={width},1000", "--virtual-time-budget=10000", "--dump-dom", probe.as_uri()],
                     folder / f"profile_{width}")
    m = re.search(r"PROBE(\{.*?\})END", proc.stdout, re.S)
    assert m, f"the page did not finish loading in Chromium (exit {proc.returncode}): {proc.stderr[-2000:]}"
    return json.loads(m.group(1))


@pytest.fixture(scope="module")
def study(timed_small_study):
    return timed_small_study


@needs_browser
@pytest.mark.parametrize("width", [1400, 800])
def test_report_in_headless_chromium(study, tmp_path_factory, width):
    page = (study / "report.html").read_text()
    n_img = len(re.findall(r"<img ", page))
    assert n_img >= 10
    res = _probe(page, tmp_path_factory.mktemp(f"iso{width}"), width)
    assert res["first"] == "summary" and res["last"] == "provenance" and res["lastDetails"], res
    assert res["scroll"] <= res["inner"], f"horizontal overflow at {width} px: {res['scroll']} > {res['inner']} " \
                                          f"({res['wide']})"
    assert len(res["imgs"]) == n_img
    for i, (done, w, h) in enumerate(res["imgs"]):
        assert done == 1 and w > 100 and h > 100, f"image {i} did not load: {done} {w}x{h}"
    assert res["math"] >= 4  # the model's equations, as MathML
    # a screenshot of the first screen for a person to look at: BPMID_SCREENSHOTS=DIR asks for it (a third Chromium
    # launch per width, some 1 s of the 100 s budget, for a file no assertion reads beyond its size)
    if not os.environ.get("BPMID_SCREENSHOTS"):
        return
    shots = Path(os.environ["BPMID_SCREENSHOTS"])
    shots.mkdir(parents=True, exist_ok=True)
    png = shots / f"report_{width}px.png"
    iso = tmp_path_factory.mktemp(f"shot{width}")
    (iso / "report.html").write_text(page)
    _chromium([f"--window-size={width},1400", f"--screenshot={png}", (iso / "report.html").as_uri()],
              iso / "profile")
    assert png.is_file() and png.stat().st_size > 10_000
    print(f"screenshot: {png}")


@needs_browser
def test_svg_report_in_headless_chromium(study, tmp_path_factory):
    """--figures svg: the figures are inline SVG elements that lay out at a real size."""
    from typer.testing import CliRunner

    from bpmid.cli import app

    d = tmp_path_factory.mktemp("svgreport") / "copy"
    shutil.copytree(study, d)
    r = CliRunner().invoke(app, ["report", str(d), "--figures", "svg"])
    assert r.exit_code == 0, r.output
    page = (d / "report.html").read_text()
    res = _probe(page, tmp_path_factory.mktemp("isosvg"), 1400)
    assert res["svgs"] >= 3 and res["svgOk"] == res["svgs"], res
    assert res["scroll"] <= res["inner"], res
