"""The comparison methods of the rocket Monte-Carlo on one board record.

They get the barometric altitude (``shared.altitude``, relative to the pad pressure in the
metadata) and the axial accelerometer, a missing reading (an empty cell) held from the previous
sample, and the seed-paper study's lockout (1 s after the first sample above 30 m/s^2):

- ``seed-kalman/seed``: the paper's float Kalman filter with gains from its recursion at the
  record's (median) sample period, and its three-falling-samples rule.
- ``boxcar/seed``: moving average over the paper study's 2.0 s (40 samples at 20 Hz; the same
  duration in samples at the board's rate), the paper's rule.
- ``butterworth/seed``: 4th order, 1 Hz, designed at the record's rate, the paper's rule.
"""

from __future__ import annotations

import numpy as np

from desktop.sim.seed_model import SEED_PAPER_G0_MPS2
from desktop.study import baselines

COMPARISON_METHODS = ("seed-kalman/seed", "boxcar/seed", "butterworth/seed")
BOXCAR_SECONDS = baselines.BOXCAR_WINDOW * baselines.SEED_T_S  # 40 samples at 20 Hz = 2.0 s


def hold_missing(x: np.ndarray) -> np.ndarray:
    """Missing readings (NaN) hold the previous one (the first valid one before any)."""
    x = np.asarray(x, dtype=np.float64)
    ok = ~np.isnan(x)
    if ok.all():
        return x
    if not ok.any():
        return np.zeros_like(x)
    idx = np.where(ok, np.arange(len(x)), 0)
    np.maximum.accumulate(idx, out=idx)
    idx[: int(np.argmax(ok))] = int(np.argmax(ok))
    return x[idx]


def baseline_inputs(log, replay_result=None):
    """(time_s, altitude_m, accel_mps2) for the comparison methods: the barometric altitude the
    board computes (``shared.altitude`` on Pa x 16) above the pad pressure of the metadata, and the
    axial accelerometer; missing readings held. ``replay_result`` (of the same log, whose ground
    reference is the metadata's) saves converting the pressures again: its ``raw_agl_m`` is the same."""
    from desktop.review.replay import ground_alt_mm, readings

    if replay_result is not None and log.metadata_float("ground_pressure_pa") is not None:
        alt_m = np.asarray(replay_result.raw_agl_m, dtype=np.float64)
    else:
        _dt, alt_mm, _acc, _have = readings(log)
        alt = alt_mm.astype(np.float64)
        alt[np.isnan(log.pressure_pa)] = np.nan
        ground = ground_alt_mm(log)
        if ground is None:
            ground = float(np.nanmedian(alt[: max(1, len(alt) // 20)]))
        alt_m = (alt - ground) / 1000.0
    return log.time_s, hold_missing(alt_m), hold_missing(log.accel_mps2)


def boxcar_window(time_s) -> int:
    """Samples in the paper study's 2.0 s boxcar at this record's sample period."""
    return max(1, int(round(BOXCAR_SECONDS / baselines.sample_period_s(time_s))))


def comparison_altitudes(time_s, altitude_m, accel_mps2) -> dict:
    """The altitude (m) each comparison method's rule watches, name -> one value per sample."""
    t = np.asarray(time_s, dtype=np.float64)
    alt = np.asarray(altitude_m, dtype=np.float64)
    acc = np.asarray(accel_mps2, dtype=np.float64)
    period = baselines.sample_period_s(t)
    T = round(period, 4)  # as baselines' seed-kalman methods: gains for the (rounded) period
    return {
        "seed-kalman/seed": baselines.seed_kalman(alt, acc - SEED_PAPER_G0_MPS2, T)[0][0],
        "boxcar/seed": baselines.boxcar(alt, window=boxcar_window(t))[0],
        "butterworth/seed": baselines.butterworth(alt, 1.0 / period)[0],
    }


def comparison_methods(time_s, altitude_m, accel_mps2) -> dict:
    """Detection time (s, NaN if none) of each comparison method on one flight's record."""
    t = np.asarray(time_s, dtype=np.float64)
    armed = baselines.armed_mask(t, np.asarray(accel_mps2, dtype=np.float64))
    return {name: float(baselines.detect_seed_rule(t, altitude, armed)[0])
            for name, altitude in comparison_altitudes(time_s, altitude_m, accel_mps2).items()}
