"""Per-sensor health, judged on every sample before the filter sees the readings.

Portable and allocation-free per sample. ``check_health()``, once per sample, takes the
sample's ``have`` mask (``shared.detector.HAVE_BARO | HAVE_ACCEL``) and returns the mask of the
readings that may be used. It judges each reading alone:

- a sensor the board does not have (``sensors`` in the configuration) is never used;
- a barometric altitude at either end of the altitude table (a pressure outside 1 to 110 kPa:
  a BMP280 returning 0, a broken bus) is out of range and not used;
- an accelerometer reading at its full scale under-reads, so the sample uses the barometer alone.

then each sensor over time (docs/DESIGN.md D16, "Sensor arbitration"): frozen (identical readings
for ``baro_stuck_s`` in flight; for the accelerometer ``accel_stuck_s`` while it reads more than
1 g, where noise and change are certain; a reading at the configured full scale, or held at the
largest of the flight, is clipped, and frozen only once held ``max_boost_s``: no boost that clips
lasts longer) and single readings that are impossible (one that moved faster than
``baro_rate_max_mps`` from the previous reading); it keeps the accelerometer's jumpiness
(``acc_jitter``, the mean change from one reading to the next), by which shared/flight.py retires
a part that reads noise in coast (D16 rule 15); and last counts how long each sensor has gone
without a usable reading: one without a usable reading for ``sensor_lost_s`` is lost
(``baro_ok`` / ``accel_ok`` False), and the proof of flight falls back to the other sensor's
(shared/flight.py). ``flags`` holds the HEALTH_* bits; a frozen or lost sensor's readings are not
used while the condition lasts.
"""

try:
    from micropython import const
except ImportError:
    def const(x):
        return x

from shared.altitude import pressure_to_alt_mm
from shared.altitude_table import P_MAX_Q4, P_MIN_Q4

# shared.detector's HAVE_BARO and HAVE_ACCEL, folded here: on MicroPython an imported constant is a
# global, looked up at three times a local's cost, and check_health tests them about eight times
# a sample (tests/shared/test_flight.py checks that the copies agree)
_HAVE_BARO = const(1)
_HAVE_ACCEL = const(2)

HEALTH_BARO_STUCK = const(1)
HEALTH_BARO_LOST = const(2)
HEALTH_ACCEL_STUCK = const(4)
HEALTH_ACCEL_LOST = const(8)
# the barometer contradicted it beyond any barometric error (``retire_accel``): for the flight
HEALTH_ACCEL_IMPLAUSIBLE = const(16)
# its readings in coast jumped from one to the next like noise of several g (``acc_jitter``,
# shared/flight.py): for the flight
HEALTH_ACCEL_NOISY = const(32)
# the accelerometer contradicted it beyond any barometric lie: far below it in coast, reading no
# climb (``retire_baro``): for the flight
HEALTH_BARO_IMPLAUSIBLE = const(64)
HEALTH_BARO_BAD = const(67)  # HEALTH_BARO_STUCK | HEALTH_BARO_LOST | HEALTH_BARO_IMPLAUSIBLE
# HEALTH_ACCEL_STUCK | HEALTH_ACCEL_LOST | HEALTH_ACCEL_IMPLAUSIBLE | HEALTH_ACCEL_NOISY
HEALTH_ACCEL_BAD = const(60)
HEALTH_NAMES = ("baro frozen", "baro lost", "accel frozen", "accel lost", "accel implausible",
                "accel noisy", "baro implausible")

# The ends of the altitude table: shared.altitude clamps any pressure outside it to these.
ALT_TOP_MM = pressure_to_alt_mm(P_MIN_Q4)
ALT_BOTTOM_MM = pressure_to_alt_mm(P_MAX_Q4)
_AGE_LIMIT_MS = const(0x3FFFFFFF)  # ages saturate here (days), inside 31 bits
# A barometric step larger than baro_rate_max x dt plus this (the filter's 50 m outlier gate) in
# one sample is a spike; beyond _RATE_DT_MAX_MS (a gap) no rate is judged.
_SPIKE_ALLOW_MM = const(50000)
# Off the path of the barometer's windowed rate (D16 rule 19) by more than _SPIKE_ALLOW_MM plus
# this x the time since the reading before: the window's rate is the velocity of up to 0.35 s
# ago, and 100 m/s covers its change since under 28 g (a 100 g boost: 34 m at 10 Hz, inside the
# 50 m), and the rate's noise
_PATH_TOL_MMPS = const(100000)
_RATE_DT_MAX_MS = const(200)
_ONE_G_MMPS2 = const(9807)
# An accelerometer reading held this long at the flight's largest is clipped (see check_health): five
# samples at 100 Hz, where a reading that only ties by chance (noise of a least significant bit
# or more) changes within two or three.
_CLIP_HOLD_MS = const(50)
_CLIP_HOLD_N = const(2)  # held readings after the one that set the run: three equal readings
# Impossible barometric readings in a row for _ERRATIC_RUN_MS are a broken part (the real logs'
# longest run, an ejection charge's blast at apogee, lasts 65 ms: firm-jackpot-4, 7 readings), and
# none of its readings is used for _ERRATIC_HOLD_MS after it: at random kilometres a few percent
# pass the spike test by chance, enough for the filter to take a few (a barometer reading +-2 km
# of noise fired drogues 7 to 15 s early)
_ERRATIC_RUN_MS = const(200)
_ERRATIC_HOLD_MS = const(2000)
# The accelerometer's jumpiness, ``acc_jitter``: the mean change from one reading to the next,
# each change counted to at most _JUMP_CAP_MMPS2 (8 g: a glitch or a shock moves it little), an
# exponential average over 2**_JUMP_AVG_SHIFT readings (0.32 s at 100 Hz). Zero-mean noise of
# sigma gives 1.13 sigma (less by the cap); drag changes by a few mg per reading.
_JUMP_CAP_MMPS2 = const(78456)
_JUMP_AVG_SHIFT = const(5)


