"""Per-sample driver of the Kalman filter: picks the gains for each sample's period, predicts
across dropouts, and corrects with whichever readings the sample carries.

Portable and allocation-free per sample. Time is integer microseconds (``dt_us``: time since
the previous sample). Readings: barometric altitude in mm (any datum) and kinematic acceleration
in mm/s^2 (specific force minus the pad's 1 g; 0 at rest, about -9807 in drag-free coast).
"""

from array import array

try:
    from micropython import const
except ImportError:
    def const(x):
        return x

from shared.kalman import MEAS_LIMIT_MM, RATE_LIMIT_Q4, Kalman

HAVE_BARO = const(1)
HAVE_ACCEL = const(2)
HAVE_BOTH = const(3)

# Correction models, chosen by the state machine for the flight phase (``Detector.model``).
MODEL_PLAIN = const(0)  # pad, boost, descent: altitude, velocity, acceleration
MODEL_BIAS = const(1)  # coast: plus the accelerometer's bias
MODEL_GRAVITY = const(2)  # late coast: barometer and "acceleration = -g"; accelerometer unused

# A gap longer than this many periods of the nearest table rate is predicted across in steps
# (a dropout); the loop is bounded so a stalled clock cannot stall the flight loop.
MAX_PREDICT_STEPS = const(600)
# A reading outside its gate is an outlier (ejection charge, shock, pressure transient) and is not
# used; after this long of consecutive outliers the filter accepts them again (re-synchronises),
# so a filter that really drifted away cannot lock its sensor out for good. Accelerometer
# outliers (shocks, ejection) last tens of ms, a real change in acceleration persists: 0.1 s.
# Barometric transients (ejection, Mach) last up to about a second.
BARO_RESYNC_US = const(1000000)
ACCEL_RESYNC_US = const(100000)
# After a re-synchronisation the gate stays open until the innovation has stayed inside it this
# long: the filter then re-converges as the linear filter its gains describe. A gate that closed
# again at the first small innovation would cut the re-convergence at every overshoot and turn a
# large error into a limit cycle (docs/DESIGN.md, "A filter that always re-converges").
GATE_REARM_US = const(3000000)


def _clamp(x):
    if x > MEAS_LIMIT_MM:
        return MEAS_LIMIT_MM
    if x < -MEAS_LIMIT_MM:
        return -MEAS_LIMIT_MM
    return x


class Detector:
    """Kalman filter plus an apogee rule, stepped once per sample.

    Parameters
    ----------
    table : tuple of gain rows (``shared.gains_table.PROJECT`` or ``SEED``)
    rule : object with ``reset()`` and ``update(kf, rate_hz, enabled) -> bool``
    """

    def __init__(self, table, rule):
        self.table = table
        self.rule = rule
        self.kf = Kalman()
        self.row = table[0]
        self.dt_us = -1  # period the cached row and predict_steps belong to
        self.predict_steps = 0  # predictions per step: 1 normally, more across a gap
        # innovation gates (0 = off), set by the state machine for the flight phase
        self.gate_alt_mm = 0
        self.gate_acc_mmps2 = 0
        self.outlier_us = array("i", (0, 0))  # consecutive outlier time: barometer, accelerometer
        self.inside_us = array("i", (0, 0))  # time inside the gate since it opened (-1: closed)
        self.inside_us[0] = self.inside_us[1] = -1
        self.acc_max_q4 = RATE_LIMIT_Q4  # ceiling of the acceleration state (coast: -0.5 g)
        self.outliers = 0  # count of rejected readings
        self.model = MODEL_PLAIN

    def start(self, alt_mm, acc_mmps2=0):
        """Initialise the state at rest at ``alt_mm`` (the seed starts from [alt(1); 0; accel(1)])."""
        self.kf.reset(alt_mm, 0, acc_mmps2)
        self.rule.reset()

    def step(self, dt_us, alt_mm, acc_mmps2, have, enabled):
        """Advance by ``dt_us`` and correct with the readings flagged in ``have``.

        Returns True on the sample at which the rule declares apogee (``enabled`` permitting).
        """
        if dt_us != self.dt_us:  # re-select only when the period changes: this loops over the table
            self._set_period(dt_us)
        row = self.row
        kf = self.kf
        for _ in range(self.predict_steps):
            kf.predict(row)
        if have & HAVE_BARO and self.gate_alt_mm and self._outlier(
                _clamp(alt_mm) - (kf.alt_q4 >> 4), self.gate_alt_mm, 0, dt_us, BARO_RESYNC_US):
            have &= HAVE_ACCEL
        if have & HAVE_ACCEL and self.gate_acc_mmps2 and self._outlier(
                _clamp(acc_mmps2) - (kf.acc_q4 >> 4), self.gate_acc_mmps2, 1, dt_us, ACCEL_RESYNC_US):
            have &= HAVE_BARO
        if self.model == MODEL_GRAVITY:
            if have & HAVE_BARO:
                kf.correct_gravity(row, alt_mm)
        elif have == HAVE_BOTH:
            if self.model == MODEL_BIAS:
                kf.correct_coast(row, alt_mm, acc_mmps2)
            else:
                kf.correct(row, alt_mm, acc_mmps2)
        elif have == HAVE_BARO:
            kf.correct_baro(row, alt_mm)
        elif have == HAVE_ACCEL:
            kf.correct_accel(row, acc_mmps2)
        if kf.acc_q4 > self.acc_max_q4:
            kf.acc_q4 = self.acc_max_q4
        return self.rule.update(kf, row[0], enabled)

    def _outlier(self, e, gate, sensor, dt_us, resync_us):
        """True if the innovation ``e`` is beyond ``gate`` and this sensor's run of outliers is
        still shorter than ``resync_us`` (then the reading is not used). Once re-synchronised the
        gate stays open until the innovation has stayed inside it for GATE_REARM_US."""
        inside = -gate <= e <= gate
        if self.inside_us[sensor] >= 0:
            if not inside:
                self.inside_us[sensor] = 0
                return False
            self.inside_us[sensor] += dt_us
            if self.inside_us[sensor] >= GATE_REARM_US:
                self.inside_us[sensor] = -1
            return False
        if inside:
            self.outlier_us[sensor] = 0
            return False
        self.outlier_us[sensor] += dt_us
        if self.outlier_us[sensor] < resync_us:
            self.outliers += 1
            return True
        self.outlier_us[sensor] = 0
        self.inside_us[sensor] = 0  # re-synchronise: open the gate
        return False

    def _set_period(self, dt_us):
        """Select the gain row and the number of its periods that cover ``dt_us``.

        A period within 1/8 of a table rate's period is one step of that rate (jitter, or a logger
        changing rate: 10 ms, then 100 ms). Anything else is a gap: whole periods of the rate in
        use before it (a 60 ms gap at 100 Hz is six 100 Hz steps), at most MAX_PREDICT_STEPS.
        """
        best = self.table[0]
        best_err = 0x3FFFFFFF
        for row in self.table:
            err = 1000000 // row[0] - dt_us
            if err < 0:
                err = -err
            if err < best_err:
                best = row
                best_err = err
        if best_err * 8 <= 1000000 // best[0]:
            self.row = best
            steps = 1
        else:
            period_us = 1000000 // self.row[0]
            steps = (dt_us + (period_us >> 1)) // period_us
            if steps < 1:
                steps = 1
            elif steps > MAX_PREDICT_STEPS:
                steps = MAX_PREDICT_STEPS
        self.dt_us = dt_us
        self.predict_steps = steps
