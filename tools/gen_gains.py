"""Compute the fixed Kalman gains and write them as integers to ``shared/gains_table.py``.

Model (seed, chapter 3): state x = (altitude, velocity, acceleration), constant-acceleration
transition A = [[1, T, T^2/2], [0, 1, T], [0, 0, 1]], measurements of altitude (barometer) and
acceleration (accelerometer): H_both = [[1,0,0],[0,0,1]], H_baro = [[1,0,0]], H_accel = [[0,0,1]].

Two families of gains:

``seed``
    The seed's recursion reproduced exactly: P = I, 20 iterations of K = P H' (H P H' + R)^-1,
    P = (I - K H) P, P = A P A' + Q, with R = diag(35.8229, 0.0012), Q = diag(0, 0, 1), T = 0.05 s.
    Only for T = 0.05 s (the seed samples at 20 Hz); used to replicate the seed's study.

``project``
    Converged (steady-state) gains for every sample rate the board supports. The method follows
    from observability: observable filters from scipy's discrete algebraic Riccati solver,
    cross-checked against the limit of the Riccati recursion; the accelerometer-only filter, whose
    altitude and velocity are unobservable (no stabilising Riccati solution), from the limit of
    the recursion alone. Noise parameters (SI units), chosen as AltOS chose them after years of
    flights (docs/DESIGN.md D12):

    - process noise: continuous white jerk, spectral density SIGMA_JERK^2 (m^2/s^5), discretised
      exactly: Q = q [[T^5/20, T^4/8, T^3/6], [T^4/8, T^3/3, T^2/2], [T^3/6, T^2/2, T]].
      It lets the acceleration state follow motor burn-out and drag changes within ~0.2 s.
    - barometer: SIGMA_ALT_M = 6 m. Real parts are quieter (0.1-1 m RMS, docs/SENSORS.md
      and DESIGN.md D12), but their errors are dominated by transients (ejection, av-bay venting,
      transonic static-pressure error) that 6 m covers; the seed's simulated barometer has 5.985 m.
    - accelerometer: SIGMA_ACCEL_MPS2 = 2 m/s^2: noise, vibration and the unknown tilt between the
      rocket's axis and the vertical.

Run ``python tools/gen_gains.py`` to rewrite the table, ``--check`` to verify the committed one
(every gain within one least significant bit),
``--print-seed`` to print the seed's K at T = 0.05 s.
"""

import argparse
import functools
import math
import runpy
import sys
import textwrap
from pathlib import Path

import numpy as np
import scipy.linalg

ROOT = Path(__file__).resolve().parent.parent
if str(ROOT) not in sys.path:  # run as a script: make the project's packages importable
    sys.path.insert(0, str(ROOT))
from desktop.study.baselines import SEED_R, seed_kalman_gain  # noqa: E402  (the seed paper's recursion)

OUT = ROOT / "shared" / "gains_table.py"

SIGMA_JERK = 2.0  # sqrt of white-jerk spectral density, m/s^2.5 (AltOS sigma_m)
SIGMA_ALT_M = 6.0
SIGMA_ACCEL_MPS2 = 2.0
# Coast (after burnout) adds an accelerometer-bias state. A constant bias b makes the
# three-state filter's velocity err by about 2.5 s * b at 100 Hz (-0.8 m/s^2 on the TeleMetrum
# logs: 0.2 s early apogee); the seed's floor quantisation is a -2.19 m/s^2 bias. The bias walks
# at SIGMA_BIAS m/s^2 per sqrt(s) so it settles within the first seconds of coast; in coast
# the accelerometer is trusted more (its vibration and tilt error fall once the motor is out).
SIGMA_BIAS = 0.3
SIGMA_ACCEL_COAST_MPS2 = 1.0
SIGMA_JERK_COAST = 2.0
# Late coast (vertical speed below the state machine's LATE_COAST speed, 30 m/s): the vertical
# acceleration is -g - (D/m) v_z/|v|; drag D/m at 30 m/s is 0.3 m/s^2 for a 1 kg, 40 mm rocket
# and about 1.4 m/s^2 for a 100 g, 25 mm one, and it vanishes at apogee. So "-g" is used as a
# pseudo-measurement of the acceleration with SIGMA_GRAVITY m/s^2, in place of the accelerometer,
# whose bias and tilt no longer matter.
SIGMA_GRAVITY_MPS2 = 2.0
# A quiet barometer (a modern part behind a good static port: BMP390, MS5611, about 0.5 m of noise)
# is trusted more near apogee: the PROJECT_LOW_NOISE table's late-coast gains assume this noise.
# There, model errors (drag of a light rocket, weathercocking in wind) are larger than the noise,
# and 6 m gains let them make apogee 0.1-0.25 s late (the C6 Monte-Carlo, docs/BENCHMARKS.md).
SIGMA_ALT_LOW_NOISE_M = 2.0
RATES_HZ = (10, 20, 25, 50, 100, 200)

