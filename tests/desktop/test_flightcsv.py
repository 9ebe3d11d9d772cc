"""The flight-CSV format (desktop/io/flightcsv.py) and the real AltOS logs in tests/data/flights/altos."""

import json
import math
import re
import time
from decimal import ROUND_HALF_EVEN, Decimal
from pathlib import Path

import numpy as np
import pytest

from desktop.errors import DesktopError, InputFileError
from desktop.io.flightcsv import FlightCSVError, FlightLog, read_flight_csv, write_flight_csv

ALTOS_DIR = Path(__file__).parents[1] / "data" / "flights" / "altos"
ALTOS_FILES = sorted(ALTOS_DIR.glob("*.csv"))
ALTOS_STATES = {"pad", "boost", "fast", "coast", "drogue", "main", "landed"}


def _write(tmp_path, content, name="flight.csv"):
    p = tmp_path / name
    p.write_bytes(content.encode("utf-8") if isinstance(content, str) else content)
    return p


# --------------------------------------------------------------------------------------------------
# Reading: good files


def test_minimal_file_and_fields(tmp_path):
    p = _write(
        tmp_path,
        "# A comment\n"
        "# ground_pressure_pa: 101325.0\n"
        "# Rocket :  Test Rocket \n"
        "time_s,pressure_pa,accel_mps2,true_altitude_m,altos_state\n"
        "0.00,101325.00,9.8100,0.000,pad\n"
        "0.01,101320.50,,0.125,pad\n"
        "0.05,,50.0,1.000,boost\n",
    )
    log = read_flight_csv(p)
    assert isinstance(log, FlightLog)
    assert log.path == str(p)
    assert len(log) == 3
    assert log.columns == ["time_s", "pressure_pa", "accel_mps2", "true_altitude_m", "altos_state"]
    assert log.metadata == {"ground_pressure_pa": "101325.0", "rocket": "Test Rocket"}
    assert log.comments == ["A comment"]
    assert log.time_us.dtype == np.int64 and log.time_us.tolist() == [0, 10000, 50000]
    assert log.time_s.dtype == np.float64 and log.time_s.tolist() == [0.0, 0.01, 0.05]
    assert log.pressure_pa[0] == 101325.0 and math.isnan(log.pressure_pa[2])
    assert math.isnan(log.accel_mps2[1]) and log.accel_mps2[2] == 50.0
    assert log.altitude_m is None
    assert log.has_pressure and log.has_accel and not log.has_altitude
    assert log.extra["true_altitude_m"].dtype == np.float64
    assert log.extra["altos_state"].dtype == object
    assert log.extra["altos_state"].tolist() == ["pad", "pad", "boost"]
    assert log.line_numbers.tolist() == [5, 6, 7]
    assert log.metadata_float("ground_pressure_pa") == 101325.0
    assert log.metadata_float("GROUND_PRESSURE_PA") == 101325.0
    assert log.metadata_float("seed") is None
    assert log.metadata_float("seed", 7.0) == 7.0


def test_altitude_only_and_both(tmp_path):
    log = read_flight_csv(_write(tmp_path, "time_s,altitude_m\n0,-12.5\n1,3\n"))
    assert log.pressure_pa is None and log.accel_mps2 is None
    assert log.altitude_m.tolist() == [-12.5, 3.0] and not log.has_pressure and not log.has_accel
    log = read_flight_csv(_write(tmp_path, "altitude_m,time_s,pressure_pa\n1,0,90000\n2,1,89990\n"))
    assert log.altitude_m.tolist() == [1.0, 2.0] and log.pressure_pa.tolist() == [90000.0, 89990.0]
    assert log.time_us.tolist() == [0, 1000000]


def test_bom_crlf_trailing_blank_lines_whitespace_tolerated(tmp_path):
    content = "\ufeff# source: test\r\ntime_s , pressure_pa\r\n 0.00, 100000 \r\n0.10,99990\r\n\r\n\n  \n"
    log = read_flight_csv(_write(tmp_path, content))
    assert log.columns == ["time_s", "pressure_pa"]
    assert log.metadata == {"source": "test"}
    assert log.time_us.tolist() == [0, 100000]
    assert log.pressure_pa.tolist() == [100000.0, 99990.0]
    assert log.line_numbers.tolist() == [3, 4]


