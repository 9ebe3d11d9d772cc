"""Fixed-gain Kalman filter over barometric altitude and acceleration, in integer fixed point.

Portable: runs unchanged on MicroPython and CPython; no allocation per sample on MicroPython.

State (instance attributes, ints), all in one length unit, 1/16 mm (4 fractional bits):

- ``alt_q4`` altitude, mm * 16 (same datum as the altitude measurements)
- ``vel_q4`` vertical velocity, mm/s * 16
- ``acc_q4`` vertical (kinematic) acceleration, mm/s^2 * 16; 0 at rest

Range: every intermediate stays within +-2**30 (31-bit small ints on 32-bit boards):
measurements are clamped to +-MEAS_LIMIT_MM (33.5 km, 3.3 km/s^2), innovations to +-(2**27 - 1)
(8.4 km), altitude to +-ALT_LIMIT_Q4 (33.5 km), velocity and acceleration to +-RATE_LIMIT_Q4
(8.4 km/s, 855 g). With |K| < 1, no sum below leaves the range.

Gains come from ``shared/gains_table.py`` rows: ``row[0]`` is the sample rate in Hz (one
prediction is T = 1/rate s exactly), then (mantissa, shift) pairs, K = mantissa / 2**shift:
row[1:13] combined gains K00 K01 K10 K11 K20 K21, row[13:19] barometer-only K0 K1 K2,
row[19:25] accelerometer-only K0 K1 K2, row[25:41] coast gains with the accelerometer-bias state
K00 K01 K10 K11 K20 K21 K30 K31, row[41:53] late-coast gains (barometer + gravity) K00 .. K21.

``bias_q4`` (1/16 mm/s^2) is the accelerometer's estimated bias: every accelerometer innovation
is taken against acceleration + bias; only the coast gains update it.

The two-sensor corrections take one row per sensor: each sensor's column of gains comes from the
row of its own reading interval (a barometer read every 50 ms beside an accelerometer read every
10 ms). ``correct_baro_part`` / ``correct_accel_part`` apply one sensor's column of the two-sensor
gains alone: a reading on its own row while the other sensor keeps its schedule on other rows
(shared/detector.py), so that readings on separate rows add up to the correction of a row with both.
"""

try:
    from micropython import const
except ImportError:
    def const(x):
        return x

MEAS_LIMIT_MM = const(0x1FFFFFF)  # 2**25 - 1 mm: 33.5 km, or 3.3e7 mm/s^2 (3400 g)
ALT_LIMIT_Q4 = const(0x1FFFFFFF)  # 2**29 - 1 (1/16 mm): 33.5 km
RATE_LIMIT_Q4 = const(0x7FFFFFF)  # 2**27 - 1 (1/16 mm/s or mm/s^2): 8.4 km/s, 855 g
_G_Q4 = const(156912)  # standard gravity, 9806.65 mm/s^2 * 16
_INNOV_LIMIT = const(0x7FFFFFF)  # 2**27 - 1 (1/16 mm): 8.4 km, inside _mul_gain's domain
# An innovation below this (2 m, 2 m/s^2) times a mantissa (|m| < 2**14) plus the rounding stays
# within 31 bits: its products need no split (``_add2``)
_SMALL_INNOV = const(0x8000)


# MicroPython cost (docs/BENCHMARKS.md, "Per-sample cost"): a method call costs up to three times
# a module-level function call, every bytecode operation about a hundred instructions on a
# Cortex-M0. So the helpers of the corrections below are module-level functions taking the filter,
# and each does its work in as few operations as the exact arithmetic allows.


def _mul_gain(e, m, s):
    """round(e * m / 2**s), half up, for |e| < 2**28, |m| < 2**14, 14 <= s <= 28, in 31 bits.

    e = hi * 2**14 + lo with 0 <= lo < 2**14, so e*m + 2**(s-1) = (hi*m) * 2**14 + (lo*m + 2**(s-1)).
    The low sum's bits below 2**14 cannot reach the quotient by 2**s (s >= 14): its upper part
    joins the high product, and the sum is then divided by the remaining 2**(s-14). Exactly rounded
    (a truncating product biases every correction by about one unit, which the slow velocity loop
    turns into centimetres of altitude error); every intermediate is below 2**29.
    """
    return ((e >> 14) * m + (((e & 0x3FFF) * m + (1 << (s - 1))) >> 14)) >> (s - 14)