# Integer gain format: K ~= m / 2**s with |m| < 2**14 and 14 <= s <= 28, the domain in which
# shared/kalman.py's rounded product stays within 31 bits: a 14-bit mantissa for any |K| < 1.
MANTISSA_BITS = 14
SHIFT_MIN = 14
SHIFT_MAX = 28

H_BOTH = np.array([[1.0, 0.0, 0.0], [0.0, 0.0, 1.0]])
H_BARO = np.array([[1.0, 0.0, 0.0]])
H_ACCEL = np.array([[0.0, 0.0, 1.0]])


def transition(t_s):
    """State transition A for a step of ``t_s`` seconds, shape (3, 3)."""
    return np.array([[1.0, t_s, t_s * t_s / 2.0], [0.0, 1.0, t_s], [0.0, 0.0, 1.0]])


def white_jerk_q(t_s, sigma_jerk=SIGMA_JERK):
    """Process noise of a continuous white-jerk model over one step, shape (3, 3)."""
    t = t_s
    return sigma_jerk**2 * np.array([
        [t**5 / 20, t**4 / 8, t**3 / 6],
        [t**4 / 8, t**3 / 3, t**2 / 2],
        [t**3 / 6, t**2 / 2, t],
    ])


def seed_gain(h=H_BOTH, r=SEED_R):
    """The seed paper's MATLAB recursion at its T = 0.05 s, for the measurement rows ``h``."""
    return seed_kalman_gain(R=r, H=h)


# The Riccati solution must agree with the doubled recursion to this relative tolerance (both are
# accurate to about 1e-12 at every supported rate; a disagreement means one of them failed).
CROSS_CHECK_RTOL = 1e-9
MAX_DOUBLINGS = 64


class GainError(RuntimeError):
    """The gain computation failed: no convergence, or the two methods disagree."""


def is_observable(a, h):
    """True when (A, H) is observable: rank [H; HA; HA^2; ...] equals the number of states.

    Every eigenvalue of the constant-acceleration model lies on the unit circle, so observable
    and detectable coincide: observable filters have a stabilising Riccati solution."""
    n = a.shape[0]
    rows = [h]
    for _ in range(n - 1):
        rows.append(rows[-1] @ a)
    return bool(np.linalg.matrix_rank(np.vstack(rows)) == n)


def kalman_gain(p_prior, h, r):
    """K = P- H' (H P- H' + R)^-1."""
    return p_prior @ h.T @ np.linalg.inv(h @ p_prior @ h.T + r)


def doubled_recursion_prior(a, q, h, r, rtol=1e-15):
    """Limit of the Riccati recursion P-(k+1) = A (P-(k) - P-(k) H' (H P-(k) H' + R)^-1 H P-(k)) A' + Q
    from P- = 0, taken 2**j steps at a time (the structure-preserving doubling algorithm: its j-th
    iterate is the recursion's 2**j-th, so it converges in tens of steps where the plain recursion
    needs tens of thousands at 200 Hz). Only for observable filters, whose P- stays bounded."""
    eye = np.eye(a.shape[0])
    a_k = a.T.copy()
    g_k = h.T @ np.linalg.inv(r) @ h
    p_k = q.copy()
    for _ in range(MAX_DOUBLINGS):
        w = np.linalg.inv(eye + g_k @ p_k)
        p_next = p_k + a_k.T @ p_k @ w @ a_k
        g_k = g_k + a_k @ w @ g_k @ a_k.T
        a_k = a_k @ w @ a_k
        if np.max(np.abs(p_next - p_k)) <= rtol * np.max(np.abs(p_next)):
            return p_next
        p_k = p_next
    raise GainError("the doubled Riccati recursion did not converge")