def test_comments_inside_data_are_kept_not_rows(tmp_path):
    log = read_flight_csv(_write(tmp_path, "time_s,pressure_pa\n0,1000\n# note here\n1,1001\n"))
    assert len(log) == 2 and log.comments == ["note here"] and log.line_numbers.tolist() == [2, 4]


def test_metadata_vs_comment_lines(tmp_path):
    log = read_flight_csv(
        _write(
            tmp_path,
            "# see http://example.org/x\n"
            "# sample rate: 100 Hz\n"
            "# license: GPL-2.0-or-later (AltOS); converted: yes\n"
            "# empty_key:\n"
            "#seed:42\n"
            "#seed2: 43\n"
            "time_s,pressure_pa\n0,1000\n",
        )
    )
    assert log.metadata == {
        "license": "GPL-2.0-or-later (AltOS); converted: yes",
        "empty_key": "",
        "seed2": "43",
    }
    assert log.comments == ["see http://example.org/x", "sample rate: 100 Hz", "seed:42"]


@pytest.mark.parametrize(
    "text, us",
    [
        ("10.20", 10200000),
        ("0.1", 100000),
        ("-0.30", -300000),
        ("0.000001", 1),
        ("-0.000001", -1),
        ("0.0000005", 0),  # ties to even, like round()
        ("0.0000015", 2),
        ("0.0000025", 2),
        ("1e-3", 1000),
        ("1.5E2", 150000000),
        ("+3", 3000000),
        ("4.", 4000000),
        (".25", 250000),
        ("123456.7890125", 123456789012),
        ("100000.000001", 100000000001),  # float would already lose the last digit here
    ],
)
def test_time_exact_decimal_rounding(tmp_path, text, us):
    log = read_flight_csv(_write(tmp_path, f"time_s,pressure_pa\n-1000,1000\n{text},1000\n"))
    assert log.time_us[1] == us
    assert us == int((Decimal(text) * 1000000).to_integral_value(ROUND_HALF_EVEN))


def test_extra_columns_numeric_or_text(tmp_path):
    log = read_flight_csv(
        _write(
            tmp_path,
            "time_s,pressure_pa,n,s,empty,mixed\n0,1000,1,a,,1\n1,1000,,b,,x\n2,1000,3e2,,,2.5\n",
        )
    )
    assert log.extra["n"].dtype == np.float64 and np.isnan(log.extra["n"][1]) and log.extra["n"][2] == 300
    assert log.extra["s"].tolist() == ["a", "b", ""]
    assert log.extra["empty"].dtype == np.float64 and np.isnan(log.extra["empty"]).all()
    assert log.extra["mixed"].dtype == object and log.extra["mixed"].tolist() == ["1", "x", "2.5"]


def test_variable_sample_rate(tmp_path):
    log = read_flight_csv(_write(tmp_path, "time_s,pressure_pa\n0,1000\n0.01,1000\n0.02,1\n0.12,2\n5,3\n"))
    assert np.diff(log.time_us).tolist() == [10000, 10000, 100000, 4880000]


# --------------------------------------------------------------------------------------------------
# Reading: errors, each with the file, the physical line number and the problem on one line

