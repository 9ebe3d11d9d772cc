"""Float64 reference of the fixed-gain filter (tests only).

Same model, same gains (decoded from the integer table, so only the fixed-point rounding differs),
same per-sample logic as shared/detector.py: nearest-period gain row, n predictions across a gap,
then the correction for the readings present.
"""

import numpy as np

from tools.gen_gains import decode


def decode_row(row):
    """(rate_hz, K_both (3, 2), K_baro (3,), K_accel (3,)) from an integer gain row."""
    k = np.array([decode(row[i], row[i + 1]) for i in range(1, 25, 2)])
    return row[0], k[:6].reshape(3, 2), k[6:9], k[9:12]


def run_float(table, dts_us, alts_mm, accs_mmps2):
    """States (n, 3) in mm, mm/s, mm/s^2 for samples 1..n-1 (row 0 is the initial state)."""
    rows = [decode_row(r) for r in table]
    periods = np.array([1e6 / r[0] for r in rows])
    x = np.array([float(alts_mm[0]), 0.0, float(accs_mmps2[0])])
    out = np.zeros((len(dts_us), 3))
    out[0] = x
    for i in range(1, len(dts_us)):
        err = np.abs(1e6 // np.array([r[0] for r in rows]) - dts_us[i])
        j = int(np.argmin(err))
        rate, k_both, _, _ = rows[j]
        steps = max(1, int((dts_us[i] + periods[j] // 2) // periods[j]))
        t = 1.0 / rate
        a = np.array([[1, t, t * t / 2], [0, 1, t], [0, 0, 1]])
        for _ in range(steps):
            x = a @ x
        innov = np.array([alts_mm[i] - x[0], accs_mmps2[i] - x[2]])
        x = x + k_both @ innov
        out[i] = x
    return out
