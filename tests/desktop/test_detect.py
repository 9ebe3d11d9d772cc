"""The integer detectors in the seed study: the exact shared/ code, against the seed's float
filter and against the study's goals, on simulated seed flights."""

import numpy as np
import pytest

from desktop.sim.seed_model import simulate_monte_carlo
from desktop.study import baselines, detect


@pytest.fixture(scope="module")
def flights():
    return simulate_monte_carlo(300, 7, pad_s=2.0)


def test_integer_seed_replica_matches_the_float_seed_filter(flights):
    b = flights
    integer = detect.int_kalman_seed(b.time_s, b.altitude_m, b.accel_mps2)
    floating = baselines.seed_kalman_seed_rule(b.time_s, b.altitude_m, b.accel_mps2)
    # same gains, same rule, same lockout: the fixed-point rounding moves no detection
    assert np.array_equal(integer, floating)


def test_flight_computer_detects_every_flight_and_never_early(flights):
    b = flights
    d = detect.flight_computer(b.time_s, b.altitude_m, b.accel_mps2)
    assert not np.isnan(d).any()  # every flight detected
    err = d - b.true_apogee_time_s
    assert (err > -1.0).all()  # never more than 1 s early


def test_flight_computer_meets_the_study_accuracy_goals(flights):
    # issue 3's goals. The seed's accelerometer holds one reading through the whole boost (a flat
    # 160 m/s^2 floored to 3 m/s^2 steps), which the health rule for a part of unknown range reads
    # as clipped at full scale: the filter then holds its acceleration at or above the reading
    # (shared/flight.py), as a clip proves; left at the value it had when the clip began, the
    # study's mean was 0.094 s and its p95 0.203 s
    b = flights
    err = detect.flight_computer(b.time_s, b.altitude_m, b.accel_mps2) - b.true_apogee_time_s
    assert np.abs(err).mean() <= 0.06
    assert np.percentile(np.abs(err), 95) <= 0.15


def test_detections_are_identical_in_parallel_and_serial(flights, monkeypatch):
    b = flights
    parallel = detect.flight_computer(b.time_s, b.altitude_m[:80], b.accel_mps2[:80])
    monkeypatch.setattr(detect.os, "cpu_count", lambda: 1)
    serial = detect.flight_computer(b.time_s, b.altitude_m[:80], b.accel_mps2[:80])
    assert np.array_equal(parallel, serial, equal_nan=True)