H = "time_s,pressure_pa,accel_mps2\n"
BAD_FILES = [
    # id, content, line (None: no line applies), text the message must contain
    ("empty", "", None, "file is empty"),
    ("only_comments", "# a\n# b: c\n\n", None, "no header line"),
    ("only_blank", "\n\n", None, "no header line"),
    ("no_rows", "# x\n" + H + "\n", 2, "no data rows"),
    ("no_time", "t,pressure_pa\n0,1\n", 1, "header has no 'time_s' column"),
    ("data_without_header", "# c\n0.0,101325,9.8\n", 2, "is the header line missing?"),
    ("no_baro", "time_s,accel_mps2\n0,9.8\n", 1, "needs a 'pressure_pa' or 'altitude_m'"),
    ("duplicate_col", "time_s,pressure_pa,pressure_pa\n0,1,2\n", 1, "duplicate column name 'pressure_pa'"),
    ("empty_col_name", "time_s,,pressure_pa\n0,1,2\n", 1, "column 2 has an empty name"),
    ("too_few_cells", H + "0,1000,9.8\n0.01,1000\n", 3, "row has 2 cells, the header has 3"),
    ("too_many_cells", H + "0,1000,9.8,\n", 2, "row has 4 cells, the header has 3"),
    ("bad_pressure", H + "0,1000,1\n0.01,abc,1\n", 3, "column 'pressure_pa': 'abc' is not a number"),
    ("bad_accel", H + "0,1000,1\n0.01,1000,9.8g\n", 3, "column 'accel_mps2': '9.8g' is not a number"),
    ("underscore_number", H + "0,100_000,1\n", 2, "'100_000' is not a number"),
    ("unicode_digits", H + "0,\u0661\u0662,1\n", 2, "is not a number"),
    ("bad_time", H + "0,1000,1\n1:00,1000,1\n", 3, "column 'time_s': '1:00' is not a number"),
    ("nan_text", H + "0,1000,1\n0.01,NaN,1\n", 3, "'NaN' is not allowed (leave the cell empty"),
    ("inf_text", H + "0,1000,inf\n", 2, "column 'accel_mps2': 'inf' is not allowed"),
    ("neg_infinity_text", H + "0,1000,1\n1,1000,-Infinity\n", 3, "'-Infinity' is not allowed"),
    ("nan_time", H + "nan,1000,1\n", 2, "column 'time_s': 'nan' is not allowed"),
    ("nan_in_extra", "time_s,pressure_pa,x\n0,1,1\n1,1,nan\n", 3, "column 'x': 'nan' is not allowed"),
    ("overflow", H + "0,1000,1e400\n", 2, "column 'accel_mps2': '1e400' is out of range"),
    ("time_overflow", H + "1e30,1000,1\n", 2, "column 'time_s': '1e30' is out of range"),
    ("empty_time", H + "0,1000,1\n,1000,1\n", 3, "column 'time_s' is empty"),
    ("time_back", H + "0,1,1\n2.5,1,1\n2.4,1,1\n", 4,
     "time goes backwards: 2.4 s after 2.5 s (line 3)"),
    ("pressure_zero", H + "0,1000,1\n1,0,1\n", 3, "column 'pressure_pa': 0 Pa is implausible"),
    ("pressure_negative", H + "0,-5.5,1\n", 2, "'pressure_pa': -5.5 Pa is implausible"),
    ("pressure_high", H + "0,1000,1\n1,200000.01,1\n", 3, "200000.01 Pa is implausible"),
    ("accel_high", H + "0,1000,1\n1,1000,1e30\n", 3, "column 'accel_mps2': 1e30 m/s^2 is implausible"),
    ("accel_low", H + "0,1000,-19614\n", 2, "-19614 m/s^2 is implausible (expected at most 19613"),
    ("pressure_all_empty", H + "0,,1\n1,,1\n", 1, "'pressure_pa' has no readings"),
    ("blank_inside_data", H + "0,1,1\n\n1,1,1\n", 3, "blank line inside the data"),
    ("dup_metadata", "# seed: 1\n# x\n# Seed: 2\n" + H + "0,1,1\n", 3,
     "metadata key 'seed' repeated (first on line 1)"),
    ("crlf_line_numbers", H.replace("\n", "\r\n") + "0,1,1\r\n1,x,1\r\n", 3, "'x' is not a number"),
    ("bom_line_numbers", "\ufeff" + H + "0,1,1\n1,x,1\n", 3, "'x' is not a number"),
    ("not_utf8", (H + "0,1000,1\n1,1000,\xb0\n").encode("latin-1"), 3, "not UTF-8 text (byte 0xb0"),
    ("nul_bytes", b"time_s,pressure_pa\n0,1\x00\x00\x001\n", 2, "binary data (NUL byte)"),
    ("binary_junk", bytes(range(256)) * 4, 1, "binary data"),
    ("utf16", H.encode("utf-16"), 1, "UTF-16 text; save the file as UTF-8"),
    ("old_mac_cr", "# c\r\n" + H.replace("\n", "\r") + "0,1,1\r", 2, "carriage return inside a line"),
    ("unicode_line_sep", H + "0,1,1\n1,1\u2028,1\n", 3, "'1\\u2028' is not a number"),
    ("odd_dup_name", "time_s,altitude_m,a\u2028,a\u2028\n0,1,1,1\n", 1, "duplicate column name 'a\\u2028'"),
]


