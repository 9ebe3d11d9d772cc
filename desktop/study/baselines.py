"""Comparison apogee detectors of the seed study (seed chapters 2, 3 and 5), float, vectorised.

Every filter is causal, as on a board: the output at sample k depends on samples 0..k only
(``scipy.signal.lfilter`` runs forward with an initial state set from the first sample; the Kalman
filter is a forward recursion). Arrays are (n_flights, n_samples) with one shared ``time_s``.

Filters (settings at the nominal 20 Hz of the seed's data; the IIR filters are designed for the
measured sample rate):

- ``boxcar``: moving average of the last ``BOXCAR_WINDOW`` = 40 samples (2.0 s at 20 Hz). The
  seed never gives its window. Figure 2.2 shows its boxcar putting apogee about a second late
  (10-11 s -> 11-12 s); a causal 40-sample average lags a parabola's peak by 19.5 samples (0.98 s)
  and, with the seed's rule, detects 1.0 s late on average on the study's flights. (A 60-sample
  window reproduces Figure 5.2's 1.52 s / 14.9 m/s instead; docs/SEED_STUDY.md has the sweep.)
- ``butterworth``: ``scipy.signal.butter(4, 1.0 Hz)``: 4th order, -3 dB at 1 Hz (group delay
  about 0.3 s at low frequency). Passes the noise below 1 Hz, so its output wanders by +-1-2 m:
  the seed's Figure 2.3 "peaks and troughs".
- ``elliptic``: ``scipy.signal.ellip(4, 1 dB, 40 dB, 1.0 Hz)``: 4th order, 1 dB passband ripple,
  40 dB stopband, passband edge 1 Hz. Even order: the DC gain is -1 dB (0.891), the seed's
  "attenuated" output (Figure 2.4); ripples like the Butterworth.
- ``seed_kalman``: the seed's float Kalman filter, state [s, v, a], measurements [altitude,
  kinematic acceleration = accel_mps2 - 9.81], constant gains from the seed's recursion (P = I,
  20 iterations, ``K = P H'/(H P H' + R)``, ``P = (I - K H) P``, ``P = A P A' + Q``, R =
  diag(35.8229, 0.0012), Q = diag(0, 0, 1), T = 0.05), started at [alt(1); 0; accel(1)].

Decision rules (both armed only after the lockout below):

- ``seed``: the seed's chapter-5 rule: the position falls for three consecutive samples,
  x[k] < x[k-1] < x[k-2].
- ``velocity``: the estimated velocity is below zero (the Kalman filter's v state; for the other
  filters the first difference of the output). Armed after the climb, the first negative value
  is the zero crossing.

Lockout (the same for every baseline): a detection is accepted only at samples at least
``LOCKOUT_S`` = 1.0 s after launch, launch being the first sample whose ``accel_mps2`` exceeds
``LAUNCH_THRESHOLD_MPS2`` = 30 m/s^2 (about 3 g: specific force, causal, and never reached on the
pad, which reads at most 9.81). Every Monte-Carlo draw burns out by 0.9 s, so this is also "no
detection before burnout". Without it the seed's rule trips at once: the Kalman filter starts at
rest and the first altitude samples are noise.

Every detector is registered in ``METHODS`` (name -> callable(time_s, altitude_m, accel_mps2) ->
detection times in s, NaN when none), the interface of ``desktop.study.detect.METHODS``.
"""

from __future__ import annotations

import numpy as np

from desktop.sim.seed_model import SEED_PAPER_G0_MPS2

# scipy.signal is imported in the functions that use it: it takes seconds to import, and
# ``python -m desktop --help`` imports this module.

LAUNCH_THRESHOLD_MPS2 = 30.0
LOCKOUT_S = 1.0
BOXCAR_WINDOW = 40
BUTTER_ORDER, BUTTER_CUTOFF_HZ = 4, 1.0
ELLIP_ORDER, ELLIP_RP_DB, ELLIP_RS_DB, ELLIP_CUTOFF_HZ = 4, 1.0, 40.0, 1.0

# The seed's Kalman filter (chapter 3).
SEED_T_S = 0.05
SEED_R = np.diag([35.8229, 0.0012])
SEED_Q = np.diag([0.0, 0.0, 1.0])
SEED_H = np.array([[1.0, 0.0, 0.0], [0.0, 0.0, 1.0]])
SEED_ITERATIONS = 20


def _2d(x) -> np.ndarray:
    x = np.asarray(x, dtype=np.float64)
    return x[None, :] if x.ndim == 1 else x


def sample_period_s(time_s) -> float:
    """The median sample period of ``time_s``."""
    return float(np.median(np.diff(np.asarray(time_s, dtype=np.float64))))


# --------------------------------------------------------------------------------------------------
# Filters