def recursion_gain(a, q, h, r, tol=1e-14, max_iterations=500000):
    """Limit of the gain of the Riccati recursion from P = 0, one step at a time (as AltOS's
    make-kalman computes its gains). It converges for the accelerometer-only filter too, whose
    altitude and velocity are unobservable: their variances grow without bound, the gains do not."""
    p = np.zeros_like(a)
    eye = np.eye(a.shape[0])
    k_prev = None
    for _ in range(max_iterations):
        p_prior = a @ p @ a.T + q
        k = kalman_gain(p_prior, h, r)
        p = (eye - k @ h) @ p_prior
        if k_prev is not None and np.max(np.abs(k - k_prev)) < tol:
            return k
        k_prev = k
    raise GainError("the Riccati recursion did not converge")


def converged_gain(a, q, h, r):
    """Steady-state Kalman gain of the model (A, Q, H, R), shape (n_states, n_meas).

    Observable filters: scipy's discrete Riccati solver, cross-checked against the doubled
    recursion (GainError if they disagree). The accelerometer-only filter has unobservable
    altitude and velocity, so its Riccati equation has no stabilising solution (scipy's solver
    fails on it, with an exception type that depends on the BLAS kernel): its gain is the limit of
    the plain recursion."""
    if not is_observable(a, h):
        return recursion_gain(a, q, h, r)
    k = kalman_gain(scipy.linalg.solve_discrete_are(a.T, h.T, q, r), h, r)
    k_check = kalman_gain(doubled_recursion_prior(a, q, h, r), h, r)
    if not np.allclose(k, k_check, rtol=CROSS_CHECK_RTOL, atol=CROSS_CHECK_RTOL * np.max(np.abs(k))):
        raise GainError("Riccati solver and recursion disagree: %r vs %r" % (k.tolist(), k_check.tolist()))
    return k


def steady_gain(t_s, h, r, sigma_jerk=SIGMA_JERK):
    """Converged gain of the three-state white-jerk model at a step of ``t_s`` seconds."""
    return converged_gain(transition(t_s), white_jerk_q(t_s, sigma_jerk), h, r)


def iterated_gain(t_s, h, r, sigma_jerk=SIGMA_JERK):
    """The same model's gain from the plain recursion (for tests: the reference for steady_gain)."""
    return recursion_gain(transition(t_s), white_jerk_q(t_s, sigma_jerk), h, r)


def bias_gain(t_s, sigma_jerk=SIGMA_JERK_COAST, sigma_bias=SIGMA_BIAS, sigma_accel=SIGMA_ACCEL_COAST_MPS2):
    """Steady-state gain of the coast model with accelerometer bias, shape (4, 2).

    State (altitude, velocity, acceleration, accelerometer bias); the accelerometer measures
    acceleration + bias; the bias is a random walk of ``sigma_bias`` m/s^2 per sqrt(s).
    """
    a = np.eye(4)
    a[:3, :3] = transition(t_s)
    q = np.zeros((4, 4))
    q[:3, :3] = white_jerk_q(t_s, sigma_jerk)
    q[3, 3] = sigma_bias**2 * t_s
    h = np.array([[1.0, 0.0, 0.0, 0.0], [0.0, 0.0, 1.0, 1.0]])
    r = np.diag([SIGMA_ALT_M**2, sigma_accel**2])
    return converged_gain(a, q, h, r)


def project_gains(rate_hz, sigma_alt_late_m=SIGMA_ALT_M):
    """The gain matrices (both, baro, accel, coast-with-bias, late coast) of the project family at
    ``rate_hz``; ``sigma_alt_late_m`` is the barometer noise the late-coast gains assume."""
    t_s = 1.0 / rate_hz
    both = steady_gain(t_s, H_BOTH, np.diag([SIGMA_ALT_M**2, SIGMA_ACCEL_MPS2**2]))
    baro = steady_gain(t_s, H_BARO, np.array([[SIGMA_ALT_M**2]]))
    accel = steady_gain(t_s, H_ACCEL, np.array([[SIGMA_ACCEL_MPS2**2]]))
    late = steady_gain(t_s, H_BOTH, np.diag([sigma_alt_late_m**2, SIGMA_GRAVITY_MPS2**2]))
    return both, baro, accel, bias_gain(t_s), late