def _baro_innovation(kf, alt_mm):
    """The barometric innovation (alt << 4) - alt_q4, the reading clamped to +-MEAS_LIMIT_MM and
    the result to +-_INNOV_LIMIT (|alt_q4| <= 2**29 keeps the difference inside 31 bits), then
    weighted (Mach de-weighting)."""
    if alt_mm > MEAS_LIMIT_MM:
        alt_mm = MEAS_LIMIT_MM
    elif alt_mm < -MEAS_LIMIT_MM:
        alt_mm = -MEAS_LIMIT_MM
    e = (alt_mm << 4) - kf.alt_q4
    if e > _INNOV_LIMIT:
        e = _INNOV_LIMIT
    elif e < -_INNOV_LIMIT:
        e = -_INNOV_LIMIT
    weight = kf.baro_weight_256
    if weight < 256:
        e = (e >> 8) * weight
    return e


def _accel_innovation(kf, acc_mmps2):
    """The accelerometer's innovation (acc << 4) - (acc_q4 + bias_q4), clamped as the barometer's:
    acc_q4 + bias_q4 stays within 2**28 (both clamped to 2**27), the difference inside 31 bits."""
    if acc_mmps2 > MEAS_LIMIT_MM:
        acc_mmps2 = MEAS_LIMIT_MM
    elif acc_mmps2 < -MEAS_LIMIT_MM:
        acc_mmps2 = -MEAS_LIMIT_MM
    e = (acc_mmps2 << 4) - (kf.acc_q4 + kf.bias_q4)
    if e > _INNOV_LIMIT:
        return _INNOV_LIMIT
    if e < -_INNOV_LIMIT:
        return -_INNOV_LIMIT
    return e


def _add2(kf, eh, ea, rh, ra, i):
    """Add K [eh, ea] for the two-measurement gains starting at index i: the altitude column
    from row ``rh``, the acceleration column from row ``ra``.

    Each product is ``_mul_gain``'s, written out with each innovation split once: on MicroPython
    six calls of it would cost a quarter more than this whole function. Small innovations (the
    usual case: within _SMALL_INNOV) take the unsplit product round(e * m / 2**s), the same value
    in half the operations."""
    if -_SMALL_INNOV < eh < _SMALL_INNOV and -_SMALL_INNOV < ea < _SMALL_INNOV:
        m = rh[i]
        s = rh[i + 1]
        alt = kf.alt_q4 + ((eh * m + (1 << (s - 1))) >> s)
        m = ra[i + 2]
        s = ra[i + 3]
        alt += (ea * m + (1 << (s - 1))) >> s
        m = rh[i + 4]
        s = rh[i + 5]
        vel = kf.vel_q4 + ((eh * m + (1 << (s - 1))) >> s)
        m = ra[i + 6]
        s = ra[i + 7]
        vel += (ea * m + (1 << (s - 1))) >> s
        m = rh[i + 8]
        s = rh[i + 9]
        acc = kf.acc_q4 + ((eh * m + (1 << (s - 1))) >> s)
        m = ra[i + 10]
        s = ra[i + 11]
        acc += (ea * m + (1 << (s - 1))) >> s
    else:
        hh = eh >> 14
        lh = eh & 0x3FFF
        ha = ea >> 14
        la = ea & 0x3FFF
        m = rh[i]
        s = rh[i + 1]
        alt = kf.alt_q4 + ((hh * m + ((lh * m + (1 << (s - 1))) >> 14)) >> (s - 14))
        m = ra[i + 2]
        s = ra[i + 3]
        alt += (ha * m + ((la * m + (1 << (s - 1))) >> 14)) >> (s - 14)
        m = rh[i + 4]
        s = rh[i + 5]
        vel = kf.vel_q4 + ((hh * m + ((lh * m + (1 << (s - 1))) >> 14)) >> (s - 14))
        m = ra[i + 6]
        s = ra[i + 7]
        vel += (ha * m + ((la * m + (1 << (s - 1))) >> 14)) >> (s - 14)
        m = rh[i + 8]
        s = rh[i + 9]
        acc = kf.acc_q4 + ((hh * m + ((lh * m + (1 << (s - 1))) >> 14)) >> (s - 14))
        m = ra[i + 10]
        s = ra[i + 11]
        acc += (ha * m + ((la * m + (1 << (s - 1))) >> 14)) >> (s - 14)
    # the state stored, clamped to its limits (written out: a call of a helper for it cost a
    # tenth of a correction on MicroPython)
    if alt > ALT_LIMIT_Q4:
        alt = ALT_LIMIT_Q4
    elif alt < -ALT_LIMIT_Q4:
        alt = -ALT_LIMIT_Q4
    if vel > RATE_LIMIT_Q4:
        vel = RATE_LIMIT_Q4
    elif vel < -RATE_LIMIT_Q4:
        vel = -RATE_LIMIT_Q4
    if acc > RATE_LIMIT_Q4:
        acc = RATE_LIMIT_Q4
    elif acc < -RATE_LIMIT_Q4:
        acc = -RATE_LIMIT_Q4
    kf.alt_q4 = alt
    kf.vel_q4 = vel
    kf.acc_q4 = acc