def _lfilter_from_first(b, a, x: np.ndarray) -> np.ndarray:
    """Causal ``lfilter`` along samples, started in steady state on each flight's first sample
    (so that a non-zero ground level does not ring the filter)."""
    from scipy import signal

    x = _2d(x)
    zi = signal.lfilter_zi(b, a)[None, :] * x[:, :1]
    y, _ = signal.lfilter(b, a, x, axis=1, zi=zi)
    return y


def boxcar(x, window: int = BOXCAR_WINDOW) -> np.ndarray:
    """Causal moving average of the last ``window`` samples (the first sample repeated before the
    start)."""
    window = int(window)
    if window < 1:
        raise ValueError("window must be >= 1")
    return _lfilter_from_first(np.full(window, 1.0 / window), np.array([1.0]), x)


def butter_coefficients(fs_hz: float, order: int = BUTTER_ORDER, cutoff_hz: float = BUTTER_CUTOFF_HZ):
    from scipy import signal

    return signal.butter(order, cutoff_hz, btype="low", fs=fs_hz)


def ellip_coefficients(fs_hz: float, order: int = ELLIP_ORDER, rp_db: float = ELLIP_RP_DB,
                       rs_db: float = ELLIP_RS_DB, cutoff_hz: float = ELLIP_CUTOFF_HZ):
    from scipy import signal

    return signal.ellip(order, rp_db, rs_db, cutoff_hz, btype="low", fs=fs_hz)


def butterworth(x, fs_hz: float, **kw) -> np.ndarray:
    b, a = butter_coefficients(fs_hz, **kw)
    return _lfilter_from_first(b, a, x)


def elliptic(x, fs_hz: float, **kw) -> np.ndarray:
    b, a = ellip_coefficients(fs_hz, **kw)
    return _lfilter_from_first(b, a, x)


def seed_transition(T: float = SEED_T_S) -> np.ndarray:
    return np.array([[1.0, T, 0.5 * T * T], [0.0, 1.0, T], [0.0, 0.0, 1.0]])


def seed_kalman_gain(T: float = SEED_T_S, R=SEED_R, Q=SEED_Q, iterations: int = SEED_ITERATIONS, H=SEED_H):
    """The seed's gain recursion, as its MATLAB listing (P = I; 20 times: K = P H'/(H P H' + R);
    P = (I - K H) P; P = A P A' + Q). Returns K (3 x rows of H). The one implementation:
    tools/gen_gains.py uses it for the SEED table (also with the barometer or accelerometer row
    of H alone)."""
    A = seed_transition(T)
    P = np.eye(3)
    K = None
    for _ in range(iterations):
        # MATLAB's B/C is B * inv(C), solved as (C' \\ B')'.
        K = np.linalg.solve((H @ P @ H.T + R).T, (P @ H.T).T).T
        P = (np.eye(3) - K @ H) @ P
        P = A @ P @ A.T + Q
    return K


def seed_kalman(altitude_m, accel_kinematic_mps2, T: float = SEED_T_S, K=None):
    """The seed's Kalman filter over flights: returns the estimates (s, v, a), each
    (n_flights, n_samples). ``estimate(:,1) = [alt(1); 0; accel(1)]``, then for each sample
    ``x = A x; x = x + K ([alt; accel] - H x)``.

    Flight by flight in plain Python floats: the same IEEE operations as a vectorised form, and
    about 50 times faster for one long flight (the rocket study's case)."""
    alt = _2d(altitude_m)
    acc = _2d(accel_kinematic_mps2)
    if K is None:
        K = seed_kalman_gain(T)
    gains = tuple(float(x) for x in np.asarray(K, dtype=np.float64).ravel())
    out = np.empty((3,) + alt.shape)
    for i in range(alt.shape[0]):
        out[:, i, :] = _seed_kalman_flight(alt[i].tolist(), acc[i].tolist(), float(T), gains)
    return out[0], out[1], out[2]


def _seed_kalman_flight(alt, acc, T, gains):
    """One flight of ``seed_kalman``: lists of floats in, [s, v, a] lists out."""
    k00, k01, k10, k11, k20, k21 = gains
    half_t2 = 0.5 * T * T
    s, v, a = alt[0], 0.0, acc[0]
    s_out, v_out, a_out = [s], [v], [a]
    for k in range(1, len(alt)):
        sp = s + T * v + half_t2 * a
        vp = v + T * a
        r_alt = alt[k] - sp
        r_acc = acc[k] - a
        s = sp + k00 * r_alt + k01 * r_acc
        v = vp + k10 * r_alt + k11 * r_acc
        a = a + k20 * r_alt + k21 * r_acc
        s_out.append(s)
        v_out.append(v)
        a_out.append(a)
    return s_out, v_out, a_out


def first_difference(x) -> np.ndarray:
    """x[k] - x[k-1] (0 at k = 0): the velocity sign of a filter without a velocity state."""
    x = _2d(x)
    d = np.zeros_like(x)
    d[:, 1:] = x[:, 1:] - x[:, :-1]
    return d