def seed_family_gains():
    """Seed gains in the same (both, baro, accel) layout; the seed has only the combined filter,
    so its single-sensor gains (used when one reading is missing) come from the same recursion."""
    both = seed_gain()
    baro = seed_gain(H_BARO, SEED_R[:1, :1])
    accel = seed_gain(H_ACCEL, SEED_R[1:, 1:])
    # the seed estimates no bias and has no late-coast model: those blocks repeat its combined
    # gain (with a zero bias row)
    return both, baro, accel, np.vstack([both, np.zeros((1, 2))]), both


def to_fixed(k):
    """Encode a gain as (mantissa, shift) with k ~= mantissa / 2**shift."""
    if not -1.0 < k < 1.0:
        raise ValueError("gain %r out of the supported range (-1, 1)" % k)
    if k == 0.0:
        return 0, SHIFT_MAX
    shift = MANTISSA_BITS - 1 - math.floor(math.log2(abs(k)))
    shift = max(SHIFT_MIN, min(SHIFT_MAX, shift))
    mantissa = int(round(k * 2**shift))
    if abs(mantissa) >= 2**MANTISSA_BITS:  # rounding carried into the next power of two
        shift -= 1
        mantissa = int(round(k * 2**shift))
    if shift < SHIFT_MIN or abs(mantissa) >= 2**MANTISSA_BITS:
        raise ValueError("gain %r cannot be encoded with shift >= %d" % (k, SHIFT_MIN))
    return mantissa, shift


def encode_row(rate_hz, both, baro, accel, coast, late):
    """One table row: rate, then (m, s) for both K00 K01 K10 K11 K20 K21, baro K0..2, accel K0..2,
    coast K00 K01 K10 K11 K20 K21 K30 K31, late coast K00 K01 K10 K11 K20 K21."""
    row = [rate_hz]
    for matrix in (both, baro, accel, coast, late):
        for value in matrix.reshape(-1):
            row.extend(to_fixed(float(value)))
    return tuple(row)


def _row_lines(row):
    # A list literal made a tuple at import, not a tuple literal: MicroPython's freezer (mpy-tool)
    # stores an int outside +-8191 inside a constant tuple as a long-int object, and every gain
    # product with it then allocates. The ints of a list literal are compiled as small ints.
    text = textwrap.wrap("tuple(%r)," % (list(row),), 96, break_on_hyphens=False)
    return ["    " + text[0]] + ["           " + line for line in text[1:]]


def decode(mantissa, shift):
    return mantissa / 2.0**shift


@functools.lru_cache(maxsize=1)
def expected_tables():
    """The rows of each table of shared/gains_table.py, as the current computation gives them
    (computed once per process: tuples, so the cached value cannot be changed)."""
    return {
        "PROJECT": tuple(encode_row(rate, *project_gains(rate)) for rate in RATES_HZ),
        "PROJECT_LOW_NOISE": tuple(encode_row(rate, *project_gains(rate, SIGMA_ALT_LOW_NOISE_M))
                                   for rate in RATES_HZ),
        "SEED": (encode_row(20, *seed_family_gains()),),
    }


def same_gain(m_s, expected_m_s):
    """True when two (mantissa, shift) encodings agree within one least significant bit.

    The last bit of a gain may differ between BLAS kernels (the floating-point sums run in another
    order); a carry across a power of two changes the shift, so then the values are compared."""
    (m, s), (m_exp, s_exp) = m_s, expected_m_s
    if s == s_exp:
        return abs(m - m_exp) <= 1
    return abs(decode(m, s) - decode(m_exp, s_exp)) <= 2.0**-min(s, s_exp)


