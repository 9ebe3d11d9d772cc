"""OpenRocket export import: units, derived columns, events, errors, and the round trip
RocketPy trajectory -> OpenRocket export -> import -> the same sensor record."""

from pathlib import Path

import numpy as np
import pytest

from desktop.cli import main as run_cli
from desktop.errors import InputFileError
from desktop.io.flightcsv import read_flight_csv
from desktop.io.openrocket import OpenRocketError, read_openrocket, write_openrocket_export
from desktop.io.rocket_file import load_rocket
from desktop.sim.sensor_models import make_record
from desktop.sim.trajectory import G0, drag_free_vertical, isa_pressure, simulate_rocket

ROOT = Path(__file__).resolve().parents[2]
SAMPLE = ROOT / "examples" / "openrocket" / "sample_export.csv"


@pytest.fixture(scope="module")
def rocketpy_traj():
    return simulate_rocket(load_rocket(ROOT / "examples" / "rockets" / "j360_sport.toml"), after_main_s=3.0)


def export(tmp_path, header, rows, name="e.csv", pre=("# Simulation 1 (Up to date)", "#"), events=()):
    lines = list(pre) + ["# " + header] + list(events) + rows
    p = tmp_path / name
    p.write_text("\n".join(lines) + "\n", encoding="utf-8")
    return p


# --------------------------------------------------------------------------------------------------
# Round trip


@pytest.mark.slow  # a RocketPy flight
def test_round_trip_same_record(tmp_path, rocketpy_traj):
    tr = rocketpy_traj
    path = tmp_path / "fine.csv"
    write_openrocket_export(tr, path, times=np.round(np.arange(0.0, tr.end_time_s, 0.002), 6))
    back = read_openrocket(path)
    assert back.site_altitude_m == pytest.approx(tr.site_altitude_m, abs=0.01)
    assert back.apogee_time_s == pytest.approx(tr.apogee_time_s, abs=1e-3)
    assert back.apogee_m == pytest.approx(tr.apogee_m, abs=0.01)
    assert back.drogue_time_s == pytest.approx(tr.drogue_time_s, abs=1e-3)
    assert back.main_time_s == pytest.approx(tr.main_time_s, abs=1e-3)
    assert back.burnout_time_s == pytest.approx(tr.burnout_time_s, abs=1e-3)
    r1 = make_record(tr, "bmp390+lsm6dso", seed=11)
    r2 = make_record(back, "bmp390+lsm6dso", seed=11)
    c1, c2 = r1.columns, r2.columns
    assert np.array_equal(c1["time_s"], c2["time_s"])
    assert np.array_equal(np.isnan(c1["pressure_pa"]), np.isnan(c2["pressure_pa"]))
    # within resampling error: one resolution step of pressure, one LSB or so of acceleration,
    # except within 0.1 s of a parachute opening (a shock shorter than the export's step)
    dp = np.abs(c1["pressure_pa"] - c2["pressure_pa"])
    assert np.nanmax(dp) <= 0.34
    da = np.abs(c1["accel_mps2"] - c2["accel_mps2"])
    shock = np.zeros(len(da), dtype=bool)
    for name in ("drogue_open", "main_open"):
        shock |= np.abs(c1["time_s"] - tr.events[name]) < 0.1
    assert np.nanmax(da[~shock]) < 0.2
    assert np.nanmedian(da) < 0.006
    assert np.max(np.abs(c1["true_altitude_m"] - c2["true_altitude_m"])) < 0.01
    assert r1.metadata["true_apogee_m"] == pytest.approx(r2.metadata["true_apogee_m"], abs=0.01)


@pytest.mark.slow  # a RocketPy flight
def test_round_trip_variable_step_and_imperial(tmp_path, rocketpy_traj):
    tr = rocketpy_traj
    metric, imperial = tmp_path / "m.csv", tmp_path / "i.csv"
    write_openrocket_export(tr, metric)
    write_openrocket_export(tr, imperial, imperial=True)
    a, b = read_openrocket(metric), read_openrocket(imperial)
    steps = np.diff(np.loadtxt(metric, delimiter=",", comments="#", usecols=0))
    assert steps.min() < 0.01 and steps.max() > 0.05  # variable time step
    for name in ("altitude_m", "velocity_mps", "accel_mps2", "pressure_pa", "mach"):
        x, y = getattr(a, name), getattr(b, name)
        assert np.allclose(x, y, rtol=1e-5, atol=1e-3 * max(1.0, float(np.max(np.abs(x))))), name
    # the default variable step: resampling error stays small away from the thrust spike and deployments
    ok = (a.time_s > 0.2) & (a.time_s < tr.drogue_time_s)
    assert np.max(np.abs(a.accel_mps2[ok] - tr.accel_mps2[: len(a.time_s)][ok])) < 2.0
    assert np.max(np.abs(a.altitude_m - tr.altitude_m[: len(a.time_s)])) < 0.05


