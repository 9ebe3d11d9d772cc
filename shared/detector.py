"""Per-sample driver of the Kalman filter: predicts over each sample's period (and across
dropouts), and corrects with whichever readings the sample carries.

Portable and allocation-free per sample. Time is integer microseconds (``dt_us``: time since
the previous sample). Readings: barometric altitude in mm (any datum) and kinematic acceleration
in mm/s^2 (specific force minus the pad's 1 g; 0 at rest, about -9807 in drag-free coast).

Each sensor keeps its own schedule: a sample may carry one reading, the other, or both (a
barometer slower than the accelerometer, or a logger that writes each sensor on its own row).
Each reading is used at its own time: the filter predicts across the samples without it, and its
gains are those of its own reading interval (a barometer read every 20 ms gets the 50 Hz gains
even when the samples are 10 ms apart). A reading alone on its sample, while the other sensor is
on schedule, is corrected through its column of the two-sensor gains, so that readings on separate
rows add up to the correction of a row with both. Once the other sensor has given no used
reading for SCHEDULE_US (a dead part, a run of rejected readings), or the state machine stops
using it (the accelerometer under a parachute), the single-sensor gains apply.
"""

from array import array

try:
    from micropython import const
except ImportError:
    def const(x):
        return x

from shared.kalman import RATE_LIMIT_Q4, Kalman

# shared.kalman's MEAS_LIMIT_MM, folded here: on MicroPython an imported constant is a global, and
# the gates test it on every reading (tests/shared/test_flight.py checks that the copy agrees)
_MEAS_LIMIT_MM = const(0x1FFFFFF)

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
# A sensor whose last used reading is at most this old still informs the filter (its information
# fades over about the settling time of the filter, far longer): a reading of the other sensor
# alone takes its column of the two-sensor gains. 1.5 periods of the slowest table rate (10 Hz),
# so that a 10 Hz barometer beside a fast accelerometer stays on schedule despite jitter.
SCHEDULE_US = const(150000)
# Times since a sensor's readings saturate here (268 s), far beyond any reading interval, so that
# they stay small integers however long a sensor stays silent.
_SINCE_LIMIT_US = const(0xFFFFFFF)