class SensorHealth:
    """The verdict on each sample's readings (see the module docstring)."""

    def __init__(self, config):
        self.accel_limit_mmps2 = config.accel_limit_mmps2  # 0: full scale unknown, no check
        # a held peak below this is not the full scale: half the configured range (0: unknown)
        self._early_clip_mmps2 = config.accel_limit_mmps2 >> 1
        self.lost_ms = config.sensor_lost_ms
        self.accel_clipped = 0  # count of clipped accelerometer readings
        self.clipped = False  # this sample's accelerometer reading was clipped
        self.baro_age_ms = 0  # time since the last usable reading
        self.accel_age_ms = 0
        self.baro_ok = config.has_baro  # the board has it and it is not lost
        self.accel_ok = config.has_accel
        # the readings of the sensors the board has (one operation per sample in check_health)
        self._board_mask = (_HAVE_BARO if config.has_baro else 0) | (_HAVE_ACCEL if config.has_accel else 0)

    def start_watch(self, config):
        """Thresholds and state of ``check_health``'s judgement over time (called once, from the
        constructor's owner)."""
        self.baro_stuck_ms = config.baro_stuck_ms
        self.accel_stuck_ms = config.accel_stuck_ms
        # a part clipped at full scale reads one value while the boost exceeds its range: frozen
        # only once that outlasts any boost (a 16 g part clips through the whole 1.5 s burn of a
        # 27 g motor; judged frozen after accel_stuck_s, it lost the accelerometer for the flight)
        self.max_boost_ms = config.max_boost_ms
        self.baro_rate_max_mmps = config.baro_rate_max_mmps
        # the arbitration (shared/arbitration.py), whose window's rate is the path a reading is
        # judged against while the barometer agrees with the accelerometer (D16 rule 19); set by
        # the owner (None: no such test)
        self.arb = None
        self.flags = 0
        self.changed = False  # flags changed at this sample
        self.baro_spikes = 0  # count of impossible barometric readings not used
        self.baro_spike_ms = -_AGE_LIMIT_MS  # when the last one came
        self.baro_pulse_ms = -_AGE_LIMIT_MS  # when the last reading off the path (rule 19) came
        self._spike_run_ms = 0  # when the current run of impossible readings began
        self._baro_erratic_ms = -_AGE_LIMIT_MS  # no barometric reading is used before this
        self.baro_moved = False  # this sample's barometric reading differs from the previous one
        self._baro_last = 0
        self._baro_seen = False
        self._baro_fresh_ms = 0
        self._baro_run_ms = 0  # when the current run of identical readings began
        self._acc_last = 0
        self._acc_seen = False
        self._acc_run_ms = 0
        self._acc_peak = 0  # the largest accelerometer reading in flight (mm/s^2)
        self._acc_change_ms = 0  # when the accelerometer's reading last changed
        # the run of readings held at the flight's largest: when its reading changed last (the
        # run it counts) and its held readings so far
        self._clip_run_ms = -1
        self._clip_held_n = 0
        # the flags of the sensors retired for the flight (retire_accel, retire_baro): one value
        # for both, so that the sample's lookups stay as few (docs/BENCHMARKS.md)
        self.retired = 0
        self.acc_jitter = 0  # mm/s^2, see _JUMP_CAP_MMPS2

    def accel_held_near_zero_ms(self, now_ms, near_mmps2):
        """How long the accelerometer has read one value within ``near_mmps2`` of zero (0: it
        reads another)."""
        last = self._acc_last
        if -near_mmps2 < last < near_mmps2:
            return now_ms - self._acc_change_ms
        return 0

    def retire_accel(self, noisy):
        """The accelerometer retired for the flight: the barometer contradicted it beyond any
        barometric error (HEALTH_ACCEL_IMPLAUSIBLE, docs/DESIGN.md D16 rule 14), or ``noisy``: it
        reads noise (HEALTH_ACCEL_NOISY, rule 15). From the next sample on, the board flies as
        one without an accelerometer (its readings unused, ``accel_ok`` False, the flag in
        ``flags``)."""
        self.accel_ok = False
        self._board_mask &= _HAVE_BARO
        self.retired |= HEALTH_ACCEL_NOISY if noisy else HEALTH_ACCEL_IMPLAUSIBLE

    def retire_baro(self):
        """The barometer retired for the flight: in coast (above the Mach lockout too) it read no
        climb farther below the accelerometer-carried filter than a barometric lie
        (HEALTH_BARO_IMPLAUSIBLE, docs/DESIGN.md D16 rule 20: frozen under its noise). From the
        next sample on, the board flies as one without a barometer (its readings unused,
        ``baro_ok`` False, the flag in ``flags``)."""
        self.baro_ok = False
        self._board_mask &= _HAVE_ACCEL
        self.retired |= HEALTH_BARO_IMPLAUSIBLE