def test_sample_export_example():
    text = SAMPLE.read_text(encoding="utf-8")
    assert "written by desktop/io/openrocket.py from a RocketPy trajectory" in text
    tr = read_openrocket(SAMPLE)
    assert tr.site_altitude_m == pytest.approx(150.0, abs=0.01)
    assert 1200 < tr.apogee_m < 1500
    assert tr.drogue_time_s is not None and tr.main_time_s is not None
    assert tr.time_s[0] == 0.0 and tr.dt_s == pytest.approx(0.001)
    assert tr.accel_mps2[0] == pytest.approx(G0 * np.sin(np.radians(86.0)), abs=1e-4)  # on the pad
    assert any("thrust, drag and mass" in d for d in tr.derived_columns)


# --------------------------------------------------------------------------------------------------
# Units and derived columns


@pytest.mark.parametrize("unit,value,si", [
    ("m", 100.0, 100.0), ("ft", 100.0, 30.48), ("km", 0.1, 100.0),
])
def test_altitude_in_m_ft_or_km_converts_to_metres(tmp_path, unit, value, si):
    p = export(tmp_path, f"Time (s),Altitude ({unit})", ["0,0", f"1,{value}", f"2,{value * 2}"])
    tr = read_openrocket(p, site_altitude_m=0.0)
    assert tr.altitude_m[1000] == pytest.approx(si, rel=1e-9)


@pytest.mark.parametrize("column,unit,value,check", [
    ("Vertical velocity", "ft/s", 10.0, ("velocity_mps", 3.048)),
    ("Vertical velocity", "m/s", 10.0, ("velocity_mps", 10.0)),
    ("Air pressure", "mbar", 1000.0, ("pressure_pa", 100000.0)),
    ("Air pressure", "hPa", 1000.0, ("pressure_pa", 100000.0)),
    ("Air pressure", "Pa", 100000.0, ("pressure_pa", 100000.0)),
    ("Air pressure", "psi", 14.5, ("pressure_pa", 14.5 * 6894.757293168)),
    ("Air pressure", "inHg", 29.92, ("pressure_pa", 29.92 * 3386.389)),
    ("Mach number", "", 0.5, ("mach", 0.5)),
])
def test_velocity_pressure_and_mach_columns_convert_to_si(tmp_path, column, unit, value, check):
    rows = [f"{t},{t * 10},{value}" for t in (0, 1, 2)]
    p = export(tmp_path, f"Time (s),Altitude (m),{column} ({unit})", rows)
    tr = read_openrocket(p, site_altitude_m=0.0)
    attr, expect = check
    assert getattr(tr, attr)[500] == pytest.approx(expect, rel=1e-9)


@pytest.mark.parametrize("acc_unit,acc,force_unit,force,mass_unit,mass", [
    ("m/s²", 5.0, "N", 20.0, "kg", 2.0),
    ("m/s^2", 5.0, "N", 20.0, "g", 2000.0),
    ("ft/s²", 5.0 / 0.3048, "lbf", 20.0 / 4.4482216152605, "lb", 2.0 / 0.45359237),
    ("G", 5.0 / G0, "N", 20.0, "oz", 2.0 / 0.028349523125),
])
def test_force_mass_acceleration_units(tmp_path, acc_unit, acc, force_unit, force, mass_unit, mass):
    header = (f"Time (s),Altitude (m),Vertical velocity (m/s),Vertical acceleration ({acc_unit}),"
              f"Thrust ({force_unit}),Drag force ({force_unit}),Mass ({mass_unit})")
    rows = [f"{t},{2.5 * t * t + 1},{5 * t},{acc},{force},{force / 4},{mass}" for t in (0, 1, 2, 3)]
    p = export(tmp_path, header, rows, events=["# Event LIFTOFF occurred at t=0 seconds"])
    tr = read_openrocket(p, site_altitude_m=0.0)
    assert tr.accel_mps2[1500] == pytest.approx((20.0 - 5.0) / 2.0, rel=1e-9)  # (T - D) / m
    assert tr.thrust_n[1500] == pytest.approx(20.0) and tr.mass_kg[1500] == pytest.approx(2.0)


@pytest.mark.parametrize("unit,value,kelvin", [
    ("°C", 15.0, 288.15), ("°F", 59.0, 288.15), ("K", 288.15, 288.15),
])
def test_temperature_units_give_mach(tmp_path, unit, value, kelvin):
    rows = [f"{t},{t * 100},{t * 100},{value}" for t in (0, 1, 2)]
    p = export(tmp_path, f"Time (s),Altitude (m),Total velocity (m/s),Air temperature ({unit})", rows)
    tr = read_openrocket(p, site_altitude_m=0.0)
    assert tr.mach[1000] == pytest.approx(100.0 / np.sqrt(1.4 * 287.05287 * kelvin), rel=1e-6)
    assert "mach(from total velocity)" in tr.derived_columns