def table_differences(tables, expected=None):
    """Descriptions of every gain in ``tables`` (name -> rows, as shared/gains_table.py holds them)
    that differs from the computed one by more than one least significant bit; empty if current."""
    expected = expected_tables() if expected is None else expected
    problems = []
    for name, rows in expected.items():
        have = tables.get(name)
        if have is None or [row[0] for row in have] != [row[0] for row in rows]:
            problems.append("%s: rates %s, expected %s" % (
                name, None if have is None else [row[0] for row in have], [row[0] for row in rows]))
            continue
        for row, row_exp in zip(have, rows, strict=True):
            if len(row) != len(row_exp):
                problems.append("%s at %d Hz: %d entries, expected %d" % (
                    name, row[0], len(row), len(row_exp)))
                continue
            for i in range(1, len(row), 2):
                if not same_gain(row[i:i + 2], row_exp[i:i + 2]):
                    problems.append("%s at %d Hz, gain %d: %r, expected %r" % (
                        name, row[0], (i - 1) // 2, tuple(row[i:i + 2]), tuple(row_exp[i:i + 2])))
    return problems


def render():
    """Text of shared/gains_table.py."""
    lines = [
        '"""Kalman gains as integers. GENERATED by tools/gen_gains.py: do not edit by hand.',
        "",
        "Regenerate with ``python tools/gen_gains.py``; tests/shared/test_gains.py checks this file is",
        "current.",
        "",
        "Row layout (one row per sample rate): RATE_HZ, then 12 gains as (mantissa, shift) pairs,",
        "each gain K = mantissa / 2**shift (|mantissa| < 2**14, 14 <= shift <= 28):",
        "",
        "- combined filter (barometer + accelerometer), row-major K00 K01 K10 K11 K20 K21:",
        "  state (altitude, velocity, acceleration) x measurement (altitude, acceleration);",
        "- barometer only: K0 K1 K2;  accelerometer only: K0 K1 K2;",
        "- coast, with accelerometer bias (4 states x 2 measurements): K00 K01 K10 K11 K20 K21 K30 K31;",
        "- late coast, barometer + gravity pseudo-measurement: K00 K01 K10 K11 K20 K21.",
        "",
        "Gains are dimensionless multipliers on innovations because altitude, velocity and",
        "acceleration share one length unit in shared/kalman.py (1/16 mm) and the row's rate fixes T.",
        "",
        "PROJECT: steady-state gains; white-jerk process noise sigma_jerk = %g m/s^2.5," % SIGMA_JERK,
        "sigma_alt = %g m, sigma_accel = %g m/s^2; coast: sigma_accel = %g m/s^2, bias random walk"
        % (SIGMA_ALT_M, SIGMA_ACCEL_MPS2, SIGMA_ACCEL_COAST_MPS2),
        "sigma_bias = %g m/s^2 per sqrt(s); late coast: sigma_gravity = %g m/s^2."
        % (SIGMA_BIAS, SIGMA_GRAVITY_MPS2),
        "PROJECT_LOW_NOISE: the same, but the late-coast gains assume sigma_alt = %g m"
        % SIGMA_ALT_LOW_NOISE_M,
        "(configuration baro_noise = 'low').",
        "SEED: the seed's recursion (P = I, 20 iterations, R = diag(35.8229, 0.0012),",
        "Q = diag(0, 0, 1), T = 0.05 s); only for 20 Hz; no bias or late-coast model (its combined gains).",
        '"""',
        "",
        "# Rows are tuple([...]) so that frozen firmware keeps every gain a small int (_row_lines).",
        "PROJECT = (",
    ]
    for rate in RATES_HZ:
        lines.extend(_row_lines(encode_row(rate, *project_gains(rate))))
    lines.append(")")
    lines.append("")
    lines.append("PROJECT_LOW_NOISE = (")
    for rate in RATES_HZ:
        lines.extend(_row_lines(encode_row(rate, *project_gains(rate, SIGMA_ALT_LOW_NOISE_M))))
    lines.append(")")
    lines.append("")
    lines.append("SEED = (")
    lines.extend(_row_lines(encode_row(20, *seed_family_gains())))
    lines.append(")")
    lines.append("")
    return "\n".join(lines)


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--check", action="store_true", help="exit 1 if shared/gains_table.py is stale")
    parser.add_argument("--print-seed", action="store_true", help="print the seed's K at T = 0.05 s")
    args = parser.parse_args(argv)
    if args.print_seed:
        np.set_printoptions(precision=10)
        print("seed K (T = 0.05 s, 20 iterations):")
        print(seed_gain())
        for rate in RATES_HZ:
            both = project_gains(rate)[0]
            print("project K both at %d Hz:" % rate)
            print(both)
        return 0
    if args.check:
        problems = table_differences(runpy.run_path(str(OUT))) if OUT.exists() else ["file missing"]
        if problems:
            print("%s is stale (run python tools/gen_gains.py): %s" % (OUT, "; ".join(problems)))
            return 1
        print("%s is current (every gain within one least significant bit)" % OUT)
        return 0
    OUT.write_text(render())
    print("wrote", OUT)
    return 0


if __name__ == "__main__":
    sys.exit(main())