def _add(kf, e, row, i, stride):
    """Add K e for one column of gains: altitude, velocity and acceleration gains at row[i],
    row[i + stride], row[i + 2 stride] (stride 2: single-sensor gains; 4: one column of the
    two-sensor gains). The products as in ``_add2``."""
    m = row[i]
    s = row[i + 1]
    m_vel = row[i + stride]
    s_vel = row[i + stride + 1]
    m_acc = row[i + 2 * stride]
    s_acc = row[i + 2 * stride + 1]
    if -_SMALL_INNOV < e < _SMALL_INNOV:
        alt = kf.alt_q4 + ((e * m + (1 << (s - 1))) >> s)
        vel = kf.vel_q4 + ((e * m_vel + (1 << (s_vel - 1))) >> s_vel)
        acc = kf.acc_q4 + ((e * m_acc + (1 << (s_acc - 1))) >> s_acc)
    else:
        hi = e >> 14
        lo = e & 0x3FFF
        alt = kf.alt_q4 + ((hi * m + ((lo * m + (1 << (s - 1))) >> 14)) >> (s - 14))
        vel = kf.vel_q4 + ((hi * m_vel + ((lo * m_vel + (1 << (s_vel - 1))) >> 14)) >> (s_vel - 14))
        acc = kf.acc_q4 + ((hi * m_acc + ((lo * m_acc + (1 << (s_acc - 1))) >> 14)) >> (s_acc - 14))
    # the state stored, clamped to its limits (written out: a call of a helper for it cost a
    # tenth of a correction on MicroPython)
    if alt > ALT_LIMIT_Q4:
        alt = ALT_LIMIT_Q4
    elif alt < -ALT_LIMIT_Q4:
        alt = -ALT_LIMIT_Q4
    if vel > RATE_LIMIT_Q4:
        vel = RATE_LIMIT_Q4
    elif vel < -RATE_LIMIT_Q4:
        vel = -RATE_LIMIT_Q4
    if acc > RATE_LIMIT_Q4:
        acc = RATE_LIMIT_Q4
    elif acc < -RATE_LIMIT_Q4:
        acc = -RATE_LIMIT_Q4
    kf.alt_q4 = alt
    kf.vel_q4 = vel
    kf.acc_q4 = acc


def _clamp(x, limit):
    if x > limit:
        return limit
    if x < -limit:
        return -limit
    return x