def test_minimal_export_derives_everything(tmp_path):
    ref = drag_free_vertical(thrust_n=200, burn_time_s=1.0, dry_mass_kg=2.0, site_altitude_m=300.0)
    t = np.round(np.arange(0, ref.end_time_s, 0.01), 6)
    rows = [f"{ti:.6g},{np.interp(ti, ref.time_s, ref.altitude_m):.9g}" for ti in t]
    p = export(tmp_path, "Time (s),Altitude (m)", rows,
               events=["# Event LAUNCH occurred at t=0 seconds", "# Event APOGEE occurred at t=9.0 seconds"])
    tr = read_openrocket(p, site_altitude_m=300.0)
    assert tr.site_altitude_m == 300.0
    assert tr.apogee_time_s == 9.0  # the export's event, as given
    assert tr.ground_pressure_pa == pytest.approx(isa_pressure(300.0))
    ok = tr.time_s > 0.05
    assert np.allclose(tr.pressure_pa, isa_pressure(300.0 + tr.altitude_m))
    assert np.max(np.abs(tr.velocity_mps[ok] - np.interp(tr.time_s[ok], ref.time_s, ref.velocity_mps))) < 1.0
    assert tr.pad_accel_mps2 == pytest.approx(G0)  # no orientation column: vertical
    assert tr.accel_mps2[500] == pytest.approx(100.0, rel=0.02)  # T/m during the burn
    coast = (tr.time_s > 1.5) & (tr.time_s < 10)
    assert np.max(np.abs(tr.accel_mps2[coast])) < 0.5  # vertical acceleration + g ~ 0 in free fall
    d = " ".join(tr.derived_columns)
    for part in ("true_velocity_mps(from altitude)", "pressure_pa(standard atmosphere)",
                 "vertical acceleration + g", "mach(from vertical velocity)"):
        assert part in d


def test_site_altitude_default(tmp_path):
    p = export(tmp_path, "Time (s),Altitude (m)", ["0,0", "1,10"])
    tr = read_openrocket(p)
    assert tr.site_altitude_m == 0.0
    assert any("assumed 0" in d for d in tr.derived_columns)
    q = export(tmp_path, "Time (s),Altitude (m),Air pressure (Pa)", ["0,0,95000", "1,10,94880"], name="q.csv")
    assert read_openrocket(q).site_altitude_m == pytest.approx(540.4, abs=0.5)


def test_formats_semicolon_nan_duplicates_and_plain_header(tmp_path):
    p = tmp_path / "s.csv"
    p.write_text("# Simulation\n# Time (s);Altitude (m);Vertical velocity (m/s)\n"
                 "0;0;0\n0,5;1,25;NaN\n0,5;1,25;5\n1;5;10\n# Event APOGEE occurred at t=1 seconds\n",
                 encoding="utf-8")
    tr = read_openrocket(p, site_altitude_m=0.0)
    assert tr.altitude_m[500] == pytest.approx(1.25) and tr.velocity_mps[500] == pytest.approx(5.0)
    q = tmp_path / "plain.csv"
    q.write_text("# comment\nTime (s),Altitude (m)\n0,0\n1,10\n", encoding="utf-8")
    assert read_openrocket(q, site_altitude_m=0.0).altitude_m[-1] == pytest.approx(10.0)
    r = tmp_path / "cp1252.csv"
    r.write_bytes("# Time (s),Altitude (m),Vertical acceleration (m/s²)\n0,0,0\n1,10,0\n".encode("cp1252"))
    assert read_openrocket(r, site_altitude_m=0.0).accel_mps2[0] == pytest.approx(G0)
    u = tmp_path / "unknown_cols.csv"
    u.write_text("# Time (s),Altitude (m),Stability margin calibers (\u200b),Roll rate (°/s)\n"
                 "0,0,NaN,0\n1,10,1.5,2\n", encoding="utf-8")
    assert read_openrocket(u, site_altitude_m=0.0).altitude_m[-1] == pytest.approx(10.0)


def test_time_base_kept(tmp_path):
    p = export(tmp_path, "Time (s),Altitude (m)", ["0.5,0", "1.5,10", "2.5,30"])
    tr = read_openrocket(p, site_altitude_m=0.0)
    assert tr.time_s[0] == 0.5 and tr.time_s[-1] == pytest.approx(2.5)
    rec = make_record(tr, "ideal", seed=1)
    assert rec.time_s[0] < 0  # pad samples before launch have negative times