@pytest.mark.parametrize("content, line, text", [c[1:] for c in BAD_FILES], ids=[c[0] for c in BAD_FILES])
def test_bad_file_errors(tmp_path, content, line, text):
    p = _write(tmp_path, content)
    # content problems are FlightCSVError; text that is not UTF-8 at all is InputFileError
    with pytest.raises((FlightCSVError, InputFileError)) as info:
        read_flight_csv(p)
    msg = str(info.value)
    assert "\n" not in msg and "\r" not in msg
    prefix = f"{p}:{line}: " if line is not None else f"{p}: "
    assert msg.startswith(prefix), msg
    assert text in msg, msg
    assert info.value.line == line and info.value.path == str(p)
    assert isinstance(info.value, DesktopError)


def test_error_message_exact_form(tmp_path):
    rows = "".join(f"{i / 100:.2f},{100000 - i},9.81\n" for i in range(55))
    p = _write(tmp_path, H + rows + "0.55,abc,9.81\n")  # the header is line 1, so this is line 57
    with pytest.raises(FlightCSVError) as info:
        read_flight_csv(p)
    assert str(info.value) == f"{p}:57: column 'pressure_pa': 'abc' is not a number"


def test_missing_file_and_directory(tmp_path):
    with pytest.raises(InputFileError, match=r"nope\.csv: flight CSV not found$"):
        read_flight_csv(tmp_path / "nope.csv")
    with pytest.raises(InputFileError, match="is a directory, not a flight CSV"):
        read_flight_csv(tmp_path)


def test_path_through_a_file(tmp_path):
    p = _write(tmp_path, H + "0,1,1\n")
    with pytest.raises(InputFileError, match=r"flight\.csv/x\.csv: cannot read flight CSV: Not a directory$"):
        read_flight_csv(p / "x.csv")


def test_mangled_files_never_raise_anything_else(tmp_path):
    """Random byte damage to a valid file: it still reads, or fails with one line (FlightCSVError or
    InputFileError)."""
    good = (ALTOS_DIR / "2012-05-28-serial-319-flight-005.csv").read_bytes()[:3000]
    good = good[: good.rindex(b"\n") + 1]
    rng = np.random.default_rng(3)
    junk = b",.-+eE#:\n\r \x00\xff\xc3nai0123456789"
    outcomes = {"ok": 0, "error": 0}
    for k in range(300):
        data = bytearray(good)
        for _ in range(rng.integers(1, 4)):
            pos = int(rng.integers(0, len(data)))
            op = rng.integers(0, 3)
            byte = junk[int(rng.integers(0, len(junk)))]
            if op == 0:
                data[pos] = byte
            elif op == 1:
                data.insert(pos, byte)
            else:
                del data[pos]
        p = _write(tmp_path, bytes(data), f"m{k}.csv")
        try:
            read_flight_csv(p)
            outcomes["ok"] += 1
        except (FlightCSVError, InputFileError) as e:
            assert "\n" not in str(e) and "\r" not in str(e) and str(e).startswith(f"{p}:")
            outcomes["error"] += 1
    assert outcomes["ok"] > 10 and outcomes["error"] > 100


def test_unreadable_flight_csv_is_a_one_line_input_error(tmp_path):
    p = _write(tmp_path, H + "0,1,1\n")
    p.chmod(0)
    try:
        try:
            p.read_bytes()
        except PermissionError:
            pass
        else:
            pytest.skip("running with privileges that ignore file permissions")
        with pytest.raises(InputFileError, match="cannot read flight CSV: Permission denied"):
            read_flight_csv(p)
    finally:
        p.chmod(0o644)


