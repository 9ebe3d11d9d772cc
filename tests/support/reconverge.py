"""Re-convergence of the integer filter from large disturbances, against the linear filter its
gains describe (docs/DESIGN.md, "A filter that always re-converges").

Truth: a drag-free ballistic arc (the models' own physics: constant acceleration -g), read
without noise, so that every error left is the filter's own. The integer filter runs with the
gates and clamps the flight computer sets for the model (``FLIGHT_SETTINGS``); the linear
reference propagates the same error through e <- (I - K H) A e in floats.
"""

import numpy as np

from shared.detector import HAVE_BARO, HAVE_BOTH, MODEL_BIAS, MODEL_GRAVITY, MODEL_PLAIN, Detector
from shared.flight import COAST_ACC_MAX_Q4, GATE_ACC_MMPS2, GATE_ALT_MM
from shared.gains_table import PROJECT

G_MMPS2 = 9807
SETTLE_ALT_MM = 1000  # settled: within 1 m and 0.5 m/s, and staying there
SETTLE_VEL_MMPS = 500

# model name: (detector model, readings, gains slice start, measurement rows, bias state)
MODELS = {
    "plain": (MODEL_PLAIN, HAVE_BOTH),
    "coast_bias": (MODEL_BIAS, HAVE_BOTH),
    "late_coast": (MODEL_GRAVITY, HAVE_BOTH),
    "baro_only": (MODEL_PLAIN, HAVE_BARO),
}


def _k(row, start, n):
    return [row[start + 2 * i] / 2.0 ** row[start + 2 * i + 1] for i in range(n)]


def linear_matrices(model, rate_hz=100):
    """(F, n_states): the linear error propagation e <- F e of the model at rate_hz."""
    row = next(r for r in PROJECT if r[0] == rate_hz)
    t = 1.0 / rate_hz
    a3 = np.array([[1, t, t * t / 2], [0, 1, t], [0, 0, 1]])
    if model == "coast_bias":
        a = np.eye(4)
        a[:3, :3] = a3
        k = np.array(_k(row, 25, 8)).reshape(4, 2)
        h = np.array([[1, 0, 0, 0], [0, 0, 1, 1]])
    elif model == "late_coast":
        a = a3
        k = np.array(_k(row, 41, 6)).reshape(3, 2)
        h = np.array([[1, 0, 0], [0, 0, 1]])
    elif model == "baro_only":
        a = a3
        k = np.array(_k(row, 13, 3)).reshape(3, 1)
        h = np.array([[1, 0, 0]])
    else:
        a = a3
        k = np.array(_k(row, 1, 6)).reshape(3, 2)
        h = np.array([[1, 0, 0], [0, 0, 1]])
    return (np.eye(len(a)) - k @ h) @ a, len(a)


def linear_errors(model, d_alt_m, d_vel_mps, seconds, rate_hz=100):
    """(alt error m, velocity error m/s) per sample of the linear filter from the disturbance."""
    f, n = linear_matrices(model, rate_hz)
    e = np.zeros(n)
    e[0], e[1] = d_alt_m, d_vel_mps
    out = np.empty((int(seconds * rate_hz), 2))
    for i in range(len(out)):
        e = f @ e
        out[i] = e[0], e[1]
    return out


def integer_errors(model, d_alt_m, d_vel_mps, seconds, rate_hz=100, v0_mps=150.0, h0_m=1500.0):
    """The same for the integer Detector with the flight computer's gates and clamps."""
    det_model, have = MODELS[model]
    det = Detector(PROJECT, _NoRule())
    det.model = det_model
    det.gate_alt_mm = GATE_ALT_MM
    det.gate_acc_mmps2 = GATE_ACC_MMPS2
    if model != "plain":
        det.acc_max_q4 = COAST_ACC_MAX_Q4
    kf = det.kf
    dt_us = 1000000 // rate_hz
    h_mm, v_mmps = int(h0_m * 1000), int(v0_mps * 1000)
    kf.reset(h_mm + int(d_alt_m * 1000), v_mmps + int(d_vel_mps * 1000), -G_MMPS2)
    n = int(seconds * rate_hz)
    out = np.empty((n, 2))
    for i in range(1, n + 1):
        t = i / rate_hz
        truth_h = h0_m * 1000 + v0_mps * 1000 * t - G_MMPS2 * t * t / 2
        truth_v = v0_mps * 1000 - G_MMPS2 * t
        det.step(dt_us, int(round(truth_h)), -G_MMPS2, have, False)
        out[i - 1] = ((kf.alt_q4 / 16 - truth_h) / 1000, (kf.vel_q4 / 16 - truth_v) / 1000)
    return out


class _NoRule:
    history = False  # (shared/apogee.py)

    def reset(self):
        pass

    def update(self, kf, rate_hz, enabled):
        return False


def settling_s(errors, rate_hz=100):
    """Time after which |alt error| <= 1 m and |velocity error| <= 0.5 m/s for good (None if
    not within the record)."""
    ok = (np.abs(errors[:, 0]) <= SETTLE_ALT_MM / 1000) & (np.abs(errors[:, 1]) <= SETTLE_VEL_MMPS / 1000)
    if not ok[-1]:
        return None
    bad = np.flatnonzero(~ok)
    return (bad[-1] + 2) / rate_hz if len(bad) else 1 / rate_hz


def velocity_peaks(errors):
    """Largest |velocity error| of each stretch of one sign, in order, above the settle band."""
    v = errors[:, 1]
    peaks = []
    sign = 0
    for x in v:
        s = 1 if x > 0 else -1
        if s != sign:
            peaks.append(0.0)
            sign = s
        peaks[-1] = max(peaks[-1], abs(x))
    return [p for p in peaks if p > SETTLE_VEL_MMPS / 1000]


def peaks_halve(errors):
    """After the first stretch (the disturbance itself, until the filter's correction reverses the
    error's sign), each velocity-error peak is at most half the one before."""
    peaks = velocity_peaks(errors)[1:]
    return all(b <= 0.5 * a for a, b in zip(peaks, peaks[1:], strict=False))
