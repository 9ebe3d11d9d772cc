"""Rewrite a flight log with its sensors on separate rows, as loggers write them.

Each function takes a ``desktop.io.flightcsv.FlightLog`` whose rows carry both a barometer and an
accelerometer reading and returns a new FlightLog of the same flight in another row layout that
docs/FLIGHT_CSV.md allows (an empty cell: no reading of that sensor on that row). Every reading
keeps its own time stamp unless the layout says otherwise; extra columns are dropped.
"""

import dataclasses

import numpy as np


def _log(log, time_us, pressure_pa, accel_mps2, name):
    time_us = np.asarray(time_us, dtype=np.int64)
    return dataclasses.replace(
        log, path=f"{log.path} ({name})", columns=["time_s", "pressure_pa", "accel_mps2"],
        time_us=time_us, time_s=time_us / 1e6, pressure_pa=np.asarray(pressure_pa, dtype=np.float64),
        altitude_m=None, accel_mps2=np.asarray(accel_mps2, dtype=np.float64), extra={},
        line_numbers=np.arange(len(time_us), dtype=np.int64))


def alternating(log):
    """The same rows, the barometer on even rows and the accelerometer on odd rows: each sensor at
    half the rate, the two interleaved."""
    even = np.arange(len(log)) % 2 == 0
    return _log(log, log.time_us, np.where(even, log.pressure_pa, np.nan),
                np.where(even, np.nan, log.accel_mps2), "alternating")


def merged_alternating(log):
    """``alternating(log)`` merged: each accelerometer reading moved onto the barometer row before
    it (its nearest), one row with both readings per pair."""
    n = len(log) - len(log) % 2
    return _log(log, log.time_us[0:n:2], log.pressure_pa[0:n:2], log.accel_mps2[1:n:2], "merged")


def mixed_rate(log, baro_period_s=0.05):
    """The accelerometer on every row, the barometer only on the rows at least ``baro_period_s``
    after its previous reading (a 20 Hz barometer beside a 100 Hz accelerometer)."""
    period_us = round(baro_period_s * 1e6)
    keep = np.zeros(len(log), dtype=bool)
    last = None
    for i, t in enumerate(log.time_us.tolist()):
        if last is None or t - last >= period_us:
            keep[i] = True
            last = t
    return _log(log, log.time_us, np.where(keep, log.pressure_pa, np.nan), log.accel_mps2,
                f"barometer every {baro_period_s:g} s")


def bursty(log, seed=0, longest_run_s=0.04):
    """One sensor per row, the sensors taking turns in runs of random length up to
    ``longest_run_s`` (a logger that drains each sensor's FIFO in turn): each sensor is silent for
    irregular stretches. A run holds at least one row."""
    rng = np.random.default_rng(seed)
    baro = np.zeros(len(log), dtype=bool)
    t = log.time_us.tolist()
    i, sensor = 0, True
    while i < len(t):
        end = t[i] + int(rng.integers(1, round(longest_run_s * 1e6) + 1))
        j = i + 1
        while j < len(t) and t[j] < end:
            j += 1
        baro[i:j] = sensor
        i = j
        sensor = not sensor
    return _log(log, log.time_us, np.where(baro, log.pressure_pa, np.nan),
                np.where(baro, np.nan, log.accel_mps2), "bursty")


def split_rows(log, offset_s=0.002):
    """Each row split in two: the accelerometer reading at its time, the barometer reading
    ``offset_s`` later on its own row (each sensor read in turn and stamped when read)."""
    offset_us = round(offset_s * 1e6)
    assert offset_us < int(np.min(np.diff(log.time_us)))
    n = len(log)
    time_us = np.empty(2 * n, dtype=np.int64)
    time_us[0::2] = log.time_us
    time_us[1::2] = log.time_us + offset_us
    pressure = np.full(2 * n, np.nan)
    pressure[1::2] = log.pressure_pa
    accel = np.full(2 * n, np.nan)
    accel[0::2] = log.accel_mps2
    return _log(log, time_us, pressure, accel, f"split {offset_s:g} s")
