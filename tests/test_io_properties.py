"""Property tests: random bytes and random CSV shapes thrown at every reader. Each either reads or refuses with an
InputError (the CLI's exit 2, with a message); nothing else escapes (no traceback, no exit 1)."""
import string

import numpy as np
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from typer.testing import CliRunner

from bpmid.cli import app
from bpmid.errors import InputError
from bpmid.io.motion_logs import IOConfig, read_motion_log
from bpmid.io.relax_logs import read_relax_log
from bpmid.io.tables import read_table

SETTINGS = settings(max_examples=40, deadline=None, derandomize=True,
                    suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow])
MAGIC = [b"", b"PK\x03\x04", b"\xd0\xcf\x11\xe0\xa1\xb1\x1a\xe1", b"MATLAB 5.0 MAT-file", b"\xff\xfe", b"\xef\xbb\xbf",
         b"# pressure_reference: gauge\ntime_s,pressure_kpa,angle_deg\n"]
SUFFIX = [".csv", ".txt", ".xlsx", ".xls", ".mat", ".tsv", ""]
NAMES = ["time_s", "time", "Time (s)", "t", "timestamp", "time_ms", "pressure_kpa", "pressure", "Pressure (bar a)",
         "pressure_psig", "p / bar", "angle_deg", "angle", "theta_rad", "tilt_deg", "angle_pred_deg", "strain",
         "stress_mpa", "load_n", "extension_mm", "modulus_mpa", "E_relax", "foo", "", "Zeit [s]", "Winkel [°]"]
CELLS = st.one_of(st.floats(allow_nan=True, allow_infinity=True, width=32).map(lambda v: repr(float(v))),
                  st.integers(-10 ** 6, 10 ** 6).map(str),
                  st.sampled_from(["", "nan", "1,5", "0,25", "-", "abc", "2024-05-17T09:30:00", "1e400", '"1,2"',
                                   "s", "kPa", "deg", "°", " ", "1.5.3"]))


def _readers(path):
    """Run every reader on ``path``: each must return or raise InputError."""
    for fn in (lambda: read_motion_log(path, IOConfig(pressure_reference="gauge")),
               lambda: read_motion_log(path, IOConfig(units={"pressure": "kPa", "time": "s", "angle": "deg"},
                                                      pressure_reference="absolute"), require_angle=True),
               lambda: read_relax_log(path, gap_factor=5.0),
               lambda: read_table(path, required=("time",))):
        try:
            fn()
        except InputError as exc:
            assert exc.format().strip()


@SETTINGS
@given(magic=st.sampled_from(MAGIC), body=st.binary(max_size=600), suffix=st.sampled_from(SUFFIX))
def test_random_bytes(tmp_path, magic, body, suffix):
    path = tmp_path / f"log{suffix}"
    path.write_bytes(magic + body)
    _readers(path)


@st.composite
def csv_shapes(draw):
    ncol = draw(st.integers(1, 5))
    header = [draw(st.sampled_from(NAMES)) for _ in range(ncol)]
    sep = draw(st.sampled_from([",", ";", "\t", " ", "|"]))
    rows = []
    for _ in range(draw(st.integers(0, 8))):
        n = ncol if draw(st.booleans()) or ncol == 1 else draw(st.integers(1, ncol + 2))
        rows.append(sep.join(draw(CELLS) for _ in range(n)))
    meta = draw(st.lists(st.sampled_from(["# pressure_reference: gauge", "# Pressure Reference: ABSOLUTE",
                                          "# pressure_reference: sideways", "# pressure_unit: kPa", "sep=;",
                                          "# gauge_length_mm: 50", "# cross_section_mm2: -1", ""]), max_size=3))
    newline = draw(st.sampled_from(["\n", "\r\n", "\r"]))
    enc = draw(st.sampled_from(["utf-8", "utf-8-sig", "utf-16", "cp1252"]))
    text = newline.join(meta + [sep.join(header)] + rows) + newline
    return text.encode(enc, errors="replace")


@SETTINGS
@given(data=csv_shapes())
def test_random_csv_shapes(tmp_path, data):
    path = tmp_path / "log.csv"
    path.write_bytes(data)
    _readers(path)


@SETTINGS
@given(t=st.lists(st.floats(-1e3, 1e3, allow_nan=False), min_size=2, max_size=30),
       gap=st.one_of(st.none(), st.floats(1e-3, 10.0)))
def test_random_time_columns(tmp_path, t, gap):
    path = tmp_path / "log.csv"
    rows = "".join(f"{v!r},{1 + i % 3},{i}\n" for i, v in enumerate(t))
    path.write_text("# pressure_reference: gauge\ntime_s,pressure_kpa,angle_deg\n" + rows)
    try:
        log = read_motion_log(path, IOConfig(max_gap_s=gap))
    except InputError as exc:
        assert "bpmid" not in exc.message or exc.message
        return
    assert np.all(np.diff(log.time_s) > 0)


runner = CliRunner()


@settings(max_examples=8, deadline=None, derandomize=True,
          suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow])
@given(body=st.binary(max_size=200), suffix=st.sampled_from(SUFFIX),
       flags=st.lists(st.sampled_from([["--pressure-unit", "furlong"], ["--pressure-reference", "up"],
                                       ["--columns", "time"], ["--columns", "nothing=x"], ["--max-gap", "-1"],
                                       ["--time-unit", "ms"], ["--sheet", "x"], ["--strict"]]), max_size=2))
def test_cli_exit_codes_on_random_input(tmp_path, body, suffix, flags):
    path = tmp_path / f"log{suffix}"
    path.write_bytes(body)
    args = [a for f in flags for a in f]
    for cmd in (["fit", "motion"], ["fit", "relax"]):
        if cmd[1] == "relax":
            args = [a for f in flags for a in f if f[0] in ("--columns", "--max-gap", "--time-unit", "--sheet",
                                                                "--strict")]
        res = runner.invoke(app, [*cmd, str(path), "--out", str(tmp_path / "o.yaml"), *args])
        assert res.exit_code == 2, res.output
        assert res.output.strip().splitlines()[-1].startswith("error:") and "Traceback" not in res.output


def test_printable_junk_is_refused_by_name(tmp_path):
    path = tmp_path / "junk.csv"
    path.write_text(string.printable * 3)
    try:
        read_motion_log(path, IOConfig(pressure_reference="gauge"))
    except InputError as exc:
        assert "junk.csv" in exc.format()
    else:
        raise AssertionError("junk was read")


@settings(max_examples=15, deadline=None, derandomize=True,
          suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow])
@given(header=st.lists(st.sampled_from(NAMES), min_size=1, max_size=4),
       rows=st.lists(st.lists(st.one_of(st.none(), st.booleans(), st.floats(-1e6, 1e6, allow_nan=False),
                                        st.sampled_from(["x", "1,5", "2024-05-17T09:30:00", "#c", "k: v"])),
                              max_size=5), max_size=6))
def test_random_workbooks(tmp_path, header, rows):
    import openpyxl

    wb = openpyxl.Workbook()
    ws = wb.active
    ws.append(header)
    for r in rows:
        ws.append(r)
    path = tmp_path / "w.xlsx"
    wb.save(path)
    _readers(path)
