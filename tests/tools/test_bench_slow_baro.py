"""tools/bench_slow_baro.py: the slow barometer's record (tests/support/fault_flight.py) and the
summary's counts."""

import numpy as np

from shared.detector import HAVE_ACCEL, HAVE_BARO
from tests.support.fault_flight import SUBSONIC_ROCKET, Faults, fly, slow_barometer
from tools import bench_slow_baro


def test_a_slow_barometer_keeps_every_accelerometer_reading_and_one_barometric_in_n():
    flight = fly(SUBSONIC_ROCKET, Faults())
    for hz, n in ((20, 5), (10, 10)):
        have = slow_barometer(flight, hz).have
        assert np.all(have & HAVE_ACCEL == flight.have & HAVE_ACCEL)
        baro = np.flatnonzero(have & HAVE_BARO)
        assert np.all(np.diff(baro) == n) and baro[0] == 0


def test_the_summary_counts_early_late_and_missing_drogues_per_rate():
    rows = [{"rate_hz": 20, "error_s": e} for e in (-0.6, -0.2, 0.1, 1.5, None)]
    rows.append({"rate_hz": 10, "error_s": 0.05})
    t20, t10 = bench_slow_baro.summary(rows, (20, 10))
    assert (t20["runs"], t20["early"], t20["late"], t20["none"]) == (5, 1, 1, 1)
    assert (t20["most_early_s"], t20["most_late_s"]) == (0.6, 1.5)
    assert t20["mean_abs_s"] == 0.6
    assert (t10["runs"], t10["early"], t10["mean_abs_s"]) == (1, 0, 0.05)
