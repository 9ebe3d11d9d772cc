"""The project's integer detectors, as the seed study calls them: the exact shared/ code the board
runs, one flight at a time (bit-identical to the board), spread over the machine's cores.

``METHODS``: name -> callable(time_s (n,), altitude_m (flights, n), accel_mps2 (flights, n)) ->
detection times (flights,), NaN when none; the interface of ``desktop.study.baselines.METHODS``.
``accel_mps2`` is specific force (+9.81 at rest); time is converted once to integer microseconds.

- ``int-kalman/seed-gains/seed``: the seed's gains and rule in integer fixed point, with the
  baselines' lockout (``desktop.study.baselines.armed_mask``), to compare like with like.
- ``int-kalman/velocity``: the project's gains and velocity rule, same lockout.
- ``flight-computer``: the whole state machine with its default configuration (pad
  calibration, proof of flight, coast gates); detection = its apogee event.
"""

import os
from concurrent.futures import ProcessPoolExecutor

import numpy as np

from desktop.study.baselines import armed_mask
from shared import gains_table
from shared.apogee import SeedRule, VelocityRule
from shared.config import load_config
from shared.detector import HAVE_BOTH, Detector
from shared.flight import EV_APOGEE, FlightComputer

_CHUNK = 64  # flights per task


def _integer_inputs(time_s, altitude_m, accel_mps2):
    t_us = np.rint(np.asarray(time_s, dtype=np.float64) * 1e6).astype(np.int64)
    dt_us = np.diff(t_us, prepend=t_us[0]).tolist()
    alt_mm = np.rint(np.asarray(altitude_m) * 1000).astype(np.int64)
    acc_mmps2 = np.rint(np.asarray(accel_mps2) * 1000).astype(np.int64)
    return dt_us, alt_mm, acc_mmps2


def _run_detector(args):
    """Plain filter + rule over a chunk of flights; returns detection sample indices (-1 = none)."""
    kind, dt_us, alt_mm, acc_mmps2, armed = args
    out = []
    for alt, acc, arm in zip(alt_mm.tolist(), acc_mmps2.tolist(), armed.tolist(), strict=True):
        if kind == "seed":
            det = Detector(gains_table.SEED, SeedRule())
        else:
            det = Detector(gains_table.PROJECT, VelocityRule())
        # the seed's filter takes kinematic acceleration: specific force - g (the seed's 9.81)
        det.start(alt[0], acc[0] - 9810)
        found = -1
        step = det.step
        for i in range(1, len(alt)):
            if step(dt_us[i], alt[i], acc[i] - 9810, HAVE_BOTH, arm[i]):
                found = i
                break
        out.append(found)
    return out


def _run_flight_computer(args):
    _kind, dt_us, alt_mm, acc_mmps2, _armed = args
    config = load_config()
    out = []
    for alt, acc in zip(alt_mm.tolist(), acc_mmps2.tolist(), strict=True):
        fc = FlightComputer(config)
        found = -1
        step = fc.step
        for i in range(len(alt)):
            step(dt_us[i], alt[i], acc[i], HAVE_BOTH)
            if fc.events & EV_APOGEE:
                found = i
                break
        out.append(found)
    return out


def _parallel(worker, kind, time_s, altitude_m, accel_mps2):
    dt_us, alt_mm, acc_mmps2 = _integer_inputs(time_s, altitude_m, accel_mps2)
    armed = armed_mask(time_s, accel_mps2)
    n = alt_mm.shape[0]
    tasks = [(kind, dt_us, alt_mm[i:i + _CHUNK], acc_mmps2[i:i + _CHUNK], armed[i:i + _CHUNK])
             for i in range(0, n, _CHUNK)]
    if len(tasks) > 1 and (os.cpu_count() or 1) > 1:
        with ProcessPoolExecutor(max_workers=os.cpu_count()) as pool:
            chunks = list(pool.map(worker, tasks))
    else:
        chunks = [worker(t) for t in tasks]
    index = np.array([i for chunk in chunks for i in chunk], dtype=np.int64)
    t = np.asarray(time_s, dtype=np.float64)
    return np.where(index >= 0, t[np.maximum(index, 0)], np.nan)


def int_kalman_seed(time_s, altitude_m, accel_mps2):
    """Seed gains and seed rule, integer fixed point, baselines' lockout."""
    return _parallel(_run_detector, "seed", time_s, altitude_m, accel_mps2)


def int_kalman_velocity(time_s, altitude_m, accel_mps2):
    """Project gains and velocity rule, integer fixed point, baselines' lockout."""
    return _parallel(_run_detector, "velocity", time_s, altitude_m, accel_mps2)


def flight_computer(time_s, altitude_m, accel_mps2):
    """The whole state machine (default configuration): its apogee event."""
    return _parallel(_run_flight_computer, "fc", time_s, altitude_m, accel_mps2)


METHODS = {
    "int-kalman/seed-gains/seed": int_kalman_seed,
    "int-kalman/velocity": int_kalman_velocity,
    "flight-computer": flight_computer,
}
