"""Sensor models: each part's noise, resolution and clipping measured from its output, lags, the
transonic error, board timing, determinism by seed, and the written flight CSV.

No RocketPy here: the analytic drag-free trajectory is the truth.
"""

import dataclasses
import math
from pathlib import Path

import numpy as np
import pytest

from desktop.io.flightcsv import read_flight_csv
from desktop.sim.sensor_models import (
    ACCEL_PARTS,
    BARO_PARTS,
    IDEAL_BOARD,
    BoardConfig,
    SensorProfileError,
    TransonicModel,
    make_record,
    parse_profile,
    profile_names,
    transonic_discrepancy,
    transonic_window,
    write_record,
)
from desktop.sim.trajectory import G0, drag_free_vertical, isa_altitude

ROOT = Path(__file__).resolve().parents[2]
QUIET = dataclasses.replace(IDEAL_BOARD)  # no jitter, drops, drift, port lag or transonic error


@pytest.fixture(scope="module")
def flight():
    # 25 g boost for 1 s, then drag-free coast: reaches Mach 0.7
    return drag_free_vertical(thrust_n=26 * G0 * 1.0, burn_time_s=1.0, dry_mass_kg=1.0, site_altitude_m=200.0)


@pytest.fixture(scope="module")
def supersonic():
    # 60 g for 1 s: Mach ~1.7, through the transonic window on the way up and down
    return drag_free_vertical(thrust_n=61 * G0, burn_time_s=1.0, dry_mass_kg=1.0, site_altitude_m=0.0,
                              end_time_s=20.0)


def test_sensor_profiles_parse_any_case_and_reject_unknown_parts():
    p = parse_profile("BMP390+LSM6DSO")
    assert p.name == "bmp390+lsm6dso" and p.baro is BARO_PARTS["bmp390"]
    assert parse_profile("ideal").name == "ideal+ideal"
    assert len(profile_names()) == 3 * 3 + 1
    for bad in ("bmp390", "bmp390+", "x+adxl375", "bmp390+adxl376", ""):
        with pytest.raises(SensorProfileError, match="unknown sensor profile") as err:
            parse_profile(bad)
        assert "\n" not in str(err.value) and "adxl375" in str(err.value)


def test_ideal_record_matches_truth(flight):
    rec = make_record(flight, "ideal", seed=1, board=QUIET)
    c = rec.columns
    t = c["time_s"]
    alt = isa_altitude(c["pressure_pa"]) - 200.0
    # the ideal baro converts at 1 kHz and the board reads the latest conversion: <= 1 ms old
    vmax = np.max(np.abs(flight.velocity_mps))
    assert np.max(np.abs(alt - c["true_altitude_m"])) < vmax * 0.001 + 0.01
    truth = np.interp(t, flight.time_s, flight.accel_mps2, left=flight.pad_accel_mps2)
    burn_edge = np.abs(t - 1.0) < 0.002
    assert np.max(np.abs(c["accel_mps2"] - truth)[~burn_edge]) <= 0.0005 + 1e-9
    assert np.all(c["accel_mps2"][t < 0] == pytest.approx(G0, abs=0.0005))
    assert np.array_equal(c["true_altitude_m"][t < 0], np.zeros(np.sum(t < 0)))
    assert np.allclose(np.diff(t), 0.01, atol=1e-9)


@pytest.mark.parametrize("name", [n for n in BARO_PARTS if n != "ideal"])
def test_baro_noise_and_resolution(flight, name):
    part = BARO_PARTS[name]
    board = dataclasses.replace(QUIET, pad_s=300.0)
    rec = make_record(flight, f"{name}+ideal", seed=2, board=board)
    p = rec.pressure_pa[rec.time_s < -1.0]
    assert np.std(p) == pytest.approx(math.hypot(part.noise_pa, part.resolution_pa / math.sqrt(12)), rel=0.1)
    steps = p / part.resolution_pa
    assert np.allclose(steps, np.round(steps), atol=1e-6)
    offset = rec.parameters["baro_offset_pa"]
    assert abs(offset) <= part.offset_pa
    assert np.mean(p) == pytest.approx(flight.ground_pressure_pa + offset, abs=0.3)
    # conversions at the part's ODR: a 100 Hz board sees each value about 100/ODR times (two
    # conversions can also round to the same value)
    changes = np.count_nonzero(np.diff(p)) / (len(p) / 100.0)
    assert 0.7 * part.odr_hz < changes <= 1.01 * part.odr_hz
    ground = float(rec.metadata["ground_pressure_pa"])
    assert ground == pytest.approx(flight.ground_pressure_pa + offset, abs=0.01)