@pytest.mark.parametrize("value", ["250 m", "abc", "nan", "", "1e400"])
def test_metadata_float_errors(tmp_path, value):
    p = _write(tmp_path, f"# comment\n# main_deploy_m: {value}\n" + H + "0,1,1\n")
    log = read_flight_csv(p)
    with pytest.raises(FlightCSVError) as info:
        log.metadata_float("main_deploy_m")
    assert str(info.value).startswith(f"{p}:2: metadata 'main_deploy_m': ")


# --------------------------------------------------------------------------------------------------
# Writing and round trip


def test_written_flight_csv_reads_back_the_same_values(tmp_path):
    rng = np.random.default_rng(1)
    n = 500
    t = np.cumsum(rng.integers(1, 200000, n)) / 1e6 - 0.3
    p = 101325.0 - np.cumsum(rng.normal(0, 30, n))
    p[[3, 7]] = np.nan
    alt = rng.normal(100, 300, n)
    acc = rng.normal(0, 40, n)
    acc[10] = np.nan
    true_alt = rng.normal(500, 200, n)
    vel = rng.normal(0, 1e3, n)
    state = np.array(["pad"] * 100 + ["boost"] * 400, dtype=object)
    state[5] = None
    count = np.arange(n)
    cols = {
        "time_s": t,
        "pressure_pa": p,
        "altitude_m": alt,
        "accel_mps2": acc,
        "true_altitude_m": true_alt,
        "true_velocity_mps": vel,
        "altos_state": state,
        "count": count,
    }
    meta = {"ground_pressure_pa": 101325.0, "rocket": "Test Rocket", "seed": 7,
            "true_apogee_m": np.float64(1.5)}
    path = tmp_path / "rt.csv"
    write_flight_csv(path, cols, metadata=meta, comments=["simulated flight", "second line"])
    log = read_flight_csv(path)

    assert log.columns == list(cols)
    assert log.comments == ["simulated flight", "second line"]
    assert log.metadata == {"ground_pressure_pa": "101325.0", "rocket": "Test Rocket", "seed": "7",
                            "true_apogee_m": "1.5"}
    assert log.metadata_float("seed") == 7.0
    assert log.time_us.tolist() == [round(x * 1e6) for x in t]
    np.testing.assert_allclose(log.time_s, t, rtol=0, atol=5e-7)
    assert np.array_equal(np.isnan(log.pressure_pa), np.isnan(p))
    np.testing.assert_allclose(log.pressure_pa, p, rtol=0, atol=0.005 + 1e-9)
    np.testing.assert_allclose(log.altitude_m, alt, rtol=0, atol=0.0005 + 1e-9)
    assert np.isnan(log.accel_mps2[10])
    np.testing.assert_allclose(log.accel_mps2, acc, rtol=0, atol=0.00005 + 1e-9)
    np.testing.assert_allclose(log.extra["true_altitude_m"], true_alt, rtol=0, atol=0.0005 + 1e-9)
    np.testing.assert_allclose(log.extra["true_velocity_mps"], vel, rtol=5e-6, atol=0)
    assert log.extra["altos_state"].tolist() == ["" if s is None else s for s in state]
    assert log.extra["count"].tolist() == count.tolist()

    # Writing what was read reproduces the file byte for byte.
    again = tmp_path / "again.csv"
    cols2 = {"time_s": log.time_s, "pressure_pa": log.pressure_pa, "altitude_m": log.altitude_m,
             "accel_mps2": log.accel_mps2, **log.extra}
    write_flight_csv(again, cols2, metadata=log.metadata, comments=log.comments)
    assert again.read_bytes() == path.read_bytes()


def test_integer_microseconds_round_trip_exactly(tmp_path):
    rng = np.random.default_rng(2)
    us = np.unique(rng.integers(-10**9, 10**9, 2000))
    path = tmp_path / "us.csv"
    write_flight_csv(path, {"time_s": us / 1e6, "altitude_m": np.zeros(len(us))})
    assert read_flight_csv(path).time_us.tolist() == us.tolist()