def check_health(health, now_ms, dt_ms, alt_mm, accel_mmps2, have, in_flight):
    """The usable readings of this sample: ``have`` without the readings that cannot be
    trusted, judged alone and over time (``in_flight``: after launch); counts each sensor's
    time without a usable reading and sets ``flags``, ``changed`` and ``clipped``.

    One call per sample, the sensors written out, and a module-level function taking the
    health (on MicroPython a method call costs as much as a dozen arithmetic operations, a
    function call half as much; docs/BENCHMARKS.md, "Per-sample cost")."""
    # the readings alone: a sensor the board does not have, a pressure outside the table, a
    # reading at the accelerometer's full scale
    board = health._board_mask
    have &= board
    if have & _HAVE_BARO and (alt_mm >= ALT_TOP_MM or alt_mm <= ALT_BOTTOM_MM):
        have &= _HAVE_ACCEL  # an out-of-range pressure is not a reading
    limit = health.accel_limit_mmps2
    clipped = False
    if have & _HAVE_ACCEL and limit and (accel_mmps2 >= limit or accel_mmps2 <= -limit):
        have &= _HAVE_BARO  # a clipped reading under-reads: use the barometer alone
        health.accel_clipped += 1
        clipped = True
        # a clip run, as one held at the flight's largest reading (below): a sample without a
        # reading after it is judged as the clip
        health._clip_run_ms = health._acc_change_ms
        health._clip_held_n = _CLIP_HOLD_N
    # over time: frozen runs, impossible steps, a peak held at full scale (in flight only,
    # where noise is certain; on the pad shared/padcal.py judges barometric jumps)
    # (a run of identical readings that starts on this sample is not frozen: the stuck times
    # are at least 0.1 s, so its test is skipped)
    flags = 0
    moved = False
    has_baro = board & _HAVE_BARO
    if has_baro:
        seen = health._baro_seen
        if have & _HAVE_BARO:
            step = alt_mm - health._baro_last
            if step < 0:
                step = -step
            # (a step within _SPIKE_ALLOW_MM is within any rate's bound: the rate's test, a
            # multiply and a division, only for a larger one)
            if in_flight and seen and step > _SPIKE_ALLOW_MM:
                since_ms = now_ms - health._baro_fresh_ms
                if since_ms > _RATE_DT_MAX_MS:
                    pass  # a gap: no rate judged
                elif step > health.baro_rate_max_mmps * since_ms // 1000 + _SPIKE_ALLOW_MM:
                    have &= _HAVE_ACCEL
                    health.baro_spikes += 1
                    # impossible readings for _ERRATIC_RUN_MS in a row are a broken part, and one
                    # of its readings that passes by chance is no measurement either: none is
                    # used until it has read nothing impossible for _ERRATIC_HOLD_MS
                    if health._baro_fresh_ms != health.baro_spike_ms:  # (the reading before was good)
                        health._spike_run_ms = now_ms
                    elif now_ms - health._spike_run_ms >= _ERRATIC_RUN_MS:
                        health._baro_erratic_ms = now_ms + _ERRATIC_HOLD_MS
                    health.baro_spike_ms = now_ms
                elif (health.arb is not None and health.arb.valid and health.arb.baro_agrees()
                      and health.baro_pulse_ms != health._baro_fresh_ms):
                    # while its last window agreed with the accelerometer's bounds: off the path
                    # of that window's rate by more than any motion, a pressure pulse, not motion
                    # (D16 rule 19); no sign of a broken part (not counted in a run of impossible
                    # readings). A pulse is one reading: the next one off the path too is a step,
                    # used, so that the arbitration judges it (two left out at 10 Hz emptied a
                    # slot, and its windows went unjudged through the step).
                    # (The rate is at most 1 km per 0.5 s: the product stays in 31 bits)
                    off = alt_mm - health._baro_last - health.arb.baro_rate_mmps * since_ms // 1000
                    if off < 0:
                        off = -off
                    if off > _PATH_TOL_MMPS * since_ms // 1000 + _SPIKE_ALLOW_MM:
                        have &= _HAVE_ACCEL
                        health.baro_spikes += 1
                        health.baro_pulse_ms = now_ms
            if step or not seen:
                health._baro_run_ms = now_ms
                moved = True
            health._baro_last = alt_mm
            health._baro_fresh_ms = now_ms
            if not seen:
                health._baro_seen = seen = True
            if now_ms < health._baro_erratic_ms:
                have &= _HAVE_ACCEL
        if (not moved and in_flight and seen
                and now_ms - health._baro_run_ms >= health.baro_stuck_ms):
            flags = HEALTH_BARO_STUCK
            have &= _HAVE_ACCEL
    health.baro_moved = moved
    has_accel = board & _HAVE_ACCEL
    if has_accel:
        seen = health._acc_seen
        run_now = False
        if have & _HAVE_ACCEL:
            size = accel_mmps2 if accel_mmps2 >= 0 else -accel_mmps2
            peak = health._acc_peak
            if in_flight and size > peak:
                health._acc_peak = peak = size
            jump = accel_mmps2 - health._acc_last
            held = not jump and seen
            if jump < 0:
                jump = -jump
            if jump > _JUMP_CAP_MMPS2:
                jump = _JUMP_CAP_MMPS2
            avg = health.acc_jitter
            health.acc_jitter = avg + ((jump - avg) >> _JUMP_AVG_SHIFT)
            if not held:
                health._acc_change_ms = now_ms
            if (in_flight and held and size >= peak and size > _ONE_G_MMPS2
                    and size >= health._early_clip_mmps2):
                # held at the largest reading of the flight: the part's full scale (an
                # unknown range, or a part that clips early: not below half its configured
                # range), once held _CLIP_HOLD_MS (two equal readings at a noisy peak are
                # chance), over at least _CLIP_HOLD_N readings (two equal readings either side
                # of a gap in the log are no run); never frozen
                if health._clip_run_ms != health._acc_change_ms:
                    health._clip_run_ms = health._acc_change_ms
                    health._clip_held_n = 0
                health._clip_held_n += 1
                if (health._clip_held_n >= _CLIP_HOLD_N
                        and now_ms - health._acc_change_ms >= _CLIP_HOLD_MS):
                    have &= _HAVE_BARO
                    health.accel_clipped += 1
                    clipped = True
            elif not held or size < _ONE_G_MMPS2:
                run_now = True
            if run_now:
                health._acc_run_ms = now_ms
            health._acc_last = accel_mmps2
            if not seen:
                health._acc_seen = seen = True
        # (a sample without a reading after a clip run's last one: a clip, else a 16 g part
        # clipped through a 3 s boost and missing one reading was frozen for the flight)
        if (not run_now and in_flight and seen
                and now_ms - health._acc_run_ms
                >= (health.max_boost_ms if clipped or not have & _HAVE_ACCEL
                    and health._clip_run_ms == health._acc_change_ms
                    and health._clip_held_n >= _CLIP_HOLD_N else health.accel_stuck_ms)):
            flags |= HEALTH_ACCEL_STUCK
            have &= _HAVE_BARO
            clipped = False  # frozen, not clipped: not a reading at all
    health.clipped = clipped
    # lost: the time without a usable reading (a frozen sensor's readings are not usable
    # either); a sensor silent for sensor_lost_s no longer proves anything
    # (each value stored only when it changes: a store costs more than the test)
    lost_ms = health.lost_ms
    age = health.baro_age_ms
    if have & _HAVE_BARO:
        if age:
            health.baro_age_ms = age = 0
    elif age < _AGE_LIMIT_MS - dt_ms:
        age += dt_ms
        health.baro_age_ms = age
    ok = False
    if has_baro:
        ok = age < lost_ms
        if not ok:
            flags |= HEALTH_BARO_LOST
    else:
        flags |= health.retired
    health.baro_ok = ok
    age = health.accel_age_ms
    if have & _HAVE_ACCEL or clipped:  # clipped: alive, at full scale
        if age:
            health.accel_age_ms = age = 0
    elif age < _AGE_LIMIT_MS - dt_ms:
        age += dt_ms
        health.accel_age_ms = age
    ok = False
    if has_accel:
        ok = age < lost_ms
        if not ok:
            flags |= HEALTH_ACCEL_LOST
    else:
        flags |= health.retired
    health.accel_ok = ok
    changed = flags != health.flags
    health.changed = changed
    if changed:
        health.flags = flags
    return have