class Detector:
    """Kalman filter plus an apogee rule, stepped once per sample.

    Parameters
    ----------
    table : tuple of gain rows (``shared.gains_table.PROJECT`` or ``SEED``)
    rule : object with ``reset()``, ``update(kf, rate_hz, enabled) -> bool`` and ``history``
        (shared/apogee.py)
    """

    def __init__(self, table, rule):
        self.table = table
        self.rule = rule
        self.rule_history = rule.history  # False: the rule is asked only while enabled
        self.kf = Kalman()
        self.row = table[0]
        self.fine_row = table[0]  # the table's fastest rate: samples sooner than a period step in it
        for row in table:
            if row[0] > self.fine_row[0]:
                self.fine_row = row
        self.regular = False  # the cached period is one period of a table rate
        # dt_us: the period the cached row belongs to; period_lo_us..period_hi_us: the periods
        # that select the cached row as regular (jitter around its period: no search of the
        # table; empty when the cached period is irregular), and each row's
        self.forget_period()
        self.row_lo_us = array("i", [0] * len(table))
        self.row_hi_us = array("i", [0] * len(table))
        for i in range(len(table)):
            self._row_window(i)
        self.predict_steps = 0  # predictions in the last step: 1 normally, more across a gap
        self.carry_us = 0  # time not yet predicted (irregular periods are predicted in whole steps)
        # per sensor (barometer, accelerometer): time since its last reading, since its last
        # reading that was used (within the gates), and between its last two readings (0: none yet)
        self.seen_us = array("i", (0, 0))
        self.used_us = array("i", (0, 0))
        self.interval_us = array("i", (0, 0))
        self.sensor_row = [table[0], table[0]]  # gain row for each sensor's interval
        self.sensor_row_us = array("i", (-1, -1))  # the interval each sensor_row belongs to
        # innovation gates (0 = off), set by the state machine for the flight phase
        self.gate_alt_mm = 0
        self.gate_acc_mmps2 = 0
        self.outlier_us = array("i", (0, 0))  # consecutive outlier time: barometer, accelerometer
        self.inside_us = array("i", (0, 0))  # time inside the gate since it opened (-1: closed)
        self.inside_us[0] = self.inside_us[1] = -1
        self.acc_max_q4 = RATE_LIMIT_Q4  # ceiling of the acceleration state (coast: -0.5 g)
        # a barometric run of outliers whose innovation changes slower than this over the run's
        # last half is a step (a pressure offset): the re-synchronisation moves the altitude
        # state onto it instead of the gains' transient (0 = off; set by the state machine)
        self.step_rate_mmps = 0
        # the barometric innovation over a run's third and fourth quarters (in 16 mm: a quarter
        # second of readings at up to 2 kHz stays in 31 bits), and how many readings each holds
        self.run_sum_16mm = array("i", (0, 0))
        self.run_n = array("i", (0, 0))
        self.outliers = 0  # count of rejected readings
        self.model = MODEL_PLAIN
        # set by the state machine while it follows the barometer alone (descent, a diverged or
        # resumed filter): the accelerometer is then never on schedule, and its interval restarts
        # with its first reading after (the filter does not count that time as a slow sensor's)
        self.accel_off = False

    def start(self, alt_mm, acc_mmps2=0):
        """Initialise the state at rest at ``alt_mm`` (the seed starts from [alt(1); 0; accel(1)])."""
        self.kf.reset(alt_mm, 0, acc_mmps2)
        self.rule.reset()

    def withdraw_apogee(self):
        """The caller does not take the apogee ``step`` just declared: the rule is asked again at
        the next sample, as if it had not been enabled on this one (its history is kept)."""
        self.rule.fired = False

    def step(self, dt_us, alt_mm, acc_mmps2, have, enabled):
        """Advance by ``dt_us`` and correct with the readings flagged in ``have``.

        Returns True on the sample at which the rule declares apogee (``enabled`` permitting).

        The usual cases of the steps below are written out here rather than in helper methods:
        on MicroPython a method call costs as much as a dozen arithmetic operations (docs/BENCHMARKS.md,
        "Per-sample cost"); the helpers keep the rare cases (a gap, a rate change, an outlier).
        """
        # re-select only when the period changes beyond the row's jitter: this loops over the table
        if dt_us != self.dt_us and not self.period_lo_us <= dt_us <= self.period_hi_us:
            self._set_period(dt_us)
        kf = self.kf
        row = self.row
        regular = self.regular
        if regular:  # one period of the selected rate
            self.carry_us = 0
            self.predict_steps = 1
            kf.predict(row)
        else:
            self._predict_irregular(dt_us)
        # each sensor's clocks advance by dt_us; a fresh reading measures its interval (written out
        # for the two sensors: a loop over them cost a tenth of the step)
        seen = self.seen_us
        interval = self.interval_us
        t = seen[0] + dt_us
        if t > _SINCE_LIMIT_US:
            t = _SINCE_LIMIT_US
        if have & HAVE_BARO:
            interval[0] = t
            t = 0
        seen[0] = t
        t = seen[1] + dt_us
        if t > _SINCE_LIMIT_US:
            t = _SINCE_LIMIT_US
        if have & HAVE_ACCEL:
            interval[1] = t
            t = 0
        accel_off = self.accel_off
        seen[1] = 0 if accel_off else t
        used = self.used_us
        used_baro_us = used[0] + dt_us
        if used_baro_us > _SINCE_LIMIT_US:
            used_baro_us = _SINCE_LIMIT_US
        used_acc_us = used[1] + dt_us
        if used_acc_us > _SINCE_LIMIT_US:
            used_acc_us = _SINCE_LIMIT_US
        # innovation gates: a reading inside a closed gate is used at once; the rest is _outlier's
        # (the reading clamped as the filter clamps it)
        if have & HAVE_BARO:
            gate = self.gate_alt_mm
            if gate:
                e = alt_mm
                if e > _MEAS_LIMIT_MM:
                    e = _MEAS_LIMIT_MM
                elif e < -_MEAS_LIMIT_MM:
                    e = -_MEAS_LIMIT_MM
                e -= kf.alt_q4 >> 4
                if -gate <= e <= gate and self.inside_us[0] < 0:
                    self.outlier_us[0] = 0
                elif self._outlier(e, gate, 0, BARO_RESYNC_US):
                    have &= HAVE_ACCEL
        if have & HAVE_ACCEL:
            gate = self.gate_acc_mmps2
            if gate:
                e = acc_mmps2
                if e > _MEAS_LIMIT_MM:
                    e = _MEAS_LIMIT_MM
                elif e < -_MEAS_LIMIT_MM:
                    e = -_MEAS_LIMIT_MM
                e -= kf.acc_q4 >> 4
                if -gate <= e <= gate and self.inside_us[1] < 0:
                    self.outlier_us[1] = 0
                elif self._outlier(e, gate, 1, ACCEL_RESYNC_US):
                    have &= HAVE_BARO
        # each reading's gain row: the sample's own row when it came one regular period after the
        # previous reading (every sample carries it), else the row of its own interval
        model = self.model
        if have & HAVE_BARO:
            row_baro = row if regular and interval[0] == dt_us else self._interval_row(0)
        if have & HAVE_ACCEL and model != MODEL_GRAVITY:
            row_acc = row if regular and interval[1] == dt_us else self._interval_row(1)
        if model == MODEL_GRAVITY:
            if have & HAVE_BARO:
                kf.correct_gravity(row_baro, alt_mm)
        elif have == HAVE_BOTH:
            if model == MODEL_BIAS:
                kf.correct_coast(row_baro, row_acc, alt_mm, acc_mmps2)
            else:
                kf.correct(row_baro, row_acc, alt_mm, acc_mmps2)
        # a reading alone takes its column of the two-sensor gains while the other sensor is on
        # schedule: it has a used reading within SCHEDULE_US (the accelerometer: and is not off)
        elif have == HAVE_BARO:
            if not accel_off and interval[1] > 0 and used_acc_us < SCHEDULE_US:
                kf.correct_baro_part(row_baro, alt_mm, model == MODEL_BIAS)
            else:
                kf.correct_baro(row_baro, alt_mm)
        elif have == HAVE_ACCEL:
            if interval[0] > 0 and used_baro_us < SCHEDULE_US:
                kf.correct_accel_part(row_acc, acc_mmps2, model == MODEL_BIAS)
            else:
                kf.correct_accel(row_acc, acc_mmps2)
        used[0] = 0 if have & HAVE_BARO else used_baro_us
        used[1] = 0 if have & HAVE_ACCEL else used_acc_us
        if kf.acc_q4 > self.acc_max_q4:
            kf.acc_q4 = self.acc_max_q4
        if enabled or self.rule_history:
            return self.rule.update(kf, row[0], enabled)
        return False

    def _predict_irregular(self, dt_us):
        """Advance the state by an irregular ``dt_us`` (the regular period is one prediction, in
        ``step``): whole periods (of the rate in use across a gap, of the fastest rate for a sample
        sooner than a period), the remainder carried to the next sample so that the filter's time
        keeps up with the samples' (a burst of rows 1 ms apart predicts 1 ms each)."""
        kf = self.kf
        row = self.row
        period_us = 1000000 // row[0]
        if dt_us < period_us - (period_us >> 3):
            row = self.fine_row
            period_us = 1000000 // row[0]
        t_us = self.carry_us + dt_us
        steps = (t_us + (period_us >> 1)) // period_us
        if steps > MAX_PREDICT_STEPS:
            steps = MAX_PREDICT_STEPS
            t_us = steps * period_us
        self.carry_us = t_us - steps * period_us
        self.predict_steps = steps
        for _ in range(steps):
            kf.predict(row)

    def _interval_row(self, sensor):
        """The gain row of the table period nearest to the sensor's reading interval (the slowest
        rate for an interval beyond it), kept until the interval changes."""
        interval = self.interval_us[sensor]
        if interval != self.sensor_row_us[sensor]:
            self.sensor_row[sensor] = self._nearest(interval)
            self.sensor_row_us[sensor] = interval
        return self.sensor_row[sensor]

    def _row_window(self, i):
        """The periods for which ``_set_period`` selects row ``i`` as regular: within 1/8 of its
        period (``_set_period``'s test) and nearer to it than to any other row (``_nearest``: the
        midpoint between two periods goes to the slower row)."""
        period = 1000000 // self.table[i][0]
        lo = period - period // 8
        hi = period + period // 8
        for row in self.table:
            other = 1000000 // row[0]
            if other < period:  # a faster row: from the midpoint, rounded up, on
                mid = (period + other + 1) >> 1
                if mid > lo:
                    lo = mid
            elif other > period:  # a slower row: below the midpoint
                mid = ((period + other + 1) >> 1) - 1
                if mid < hi:
                    hi = mid
        self.row_lo_us[i] = lo
        self.row_hi_us[i] = hi

    def forget_period(self):
        """Select the period again on the next step."""
        self.dt_us = -1
        self.period_lo_us = 1
        self.period_hi_us = 0

    def _nearest(self, dt_us):
        """The table row whose period is nearest to ``dt_us`` (the slower on a tie)."""
        best = self.table[0]
        best_err = 0x3FFFFFFF
        for row in self.table:
            err = 1000000 // row[0] - dt_us
            if err < 0:
                err = -err
            if err < best_err:
                best = row
                best_err = err
        return best

    def _outlier(self, e, gate, sensor, resync_us):
        """For a reading outside the gate, or while the gate is open (``step`` uses a reading
        inside a closed gate at once): True if the innovation ``e`` is beyond ``gate`` and this
        sensor's run of outliers is still shorter than ``resync_us`` (then the reading is not
        used). The run is timed by the sensor's own reading intervals. Once re-synchronised the
        gate stays open until the innovation has stayed inside it for GATE_REARM_US."""
        inside = -gate <= e <= gate
        interval_us = self.interval_us[sensor]
        if self.inside_us[sensor] >= 0:
            if not inside:
                self.inside_us[sensor] = 0
                return False
            self.inside_us[sensor] += interval_us
            if self.inside_us[sensor] >= GATE_REARM_US:
                self.inside_us[sensor] = -1
            return False
        run_us = self.outlier_us[sensor] + interval_us
        self.outlier_us[sensor] = run_us
        if sensor == 0 and self.step_rate_mmps:
            self._step_sums(e, run_us - interval_us, run_us)
        if run_us < resync_us:
            self.outliers += 1
            return True
        self.outlier_us[sensor] = 0
        self.inside_us[sensor] = 0  # re-synchronise: open the gate
        if sensor == 0 and self.step_rate_mmps:
            self._resync_step()
        return False

    def _step_sums(self, e, before_us, run_us):
        """Add the barometric innovation ``e`` (mm) at ``run_us`` into a run of outliers to the
        sums of the run's third or fourth quarter (a new run empties them)."""
        sums = self.run_sum_16mm
        n = self.run_n
        if before_us == 0:
            sums[0] = sums[1] = n[0] = n[1] = 0
        quarter = 1 if run_us * 4 > BARO_RESYNC_US * 3 else 0 if run_us * 2 > BARO_RESYNC_US else -1
        if quarter >= 0:
            sums[quarter] += e >> 4
            n[quarter] += 1

    def _resync_step(self):
        """At a barometric re-synchronisation: if the innovation held still over the run's last
        half (the barometer's rate agreed with the filter's velocity, only its level moved), move
        the altitude state by the fourth quarter's mean innovation and keep the velocity.
        Altitude cannot jump while the velocity agrees: such a step is a pressure offset (airbrakes,
        a port's transient) that the gains would otherwise turn into a velocity transient of tens
        of m/s (a -114 m step in the late coast: the filter's velocity through zero 4.6 s early).
        A run whose innovation moves is left to the gains (a filter that really drifted away)."""
        n = self.run_n
        if n[0] == 0 or n[1] == 0:
            return
        early = self.run_sum_16mm[0] // n[0]
        late = self.run_sum_16mm[1] // n[1]
        # the quarters' centres are a quarter of BARO_RESYNC_US (0.25 s) apart: 16 mm x 4 per s
        drift_mmps = (late - early) * 64
        if -self.step_rate_mmps <= drift_mmps <= self.step_rate_mmps:
            self.kf.set_altitude((self.kf.alt_q4 >> 4) + late * 16)

    def _set_period(self, dt_us):
        """Select the sample's rate for ``dt_us``.

        A period within 1/8 of a table rate's period is one step of that rate (jitter, or a logger
        changing rate: 10 ms, then 100 ms). Anything else is irregular (see ``_predict_irregular``): a gap is
        whole periods of the rate in use before it (a 60 ms gap at 100 Hz is six 100 Hz steps), at
        most MAX_PREDICT_STEPS.
        """
        best = self._nearest(dt_us)
        err = 1000000 // best[0] - dt_us
        if err < 0:
            err = -err
        self.regular = err * 8 <= 1000000 // best[0]
        if self.regular:
            self.row = best
            i = self.table.index(best)
            self.period_lo_us = self.row_lo_us[i]
            self.period_hi_us = self.row_hi_us[i]
        else:
            self.forget_period()
        self.dt_us = dt_us