def test_written_text_format(tmp_path):
    path = tmp_path / "fmt.csv"
    write_flight_csv(
        path,
        {
            "time_s": [-0.3, -0.000001, 0.0, 10.2, 12.345678, 100.0],
            "pressure_pa": [101325, 101325.004, float("nan"), 99999.995, 1.0, 2.0],
            "altitude_m": [0.0, -0.0001, 1.23456, None, 5, 6],
            "accel_mps2": [9.80667, -0.00001, 0.0, 1e-5, 3, float("nan")],
            "x": [1.0, 2.5, 1234567.0, 1.23456789, -0.0, float("nan")],
            "s": ["pad", "boost", None, "", "coast", "main"],
        },
        metadata={"source": "unit test", "main_deploy_m": 250},
        comments=["made by a test"],
    )
    assert path.read_text(encoding="utf-8") == (
        "# made by a test\n"
        "# source: unit test\n"
        "# main_deploy_m: 250\n"
        "time_s,pressure_pa,altitude_m,accel_mps2,x,s\n"
        "-0.30,101325.00,0.000,9.8067,1,pad\n"
        "-0.000001,101325.00,0.000,0.0000,2.5,boost\n"
        "0.00,,1.235,0.0000,1234567,\n"
        "10.20,99999.99,,0.0000,1.23457,\n"
        "12.345678,1.00,5.000,3.0000,0,coast\n"
        "100.00,2.00,6.000,,,main\n"
    )


@pytest.mark.parametrize(
    "cols, kwargs, text",
    [
        ({"pressure_pa": [1.0], "time_s": [0.0]}, {}, "must be the first column"),
        ({"time_s": [0.0], "accel_mps2": [1.0]}, {}, "need a 'pressure_pa' or 'altitude_m'"),
        ({"time_s": [0.0, 1.0], "pressure_pa": [1.0]}, {}, "has 1 values"),
        ({"time_s": [0.0, 0.0000001], "pressure_pa": [1.0, 1.0]}, {}, "not strictly increasing"),
        ({"time_s": [1.0, 0.5], "pressure_pa": [1.0, 1.0]}, {}, "not strictly increasing"),
        ({"time_s": [0.0, float("nan")], "pressure_pa": [1.0, 1.0]}, {}, "non-finite"),
        ({"time_s": [0.0], "pressure_pa": [0.0]}, {}, "outside 0 < p"),
        ({"time_s": [0.0], "pressure_pa": [1.0], "accel_mps2": [1e5]}, {}, "beyond +-19613 m/s^2"),
        ({"time_s": [0.0], "pressure_pa": [float("inf")]}, {}, "infinite"),
        ({"time_s": [0.0], "altitude_m": [1.0], "s": ["a,b"]}, {}, "has a comma"),
        ({"time_s": [0.0], "altitude_m": [1.0], "s": ["a\nb"]}, {}, "newline"),
        ({"time_s": [0.0], "altitude_m": [1.0], "a,b": [1.0]}, {}, "bad column name"),
        ({"time_s": [], "altitude_m": []}, {}, "no rows"),
        ({"time_s": [0.0], "altitude_m": [1.0]}, {"metadata": {"Bad Key": 1}}, "bad metadata key"),
        ({"time_s": [0.0], "altitude_m": [1.0]}, {"metadata": {"k": "a\nb"}}, "newline"),
        ({"time_s": [0.0], "altitude_m": [1.0]}, {"comments": ["seed: 3"]}, "would read back as metadata"),
        ({"time_s": [0.0], "altitude_m": [1.0]}, {"comments": ["a\nb"]}, "newline"),
    ],
)
def test_writer_rejects_bad_columns_and_writes_no_file(tmp_path, cols, kwargs, text):
    path = tmp_path / "w.csv"
    with pytest.raises(ValueError, match=re.escape(text)):
        write_flight_csv(path, cols, **kwargs)
    assert not path.exists()


# --------------------------------------------------------------------------------------------------
# The real AltOS logs


def test_altos_folder_complete():
    assert len(ALTOS_FILES) == 16
    assert (ALTOS_DIR / "README.md").is_file()