# --------------------------------------------------------------------------------------------------
# Lockout and decision rules


def launch_times(time_s, accel_mps2, threshold_mps2: float = LAUNCH_THRESHOLD_MPS2) -> np.ndarray:
    """Per flight, the time of the first sample with accel_mps2 > threshold (NaN if none)."""
    acc = _2d(accel_mps2)
    above = acc > threshold_mps2
    return first_true_time(time_s, above)


def armed_mask(time_s, accel_mps2, lockout_s: float = LOCKOUT_S,
               threshold_mps2: float = LAUNCH_THRESHOLD_MPS2) -> np.ndarray:
    """(n_flights, n_samples) True where a detection may be accepted: lockout_s after launch."""
    t = np.asarray(time_s, dtype=np.float64)
    launch = launch_times(t, accel_mps2, threshold_mps2)
    with np.errstate(invalid="ignore"):
        return t[None, :] >= (launch + lockout_s)[:, None] - 1e-9


def first_true_time(time_s, mask) -> np.ndarray:
    """Per row, time_s at the first True of ``mask`` (NaN when none)."""
    mask = np.asarray(mask, dtype=bool)
    mask = mask[None, :] if mask.ndim == 1 else mask
    t = np.asarray(time_s, dtype=np.float64)
    k = np.argmax(mask, axis=1)
    hit = mask[np.arange(mask.shape[0]), k]
    return np.where(hit, t[k], np.nan)


def seed_rule_mask(x) -> np.ndarray:
    """True at k where x[k] < x[k-1] < x[k-2] (the seed's three falling samples)."""
    x = _2d(x)
    m = np.zeros(x.shape, dtype=bool)
    m[:, 2:] = (x[:, 2:] < x[:, 1:-1]) & (x[:, 1:-1] < x[:, :-2])
    return m


def velocity_rule_mask(v) -> np.ndarray:
    """True where the velocity estimate is below zero."""
    return _2d(v) < 0.0


def detect_seed_rule(time_s, x, armed) -> np.ndarray:
    return first_true_time(time_s, seed_rule_mask(x) & armed)


def detect_velocity_rule(time_s, v, armed) -> np.ndarray:
    return first_true_time(time_s, velocity_rule_mask(v) & armed)


# --------------------------------------------------------------------------------------------------
# Registered methods: callable(time_s, altitude_m, accel_mps2) -> detection times (s), NaN if none


def _filtered(kind: str, time_s, altitude_m):
    if kind == "boxcar":
        return boxcar(altitude_m)
    fs = 1.0 / sample_period_s(time_s)
    if kind == "butterworth":
        return butterworth(altitude_m, fs)
    if kind == "elliptic":
        return elliptic(altitude_m, fs)
    raise ValueError(kind)


def _seed_kalman_states(time_s, altitude_m, accel_mps2):
    # The seed's T = .05; a differently sampled log gets gains for its own (rounded) period.
    T = round(sample_period_s(time_s), 4)
    return seed_kalman(altitude_m, _2d(accel_mps2) - SEED_PAPER_G0_MPS2, T=T)


def _make_filter_method(kind: str, rule: str):
    def method(time_s, altitude_m, accel_mps2):
        y = _filtered(kind, time_s, altitude_m)
        armed = armed_mask(time_s, accel_mps2)
        if rule == "seed":
            return detect_seed_rule(time_s, y, armed)
        return detect_velocity_rule(time_s, first_difference(y), armed)

    method.__name__ = f"{kind}_{rule}"
    method.__doc__ = f"{kind} low-pass on altitude, {rule} rule, {LOCKOUT_S} s lockout after launch."
    return method


def seed_kalman_seed_rule(time_s, altitude_m, accel_mps2):
    """The seed's Kalman filter with its three-falling-samples rule on the position estimate."""
    s, _, _ = _seed_kalman_states(time_s, altitude_m, accel_mps2)
    return detect_seed_rule(time_s, s, armed_mask(time_s, accel_mps2))


def seed_kalman_velocity_rule(time_s, altitude_m, accel_mps2):
    """The seed's Kalman filter, apogee when its velocity state goes negative."""
    _, v, _ = _seed_kalman_states(time_s, altitude_m, accel_mps2)
    return detect_velocity_rule(time_s, v, armed_mask(time_s, accel_mps2))


METHODS = {
    "boxcar/seed": _make_filter_method("boxcar", "seed"),
    "boxcar/velocity": _make_filter_method("boxcar", "velocity"),
    "butterworth/seed": _make_filter_method("butterworth", "seed"),
    "butterworth/velocity": _make_filter_method("butterworth", "velocity"),
    "elliptic/seed": _make_filter_method("elliptic", "seed"),
    "elliptic/velocity": _make_filter_method("elliptic", "velocity"),
    "seed-kalman/seed": seed_kalman_seed_rule,
    "seed-kalman/velocity": seed_kalman_velocity_rule,
}