@pytest.mark.parametrize("name", [n for n in ACCEL_PARTS if n != "ideal"])
def test_accel_noise_resolution_bias(flight, name):
    part = ACCEL_PARTS[name]
    board = dataclasses.replace(QUIET, pad_s=300.0)
    rec = make_record(flight, f"ideal+{name}", seed=3, board=board)
    a = rec.accel_mps2[rec.time_s < -1.0]
    expect = math.hypot(part.noise_rms_mps2, part.resolution_mps2 / math.sqrt(12))
    assert np.std(a) == pytest.approx(expect, rel=0.1)
    lsb = a / part.resolution_mps2
    assert np.allclose(lsb, np.round(lsb), atol=1e-6)
    bias, scale = rec.parameters["accel_bias_mps2"], rec.parameters["accel_scale_error"]
    assert abs(bias) <= part.offset_mps2 and abs(scale) <= part.scale_error
    assert np.mean(a) == pytest.approx(G0 * (1 + scale) + bias, abs=3 * expect / math.sqrt(len(a)) + 0.002)


@pytest.mark.parametrize("name,clips", [("mpu6050", True), ("lsm6dso", True), ("adxl375", False)])
def test_accel_holds_at_full_scale_only_on_parts_below_the_boost(flight, name, clips):
    part = ACCEL_PARTS[name]
    rec = make_record(flight, f"ideal+{name}", seed=4, board=QUIET)
    a = rec.accel_mps2
    top = math.floor(part.full_scale_mps2 / part.resolution_mps2) * part.resolution_mps2
    peak = 26 * G0 * (1 + rec.parameters["accel_scale_error"]) + rec.parameters["accel_bias_mps2"]
    if clips:
        assert np.max(a) == pytest.approx(top)
        assert np.sum(a == np.max(a)) > 50  # held at full scale through the boost
        assert top < 16.01 * G0
    else:
        assert np.max(a) < top
        assert np.max(a) == pytest.approx(peak, abs=5 * part.noise_rms_mps2 + part.resolution_mps2)


def test_lagging_barometer_reads_low_by_speed_times_lag_while_climbing(flight):
    """A lagging barometer reads a higher pressure (lower altitude) while climbing: about v * tau."""
    coast = (flight.time_s > 2.0) & (flight.time_s < 6.0)
    v = float(np.mean(flight.velocity_mps[coast]))
    board = dataclasses.replace(QUIET, port_lag_s=0.02)
    for name in ("bmp388", "ms5611"):
        part = BARO_PARTS[name]
        quiet_part = dataclasses.replace(part, noise_pa=0.0, offset_pa=0.0, resolution_pa=0.001)
        prof = dataclasses.replace(parse_profile(f"{name}+ideal"), baro=quiet_part)
        rec = make_record(flight, prof, seed=5, board=board)
        t = rec.time_s
        m = (t > 2.0) & (t < 6.0)
        err = (isa_altitude(rec.pressure_pa[m]) - 200.0) - rec.columns["true_altitude_m"][m]
        # lag of the two first-order filters + half a conversion period (zero-order hold)
        expect = -v * (part.lag_s + 0.02 + 0.5 / part.odr_hz)
        assert np.mean(err) == pytest.approx(expect, rel=0.15), name


def test_accel_bandwidth_lag(flight):
    rec = make_record(flight, "ideal+mpu6050", seed=6, board=dataclasses.replace(QUIET, pad_s=1.0))
    t, a = rec.time_s, rec.accel_mps2
    after = a[(t > 1.0) & (t < 1.2)]  # thrust stops at 1.0 s: the 44 Hz filter decays in ~4 ms
    assert after[0] > after[-1]
    assert np.all(np.abs(a[(t > 1.1) & (t < 2.0)]) < 1.0)


def test_transonic_window_is_one_from_mach_1_to_1_2_and_zero_outside_0_9_to_1_3():
    m = np.linspace(0, 2, 2001)
    w = transonic_window(m)
    assert np.all(w[m <= 0.9] == 0) and np.all(w[m >= 1.3] == 0)
    assert np.all(w[(m >= 1.0) & (m <= 1.2)] == 1)
    assert np.all(np.diff(w[(m > 0.9) & (m < 1.0)]) > 0) and np.all(np.diff(w[(m > 1.2) & (m < 1.3)]) < 0)
    assert np.max(np.abs(np.diff(w))) < 0.02  # smooth


@pytest.mark.parametrize("c", [0.03, -0.02])
def test_transonic_error_fixed_c(supersonic, c):
    board = dataclasses.replace(QUIET, transonic=TransonicModel(c=c))
    rec = make_record(supersonic, "ideal", seed=7, board=board)
    t = rec.time_s
    truth_p = np.interp(t, supersonic.time_s, supersonic.pressure_pa)
    q = np.interp(t, supersonic.time_s, supersonic.dynamic_pressure_pa)
    mach = np.interp(t, supersonic.time_s, supersonic.mach)
    expect = c * q * transonic_window(mach)
    err = rec.pressure_pa - truth_p
    m = t > 0
    # within the ideal baro's 1 ms hold: d(p + error)/dt * 1 ms
    slack = np.abs(np.gradient(truth_p + expect, t)) * 0.0011 + 0.01
    assert np.all(np.abs(err[m] - expect[m]) <= slack[m])
    assert np.max(np.abs(expect)) > 1000  # the error is big where it acts
    assert rec.metadata["transonic_c"] == c