# --------------------------------------------------------------------------------------------------
# Errors


@pytest.mark.parametrize("content,fragment", [
    ("# Time (s),Altitude (furlong)\n0,0\n1,1\n", "unknown unit 'furlong'"),
    ("# Time (s),Air pressure (bananas),Altitude (m)\n0,1,0\n1,1,1\n", "unknown unit 'bananas'"),
    ("# Time (s),Vertical velocity (m/s)\n0,0\n1,1\n", "needs 'Time' and 'Altitude'"),
    ("# Altitude (m),Mach number ()\n0,0\n1,1\n", "missing: time"),
    ("# Time (s),Altitude\n0,0\n1,1\n", "has no unit in parentheses"),
    ("# Time (s),Altitude (m)\n0,0\n1,1,2\n", "row has 3 fields"),
    ("# Time (s),Altitude (m)\n0,0\n1,abc\n", "'abc' is not a number"),
    ("# Time (s),Altitude (m)\n0,0\n2,1\n1,2\n", "time goes backwards"),
    ("# Time (s),Altitude (m)\n0,0\n", "fewer than 2 data rows"),
    ("# just a comment\n", "no column-name line"),
    ("0,0\n1,1\n", "data before any column-name line"),
    ("# Time (s),Altitude (m),Altitude (ft)\n0,0,0\n1,1,1\n", "appears twice"),
    ("# Time (s),Altitude (m),Thrust (N),Drag force (N),Mass (g)\n0,0,1,0,0\n1,1,1,0,0\n",
     "zero or negative"),
])
def test_malformed_export_gives_one_line_error_naming_file(tmp_path, content, fragment):
    p = tmp_path / "bad.csv"
    p.write_text(content, encoding="utf-8")
    with pytest.raises(OpenRocketError) as err:
        read_openrocket(p)
    msg = str(err.value)
    assert fragment in msg and "\n" not in msg and str(p) in msg


def test_missing_folder_or_binary_openrocket_export_is_an_input_error(tmp_path):
    with pytest.raises(InputFileError, match="OpenRocket export not found"):
        read_openrocket(tmp_path / "none.csv")
    with pytest.raises(InputFileError, match="is a directory"):
        read_openrocket(tmp_path)
    b = tmp_path / "b.csv"
    b.write_bytes(b"\x00\x01\x02")
    with pytest.raises(InputFileError, match="binary data"):
        read_openrocket(b)


# --------------------------------------------------------------------------------------------------
# The command


def test_simulate_from_an_openrocket_export_writes_record_and_metadata(tmp_path, capsys):
    out = tmp_path / "f.csv"
    rc = run_cli(["simulate", "--openrocket", str(SAMPLE), "--out", str(out), "--seed", "3",
                  "--sensors", "ms5611+adxl375", "--site-altitude", "150", "--after-main-s", "2"])
    assert rc == 0, capsys.readouterr().err
    log = read_flight_csv(out)
    m = log.metadata
    for key in ("true_apogee_time_s", "true_apogee_m", "rocket", "sensor_profile", "seed",
                "ground_pressure_pa", "site_altitude_m", "derived_columns", "source"):
        assert key in m
    assert m["sensor_profile"] == "ms5611+adxl375" and m["site_altitude_m"] == "150.0"
    assert "OpenRocket export" in m["source"] and "thrust, drag and mass" in m["derived_columns"]
    assert log.time_s[-1] == pytest.approx(float(m["true_main_time_s"]) + 2.0, abs=0.02)


@pytest.mark.parametrize("argv,fragment", [
    (["--openrocket", "{bad}", "--out", "x.csv"], "unknown unit 'furlong'"),
    (["--openrocket", "{missing}", "--out", "x.csv"], "OpenRocket export not found"),
    (["--openrocket", "{sample}", "--out", "x.csv", "--sensors", "nope"], "unknown sensor profile 'nope'"),
    (["--openrocket", "{sample}", "--out", "x.csv", "--site-altitude", "9000"], "allowed -500 to 5000 m"),
])
def test_simulate_openrocket_errors(tmp_path, capsys, argv, fragment):
    bad = tmp_path / "bad.csv"
    bad.write_text("# Time (s),Altitude (furlong)\n0,0\n1,1\n", encoding="utf-8")
    subst = {"{bad}": str(bad), "{missing}": str(tmp_path / "no.csv"), "{sample}": str(SAMPLE),
             "x.csv": str(tmp_path / "x.csv")}
    rc = run_cli(["simulate", *[subst.get(a, a) for a in argv]])
    err = capsys.readouterr().err
    assert rc == 2 and err.count("\n") == 1 and fragment in err