@pytest.mark.parametrize("path", ALTOS_FILES, ids=[p.stem for p in ALTOS_FILES])
def test_altos_log_loads(path):
    log = read_flight_csv(path)
    # No silently dropped row: one row per non-comment line after the header.
    body = [ln for ln in path.read_text(encoding="utf-8").splitlines() if ln and not ln.startswith("#")]
    assert len(log) == len(body) - 1 > 900
    assert log.columns == ["time_s", "pressure_pa", "accel_mps2", "altos_state"]

    dt = np.diff(log.time_us)
    assert (dt > 0).all()
    assert log.time_us[0] == -300000
    # 100 Hz through pad/boost/fast/coast, then 10 Hz after the board's apogee decision.
    fast, slow = np.flatnonzero(dt == 10000), np.flatnonzero(dt == 100000)
    assert fast.size > 300 and slow.size > 50
    assert fast.max() < slow.min()
    assert ((dt == 10000) | (dt == 100000) | ((dt >= 110000) & (dt <= 140000))).all()

    assert log.has_pressure and not np.isnan(log.pressure_pa).any()
    assert log.has_accel and not np.isnan(log.accel_mps2).any()
    assert log.altitude_m is None
    # On the pad the accelerometer reads about +1 g (specific force, nose up); on 319-005 the
    # pre-launch ring buffer already holds the motor's first 0.3 s (about +1.8 g).
    assert 7.0 < np.median(log.accel_mps2[:5]) < (20.0 if "319-flight-005" in path.name else 12.0)
    states = log.extra["altos_state"]
    assert states.dtype == object and set(states.tolist()) <= ALTOS_STATES
    assert states[0] == "pad"

    assert log.metadata["main_deploy_m"] == "250"
    assert log.metadata_float("main_deploy_m") == 250.0
    assert log.metadata_float("apogee_delay_s") == 0.0
    assert log.metadata["license"].startswith("GPL-2.0-or-later")
    assert log.metadata["source"].startswith("AltOS source tree")
    assert any(c.startswith("sample rate:") for c in log.comments)


def test_largest_altos_log_loads_fast():
    largest = max(ALTOS_FILES, key=lambda p: p.stat().st_size)
    read_flight_csv(largest)
    best = math.inf
    for _ in range(3):
        t0 = time.perf_counter()
        read_flight_csv(largest)
        best = min(best, time.perf_counter() - t0)
    assert best < 0.2, f"{largest.name} took {best:.3f} s"


# --------------------------------------------------------------------------------------------------
# reference.json against the README table


def _readme_table():
    lines = (ALTOS_DIR / "README.md").read_text(encoding="utf-8").splitlines()
    start = next(i for i, ln in enumerate(lines) if ln.startswith("| file |"))
    rows = {}
    for ln in lines[start + 2:]:
        if not ln.startswith("|"):
            break
        cells = [c.strip() for c in ln.strip().strip("|").split("|")]
        assert len(cells) == 6, ln
        rows[cells[0]] = cells[1:]
    return rows


def _load_reference():
    return json.loads((ALTOS_DIR / "reference.json").read_text(encoding="utf-8"))["flights"]


def test_reference_json_matches_readme_table():
    table = _readme_table()
    ref = _load_reference()
    assert set(table) == set(ref) == {p.name for p in ALTOS_FILES}
    for name, (board, t_apo, alt, logged, notes) in table.items():
        r = ref[name]
        assert set(r) == {"board", "apogee_time_s", "apogee_altitude_m_agl", "board_logged_s", "notes",
                          "clean", "non_flight"}
        assert r["board"] == board
        assert r["notes"] == notes
        assert r["board_logged_s"] == float(logged)
        if t_apo.startswith("none"):
            assert r["apogee_time_s"] is None and r["non_flight"] and not r["clean"]
        else:
            assert r["apogee_time_s"] == float(t_apo) and not r["non_flight"]
        assert r["apogee_altitude_m_agl"] == (None if alt == "-" else float(alt))
    clean = {n for n, r in ref.items() if r["clean"]}
    assert len(clean) == 14
    assert set(ref) - clean == {
        "2012-08-31-serial-334-flight-003.csv",
        "2012-05-28-serial-319-flight-005.csv",
    }
    assert [n for n, r in ref.items() if r["non_flight"]] == ["2012-08-31-serial-334-flight-003.csv"]