def test_transonic_c_drawn_from_range(supersonic):
    te = TransonicModel()
    cs = [make_record(supersonic, "ideal", seed=s, board=dataclasses.replace(QUIET, transonic=te)).parameters[
        "transonic_c"] for s in range(40)]
    assert all(te.c_range[0] <= abs(c) <= te.c_range[1] for c in cs)
    assert any(c > 0 for c in cs) and any(c < 0 for c in cs)


def test_board_timing_drops_and_read_errors(flight):
    board = BoardConfig(rate_hz=50.0, pad_s=60.0, jitter_s=0.001, drop_probability=0.05, stall_rate_hz=0.05,
                        read_error_probability=0.02)
    rec = make_record(flight, "bmp390+lsm6dso", seed=8, board=board)
    t = rec.time_s
    assert t[0] >= -60.0 and t[-1] <= flight.end_time_s
    dt = np.diff(t)
    assert np.all(dt > 0)
    assert np.median(dt) == pytest.approx(0.02, abs=0.002)
    expected = (flight.end_time_s + 60.0) * 50.0
    assert 0.88 < len(t) / expected < 0.97  # ~5 % dropped + stalls
    assert np.max(dt) > 0.06  # a stall or several drops in a row
    for col in ("pressure_pa", "accel_mps2"):
        frac = np.mean(np.isnan(rec.columns[col]))
        assert 0.01 < frac < 0.03


@pytest.mark.parametrize("rate", [20.0, 100.0])
def test_record_sample_rate_follows_board_rate_and_out_of_range_refused(flight, rate):
    rec = make_record(flight, "ms5611+adxl375", seed=9, board=BoardConfig(rate_hz=rate, pad_s=5.0))
    assert np.median(np.diff(rec.time_s)) == pytest.approx(1.0 / rate, rel=0.02)
    with pytest.raises(ValueError, match="allowed 20 to 100 Hz"):
        make_record(flight, "ideal", board=BoardConfig(rate_hz=200.0))


def test_same_seed_gives_the_same_record_another_seed_another(flight):
    a = make_record(flight, "bmp388+adxl375", seed=42)
    b = make_record(flight, "bmp388+adxl375", seed=42)
    c = make_record(flight, "bmp388+adxl375", seed=43)
    for k in a.columns:
        assert np.array_equal(a.columns[k], b.columns[k], equal_nan=True), k
    assert a.metadata == b.metadata
    assert len(a.time_s) != len(c.time_s) or not np.array_equal(a.pressure_pa, c.pressure_pa, equal_nan=True)


def test_written_record_reads_back_with_its_columns_and_metadata(tmp_path, flight):
    rec = make_record(flight, "bmp390+lsm6dso", seed=12,
                      board=BoardConfig(pad_s=10.0, read_error_probability=0.01))
    path = tmp_path / "f.csv"
    write_record(path, rec)
    log = read_flight_csv(path)
    assert log.columns == ["time_s", "pressure_pa", "accel_mps2", "true_altitude_m", "true_velocity_mps"]
    m = log.metadata
    for key in ("true_apogee_time_s", "true_apogee_m", "rocket", "sensor_profile", "seed",
                "ground_pressure_pa", "site_altitude_m", "derived_columns", "source"):
        assert key in m, key
    assert float(m["true_apogee_m"]) == pytest.approx(flight.apogee_m, abs=0.001)
    assert m["seed"] == "12" and m["sensor_profile"] == "bmp390+lsm6dso"
    assert np.array_equal(np.isnan(log.pressure_pa), np.isnan(rec.pressure_pa))
    assert np.allclose(log.accel_mps2, rec.accel_mps2, atol=5e-5, equal_nan=True)
    assert np.allclose(log.extra["true_altitude_m"], rec.columns["true_altitude_m"], atol=5e-4)


def test_transonic_analysis_of_341_005():
    path = ROOT / "tests" / "data" / "flights" / "altos" / "2012-09-29-serial-341-flight-005.csv"
    if not path.exists():
        pytest.skip("AltOS flight 341-005 not in tests/data")
    s = transonic_discrepancy(read_flight_csv(path))["summary"]
    assert 1.05 < s["max_mach"] < 1.12
    assert 1.3 < s["mach1_time_s"] < 1.45
    assert 0.015 < s["jump_c"] < 0.03
    assert 0.04 < s["peak_c"] < 0.055 and 3000 < s["peak_dp_pa"] < 4000
    te = TransonicModel()
    assert te.c_range[1] >= s["peak_c"]  # the default range covers the measured peak