class Kalman:
    """Three-state (altitude, velocity, acceleration) filter with precomputed gains."""

    def __init__(self):
        self.alt_q4 = 0
        self.vel_q4 = 0
        self.acc_q4 = 0
        self.bias_q4 = 0
        self.baro_weight_256 = 256  # barometer innovations are scaled by this / 256 (Mach de-weighting)
        self.bias_limit_q4 = RATE_LIMIT_Q4  # |bias_q4| at most this: the bias a real sensor can have

    def reset(self, alt_mm, vel_mmps=0, acc_mmps2=0):
        """Set the state from values in mm, mm/s, mm/s^2."""
        self.alt_q4 = _clamp(_clamp(alt_mm, MEAS_LIMIT_MM) << 4, ALT_LIMIT_Q4)
        self.vel_q4 = _clamp(_clamp(vel_mmps, MEAS_LIMIT_MM) << 4, RATE_LIMIT_Q4)
        self.acc_q4 = _clamp(_clamp(acc_mmps2, MEAS_LIMIT_MM) << 4, RATE_LIMIT_Q4)
        self.bias_q4 = 0

    def set_altitude(self, alt_mm):
        """Move the altitude state to ``alt_mm`` (clamped), keeping velocity and acceleration."""
        self.alt_q4 = _clamp(_clamp(alt_mm, MEAS_LIMIT_MM) << 4, ALT_LIMIT_Q4)

    def predict(self, row):
        """Advance the state by one period T = 1 / row[0] s (constant-acceleration model)."""
        rate = row[0]
        vel = self.vel_q4
        dv = (self.acc_q4 + (rate >> 1)) // rate  # a*T, rounded
        # h += v*T + a*T^2/2 = (2v + a*T) / (2 rate), rounded; the acceleration stays as it is
        # (within its limits: every store of it clamps it)
        alt = self.alt_q4 + (2 * vel + dv + rate) // (2 * rate)
        if alt > ALT_LIMIT_Q4:
            alt = ALT_LIMIT_Q4
        elif alt < -ALT_LIMIT_Q4:
            alt = -ALT_LIMIT_Q4
        vel += dv
        if vel > RATE_LIMIT_Q4:
            vel = RATE_LIMIT_Q4
        elif vel < -RATE_LIMIT_Q4:
            vel = -RATE_LIMIT_Q4
        self.alt_q4 = alt
        self.vel_q4 = vel

    def correct(self, row_alt, row_acc, alt_mm, acc_mmps2):
        """Correct with a barometric altitude (mm) and a kinematic acceleration (mm/s^2); each
        sensor's gains from its own row (the same row when both are read at the same rate)."""
        _add2(self, _baro_innovation(self, alt_mm), _accel_innovation(self, acc_mmps2), row_alt, row_acc, 1)

    def correct_baro(self, row, alt_mm):
        """Correct with a barometric altitude (mm) only (no accelerometer reading)."""
        _add(self, _baro_innovation(self, alt_mm), row, 13, 2)

    def correct_accel(self, row, acc_mmps2):
        """Correct with a kinematic acceleration (mm/s^2) only (no barometer reading)."""
        _add(self, _accel_innovation(self, acc_mmps2), row, 19, 2)

    def correct_coast(self, row_alt, row_acc, alt_mm, acc_mmps2):
        """Correct with both readings and update the accelerometer bias (coast model)."""
        eh = _baro_innovation(self, alt_mm)
        ea = _accel_innovation(self, acc_mmps2)
        _add2(self, eh, ea, row_alt, row_acc, 25)
        # the bias gains' products as _mul_gain's, written out as in _add2 (coast runs this on
        # most samples)
        m = row_alt[37]
        s = row_alt[38]
        bias = self.bias_q4 + (((eh >> 14) * m + (((eh & 0x3FFF) * m + (1 << (s - 1))) >> 14)) >> (s - 14))
        m = row_acc[39]
        s = row_acc[40]
        bias += ((ea >> 14) * m + (((ea & 0x3FFF) * m + (1 << (s - 1))) >> 14)) >> (s - 14)
        limit = self.bias_limit_q4
        if bias > limit:
            bias = limit
        elif bias < -limit:
            bias = -limit
        self.bias_q4 = bias

    def correct_baro_part(self, row, alt_mm, coast):
        """Correct with a barometric altitude (mm) through the barometer's column of the two-sensor
        gains (``coast``: the coast gains, which also update the bias)."""
        eh = _baro_innovation(self, alt_mm)
        if coast:
            _add(self, eh, row, 25, 4)
            self.bias_q4 = _clamp(self.bias_q4 + _mul_gain(eh, row[37], row[38]), self.bias_limit_q4)
        else:
            _add(self, eh, row, 1, 4)

    def correct_accel_part(self, row, acc_mmps2, coast):
        """Correct with a kinematic acceleration (mm/s^2) through the accelerometer's column of the
        two-sensor gains (``coast``: the coast gains, which also update the bias)."""
        ea = _accel_innovation(self, acc_mmps2)
        if coast:
            _add(self, ea, row, 27, 4)
            self.bias_q4 = _clamp(self.bias_q4 + _mul_gain(ea, row[39], row[40]), self.bias_limit_q4)
        else:
            _add(self, ea, row, 3, 4)

    def correct_gravity(self, row, alt_mm):
        """Late coast: correct with a barometric altitude (mm) and the pseudo-measurement that the
        vertical acceleration is -g (drag vanishes at apogee); the accelerometer is not used."""
        _add2(self, _baro_innovation(self, alt_mm), -_G_Q4 - self.acc_q4, row, row, 41)