def test_reference_board_logged_matches_the_data():
    """board_logged_s is the first row after the board left coast (drogue or main)."""
    for name, r in _load_reference().items():
        log = read_flight_csv(ALTOS_DIR / name)
        states = log.extra["altos_state"]
        after = [i for i, s in enumerate(states) if s in ("drogue", "main")]
        assert round(log.time_us[after[0]] / 1e6, 6) == r["board_logged_s"], name
        if r["apogee_time_s"] is not None:
            assert log.time_s[0] < r["apogee_time_s"] < log.time_s[-1]


def test_docs_example_reads(tmp_path):
    """The example at the top of docs/FLIGHT_CSV.md is a valid flight CSV."""
    doc = (Path(__file__).parents[2] / "docs" / "FLIGHT_CSV.md").read_text(encoding="utf-8")
    example = doc.split("```\n", 2)[1]
    log = read_flight_csv(_write(tmp_path, example))
    assert len(log) == 7 and np.isnan(log.accel_mps2[3])
    assert log.metadata_float("ground_pressure_pa") == 101325.0
    assert log.metadata_float("true_apogee_time_s") == 14.02


FIRM_DIR = Path(__file__).parents[1] / "data" / "flights" / "firm"


@pytest.mark.parametrize("name, apogee_s", [("firm-jackpot-1.csv", 1221.924), ("firm-jackpot-3.csv", 800.500),
                                            ("firm-jackpot-4.csv", 3354.882)])
def test_firm_flights_read_with_provenance_and_reference_apogee(name, apogee_s):
    """The FIRM flights are flight CSVs with their source, licence and reference apogee; the
    licence they were published under sits beside them."""
    log = read_flight_csv(FIRM_DIR / name)
    assert log.metadata["license"] == "MIT" and "AirbrakesV2" in log.metadata["source"]
    assert log.metadata_float("reference_apogee_time_s") == apogee_s
    assert log.time_s[0] < apogee_s < log.time_s[-1] and log.has_accel and log.has_pressure
    assert "MIT License" in (FIRM_DIR / "LICENSE-AirbrakesV2.txt").read_text()
    assert name in (FIRM_DIR / "README.md").read_text()


@pytest.mark.parametrize("rows, expected, note", [
    # the same row twice (a logger writing a record again): dropped
    ("0.10,1000,1\n0.1,1000,1.0\n0.2,999,2\n", [(1000.0, 1.0), (999.0, 2.0)],
     "1 identical row(s) dropped (line 3)"),
    # each sensor on its own row with the same time stamp: merged into one row
    ("0.1,1000,\n0.1,,2\n", [(1000.0, 2.0)], "1 row(s) with different readings merged into the row "
     "before (line 3)"),
    # two different readings at the same time: the later kept, and said so
    ("0.1,1000,1\n0.1,1001,\n0.2,1002,3\n", [(1001.0, 1.0), (1002.0, 3.0)],
     "the later reading kept where both had one (pressure_pa)"),
    # times that round to the same microsecond are the same time
    ("0.0000001,1,1\n0.0000004,1,1\n", [(1.0, 1.0)], "1 identical row(s) dropped (line 3)"),
])
def test_duplicated_times_are_folded_with_a_record(tmp_path, rows, expected, note):
    from desktop.io.flightcsv import describe_duplicate_times

    log = read_flight_csv(_write(tmp_path, H + rows))
    assert list(zip(log.pressure_pa.tolist(), log.accel_mps2.tolist(), strict=True)) == expected
    assert np.all(np.diff(log.time_us) > 0) and len(log.line_numbers) == len(expected)
    assert all(d.kept_line == d.line - 1 for d in log.duplicate_times)
    assert note in describe_duplicate_times(log.duplicate_times)


def test_no_duplicates_no_record(tmp_path):
    from desktop.io.flightcsv import describe_duplicate_times

    log = read_flight_csv(_write(tmp_path, H + "0,1,1\n1,1,1\n"))
    assert log.duplicate_times == [] and describe_duplicate_times(log.duplicate_times) is None
