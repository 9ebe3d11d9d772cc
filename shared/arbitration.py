"""Sensor arbitration by physics: the accelerometer's bounds on the vertical velocity, and the
test of the barometer against them (docs/DESIGN.md, "Sensor arbitration").

Portable and allocation-free per sample.

Velocity bounds. From launch, the kinematic acceleration (specific force minus the pad's 1 g) is
integrated into ``vel_mmps``. Its error is bounded: a bias left after pad calibration
(``accel_bias_max_mps2``) errs by at most b per second; a tilt of at most ``accel_tilt_max_deg``
between the sensing axis and the vertical hides (1 - cos tilt) of the specific force (a tilted
flight path), and a board mounted off-axis (calibrated on the pad at g cos tilt) reads cos tilt of
the true kinematic acceleration: both errors are within (1 / cos tilt - 1) of the reading. So
``margin_mmps`` grows each sample by
(b + (1 / cos tilt - 1) max(|specific force|, |kinematic acceleration|)) dt, and the true vertical
velocity lies within ``vel_mmps`` +- ``margin_mmps``. A clipped reading under-reads: the lower
bound stays valid, the upper one does not (``upper_valid``). A coasting rocket's reading left out
(beyond drag: a shock, a tumble, or a motor lighting before the boost rule takes it; or outside
the filter's gate, docs/DESIGN.md D16 rule 16) holds the velocity; the margin grows 1 g x dt,
and the upper bound alone by the reading beyond that (``upper_extra_mmps``, docs/DESIGN.md D19).
A frozen or lost accelerometer (``shared/health.py``) ends the track (``valid``).

Barometer consistency. Readings are averaged in slots of ``_SLOT_MS``; the climb rate between
the newest slot and the one ``_WINDOW_SLOTS`` earlier is the mean vertical velocity over that
span, which the accelerometer's track averaged over the same slots must match within its margin
plus ``baro_consistency_mps``. A barometric change outside that (a static-port error through
Mach, an airbrake or ejection transient, a frozen sensor in flight) is not motion:
``baro_consistent`` is False until a window agrees again.
"""

from array import array

try:
    from micropython import const
except ImportError:
    def const(x):
        return x


_SLOT_MS = const(50)  # averaging slot: 5 readings at 100 Hz, 1 at 20 Hz
# a slot without a reading waits for one this long: slower barometers (10 Hz), and a 20 Hz one
# whose reading was not used, still fill every slot; a silence longer than this is a gap
_SLOT_WAIT_MS = const(200)
_WINDOW_SLOTS = const(10)  # 0.5 s window: a 200 m transient reads as 400 m/s, 6 m noise as ~8 m/s
# 1.6 s of history (at 20 Hz or faster; a slower barometer's slots are longer): the
# accelerometer-only velocity is anchored before the barometer's fault was detected (a frozen run
# is detected after baro_stuck_s, a loss after sensor_lost_s)
_HISTORY_SLOTS = const(32)
# after an inconsistent window the barometer is consistent again only when every window over this
# long agrees: a window is this long, so the transient has left it
_READMIT_MS = const(500)
_ACC_LIMIT = const(0xFFFFF)  # 2**20 - 1 mm/s^2 (107 g): keeps acc x dt_ms (<= 1000) in 31 bits
_DT_LIMIT_MS = const(1000)
_SLOT_STEP_LIMIT_MM = const(0xFFFFF)  # 2**20 - 1 mm (1 km) from the previous slot: sums in 31 bits
_VEL_LIMIT_MMPS = const(0x3FFFFF)  # 2**22 - 1 mm/s (4 km/s)
# the filter's bias estimate kept in the history: |bias| < 2**15 mm/s^2 (3.3 g, beyond any bias
# limit the configuration allows), so that bias x 4096 stays inside 31 bits (set_anchor)
_DR_BIAS_LIMIT = const(0x7FFF)
# the dead reckoning's scale correction (set_anchor): at most a quarter of the track's change (a
# datasheet scale error of 10 % plus a 30 degree tilt's 13 %), so that the track's change (< 2**23
# mm/s) / 16 x the Q12 fraction stays inside 31 bits
_DR_SCALE_LIMIT_Q12 = const(1024)
_TRACK_CHANGE_LIMIT_MMPS = const(0xFFFFF)  # 2**20 - 1 mm/s: x 100 stays inside 31 bits
# The dead reckoning (``Arbitration.dr``, set_anchor): its anchor's velocity (mm/s) and the track's
# velocity then (mm/s), the share of the track's change that is the accelerometer's error (Q12),
# and the reference for the accelerometer's calibration against the barometer in the coast
# (``note_reference``): a window's barometric rate minus the track's, and the track's (mm/s;
# _NO_REF: none)
_DR_VEL = const(0)
_DR_TRACK = const(1)
_DR_SCALE = const(2)
_DR_REF_DIFF = const(3)
_DR_REF_TRACK = const(4)
_NO_REF = const(-0x3FFFFFFF)
# The calibration needs the track to change by this much between the reference and the anchor: a
# window's rate is known to a few tenths of a m/s on the parts in docs/SENSORS.md, so the scale to
# a few per cent
_DR_CAL_MIN_MMPS = const(10000)
# a barometric rate minus the track's, taken into the calibration's share at most this large
# (262 m/s), so that it x 4096 stays inside 31 bits
_DR_DIFF_LIMIT_MMPS = const(0x3FFFF)
# The change test (``_judge``): the barometer's rate minus the track's, from one window to the
# window that ended _WINDOW_SLOTS earlier. Its noise is learnt until burnout while the test
# holds: the mean absolute change over about 2 s of windows (1/_CHANGE_AVG_N per judgement, 20 per
# second), and the tolerance is baro_change_mps plus _CHANGE_NOISE_K times it (a 20 Hz barometer
# with 6 m of noise changes its rate by about 30 m/s RMS from window to window, an AltOS part by 2
# to 5 m/s). A single bad reading moves one slot, and so two windows that are 0.5 s apart; a step
# moves every window that holds it: _CHANGE_RUN consecutive windows (0.15 s) make a step.
_CHANGE_AVG_N = const(40)
_CHANGE_NOISE_K = const(3)
_CHANGE_RUN = const(3)
_NO_DIFF = const(-0x3FFFFFFF)  # a slot whose window was not judged
# The drift test (``window_drift_test``, docs/DESIGN.md D16 rule 21): in coast
# (``change_below_mmps`` at _VEL_LIMIT_MMPS, the flight's "any speed"), the barometer in use,
# while the filter's velocity and the barometer's rate stand below _DRIFT_BELOW_MMPS, the
# barometer's rate minus the track's may fall over _DRIFT_SLOTS (1.5 s, from a window of the
# barometer's own use: _DRIFT_BACK_MS) by at most _DRIFT_MMPS plus the margin grown and three times
# the change test's learnt noise (which also covers the drag an accelerometer reading zeros leaves
# out); _DRIFT_RUN windows in a row (noise fails windows alone, a barometer that stopped measuring
# fails every one) leave it out. At these speeds the barometer's lag and static-port error change
# by far less, and over 1.5 s the accelerometer knows the change of velocity to the margin's
# growth: a barometer frozen under its noise drops to a rate of zero while the track falls by g
# every second.
_DRIFT_SLOTS = const(30)
_DRIFT_MMPS = const(5000)
_DRIFT_BELOW_MMPS = const(50000)
_DRIFT_RUN = const(10)
# ... and the older window lies this long after the agreement that took the barometer back
# began: a window of its time out of use holds the lie it was out for, and a decay that the
# readmission let through (inside baro_readmit_mps) lies on for up to its decay time, 3 s in the
# fault model (_READMIT_MS + 3 s)
_DRIFT_BACK_MS = const(3500)
# parted_beyond_lie: the time since the anchor and the filter's velocity error counted at most
# 300 s and 3 km/s, so that their product (mm) stays inside 31 bits
_PART_DT_LIMIT_MS = const(300000)
_PART_VEL_LIMIT_MPS = const(3000)
# A barometer that climbs fast (``climbs_fast``) and reads above the accelerometer-carried filter,
# or less than this below it, rises away from the accelerometer's account (D16 rule 18). A
# negative transient's return climbs back to the filter from below at L / tau (L: what is left of
# it, tau: its decay's time constant), so it is within N = 10 m and faster than the hold's F = 5 m/s
# only while F tau < L < N: for tau ln(N / (F tau)), at most N / (F e) = 0.74 s (tau = 0.74 s). A
# positive transient rises above the filter for its rise alone (0.1 to 0.5 s)
_NEAR_MM = const(10000)
# A coasting rocket's climb rate falls over a window (0.5 s) by at least g x 0.5 s and by what the
# track's does, within the accelerometer's lie: a barometric rate that fell by less than gravity
# alone allows, or by more than the track's, by more than this (plus three times its pad noise)
# is no climb (D16 rule 17) but a negative transient's return, setting in or decaying
_NOT_MOTION_MMPS = const(2000)
# A coasting rocket's rate falls with the track's, by g x 0.5 s over a window, and passes zero
# only at apogee; a frozen reading's stands at zero, so that it rises against the track's by that
# much: by more than half of it, its own rate within half of it of zero and changed by less than
# that (a transient's decay can rise as fast as gravity lowers the rocket's, but at the rate of
# its lie), the barometer stands still (``reads_no_climb``, D16 rule 23; rule 22's _STOOD_MMPS
# in shared/flight.py)
_STILL_MMPS = const(2452)


# shared.physics's G_MMPS2, folded here: on MicroPython an imported constant is a global
# (tests/shared/test_flight.py checks that the copy agrees)
_G_MMPS2 = const(9807)


def _clamp(x, limit):
    if x > limit:
        return limit
    if x < -limit:
        return -limit
    return x


class Arbitration:
    """The accelerometer's velocity bounds and the barometer's consistency with them."""

    def __init__(self, config, ballistic=None):
        # without an accelerometer in use, the coast checked against ballistics on this history
        # (shared/ballistic.py, given by the flight computer: held here, not there, where one more
        # attribute slows the step on MicroPython, docs/BENCHMARKS.md)
        self.ballistic = ballistic
        self.bias_max_mmps2 = config.accel_bias_max_mmps2
        self.tilt_loss_1024 = config.tilt_loss_1024
        self.tol_mmps = config.baro_consistency_mmps
        self.change_tol_mmps = config.baro_change_mmps
        # below this speed the change test runs (the flight raises it past any speed in coast,
        # D16 rule 20), and below the configured one a readmission's tolerance is tighter
        self.change_below_mmps = self.readmit_below_mmps = config.baro_change_below_mmps
        self.readmit_tol_mmps = config.baro_readmit_mmps
        # (from the values, not a Config attribute: one more there slowed every sample's lookups
        # of the others by 1.2k instructions on the Cortex-M0)
        self.lie_max_mm = int(config.values["baro_lie_max_m"] * 1000)
        self.transient_max_mm = int(config.values["baro_transient_max_m"] * 1000)
        self.valid = False  # the track runs (from launch, healthy accelerometer)
        self.upper_valid = False
        self.vel_mmps = 0
        self.margin_mmps = 0
        # the upper bound's own margin: readings left out in coast beyond 1 g (thrust-like: a
        # shock, a tumble, or a motor lighting), which the track did not add and the margin covers
        # only to 1 g
        self.upper_extra_mmps = 0
        self._vel_um = 0  # sub-mm/s remainders (um/s)
        self._margin_um = 0
        self.anchor_filter_mmps = 0  # see set_anchor
        self.anchor_track_mmps = 0
        self.anchor_margin_mmps = 0
        self.anchor_ms = 0
        # the dead reckoning: _DR_VEL ... _DR_REF_TRACK (a short name: the attribute table of this
        # object is on every sample's path, and this one measured fastest on the Cortex-M0)
        self.dr = array("i", [0, 0, 0, 0, _NO_REF])
        self.anchored = False  # an anchor is set and the barometer has not agreed since
        self.baro_consistent = True
        self.baro_rate_mmps = 0  # last windowed barometric climb rate
        # True: a window closed and its judgement deferred (see close_slot); None: judged, its
        # drift test deferred one sample more (see window_drift_test)
        self.judge_due = False
        self.windows_drifting = 0  # windows in a row that failed the drift test
        self._agree_ms = 0  # when the current run of agreeing windows began (-1: none)
        # history of slots: barometric altitude mean (mm), middle time (ms), and at the slot's end
        # the track's velocity, the filter's velocity and the track's margin (mm/s), and the
        # filter's accelerometer bias (mm/s^2)
        self._alt = array("i", [0] * _HISTORY_SLOTS)
        self._vel = array("i", [0] * _HISTORY_SLOTS)
        self._t = array("i", [0] * _HISTORY_SLOTS)
        self._fvel = array("i", [0] * _HISTORY_SLOTS)
        self._fbias = array("i", [0] * _HISTORY_SLOTS)
        self._margin = array("i", [0] * _HISTORY_SLOTS)
        # each judged window's barometric rate minus the track's mean velocity (mm/s; _NO_DIFF:
        # not judged), the change test's learnt noise (learnt until burnout) and its run of failing
        # windows
        self._diff = array("i", [_NO_DIFF] * _HISTORY_SLOTS)
        self._change_avg_mmps = 0
        self._change_learning = True
        self._change_run = 0
        # the learnt noise as it stood at launch: the climb holds' (``climbs_fast``)
        self.pad_noise_mmps = 0
        self._slots = 0  # slots filled (saturates at _HISTORY_SLOTS)
        self._win_vel = 0  # sum of the track's velocities over the window's slots (mm/s)
        # closes to come before the window holds no slot without a barometric reading (such a
        # window is not judged)
        self._unjudged = 0
        self._head = 0  # index of the newest slot
        self._slot_start_ms = 0
        self._alt_ref = 0  # the previous slot's mean: this slot's sums are offsets from it
        self._alt_sum = 0
        self._alt_n = 0

    def start(self, vel_mmps):
        """Launch: the track starts from the filter's velocity (it follows the accelerometer in
        the first tenth of a second of the boost)."""
        self.valid = True
        self.upper_valid = True
        self.vel_mmps = vel_mmps
        self.margin_mmps = self.upper_extra_mmps = 0
        self._vel_um = self._margin_um = 0

    def note_launch(self):
        """Launch: keep the change test's learnt noise as it stood on the pad, a barometer at rest
        (in flight a lie that moves the barometer's rate against the track's widens it)."""
        self.pad_noise_mmps = self._change_avg_mmps

    def note_burnout(self):
        """Burnout: the change test's noise stays as it was learnt on the pad and through the boost
        (in coast a barometer frozen under its noise falls to zero as a ramp that, learnt, widened
        the test ahead of it: docs/DESIGN.md D16 rule 20)."""
        self._change_learning = False

    def stop(self):
        """The accelerometer froze or was lost: its integral no longer bounds anything."""
        self.valid = False
        self.upper_valid = False
        self.baro_consistent = True

    def integrate_missing(self, dt_ms, acc_mmps2):
        """An accelerometer sample missing (dropout), or a coasting rocket's reading not used
        (``acc_mmps2``, beyond drag: a shock, a tumble, or a motor lighting before the boost rule
        takes it): the track's velocity holds, and the velocity is unknown by up to 1 g x dt more,
        and upwards by the reading beyond 1 g x dt (``upper_extra_mmps``)."""
        if not self.valid:
            return
        if dt_ms > _DT_LIMIT_MS:
            dt_ms = _DT_LIMIT_MS
        self.margin_mmps = _clamp(self.margin_mmps + _G_MMPS2 * dt_ms // 1000 + 1, _VEL_LIMIT_MMPS)
        if acc_mmps2 > _G_MMPS2:
            if acc_mmps2 > _ACC_LIMIT:
                acc_mmps2 = _ACC_LIMIT
            self.upper_extra_mmps = _clamp(self.upper_extra_mmps + (acc_mmps2 - _G_MMPS2) * dt_ms // 1000 + 1,
                                           _VEL_LIMIT_MMPS)

    def baro_agrees(self):
        """The barometer's newest window was judged (a reading in each of its slots, its
        judgement not deferred) and agreed with the accelerometer's bounds."""
        return self.baro_consistent and not self._unjudged and not self.judge_due

    def lower_mmps(self):
        """The lowest vertical velocity the accelerometer allows."""
        return self.vel_mmps - self.margin_mmps

    def upper_mmps(self):
        """The highest vertical velocity the accelerometer allows."""
        return self.vel_mmps + self.margin_mmps + self.upper_extra_mmps

    def set_anchor(self, clean, kept):
        """The barometer is no longer usable: anchor the accelerometer-only velocity at the
        oldest slot of the history (before a frozen run, a loss or a transient was detected): the
        filter's velocity then, and the track's velocity and margin then.

        The dead reckoning (rule 7's guard) takes its own anchor there too, unless one is
        ``kept`` (set at an exclusion that ended a ``clean`` run: the barometer in use in coast
        for the flight computer's _ANCHORED_MS; a later exclusion's history may hold the last
        one's decay). After a clean run it is calibrated against the barometer (``_calibrate``);
        otherwise it is the filter's velocity with the share of the track's change that the
        filter's bias estimate then blames on the accelerometer: that estimate over the track's
        deceleration in the window after the anchor (Q12, within +-_DR_SCALE_LIMIT_Q12; 0
        without a coasting window)."""
        if self.judge_due:  # it may clear ``anchored``: first, as when it is not deferred
            judge_late(self)
        i = self._head + 1 if self._slots == _HISTORY_SLOTS else self._head - self._slots + 1
        if i >= _HISTORY_SLOTS:
            i -= _HISTORY_SLOTS
        elif i < 0:
            i += _HISTORY_SLOTS
        self.anchor_filter_mmps = self._fvel[i]
        self.anchor_track_mmps = self._vel[i]
        self.anchor_margin_mmps = self._margin[i]
        self.anchor_ms = self._t[i]
        self.anchored = True
        dr = self.dr
        if clean or not kept:
            dr[_DR_VEL] = self._fvel[i]
            dr[_DR_TRACK] = self._vel[i]
            dr[_DR_SCALE] = 0
            decel = window_decel_mmps2(self, i)
            # a share only where the track decelerates as a coast does (at least g / 2: it reads
            # g plus the drag, scaled by the part's error)
            if decel > _G_MMPS2 // 2:
                dr[_DR_SCALE] = _clamp(-self._fbias[i] * 4096 // decel, _DR_SCALE_LIMIT_Q12)
            if clean:
                _calibrate(self, i, dr)
        dr[_DR_REF_TRACK] = _NO_REF  # the next clean run takes its own reference

    def dead_reckoned_mmps(self):
        """The velocity at the dead reckoning's anchor carried forward by the accelerometer
        alone: the track's change since, less the share of it that is the accelerometer's error.
        After the pad calibration the part's error is its scale error (and a tilt's) times what
        it reads: in coast it shrinks with the drag, so it is carried as a share of the track's
        change, not as a constant (docs/DESIGN.md D16 rule 7)."""
        dr = self.dr
        change = self.vel_mmps - dr[_DR_TRACK]
        return dr[_DR_VEL] + change - ((change >> 4) * dr[_DR_SCALE] >> 8)

    def anchored_upper_mmps(self):
        """Highest vertical velocity: the filter's at the anchor plus the track's change since,
        plus the margin grown since (and the upper bound's own, all of it)."""
        return (self.anchor_filter_mmps + self.vel_mmps - self.anchor_track_mmps
                + self.margin_mmps - self.anchor_margin_mmps + self.upper_extra_mmps)

    def parted_beyond_lie(self, filter_alt_mm, now_ms, lie_mm, with_margin, below=False):
        """The newest slot's barometric altitude lies farther above the filter (carried on by the
        accelerometer since the barometer was left out), or with ``below`` farther below it, than
        ``lie_mm`` (a barometric error: ``lie_max_mm``, or ``transient_max_mm`` when the rocket is
        slow) plus the filter's own error since the anchor: its velocity then known to
        ``baro_readmit_mps`` and, ``with_margin``, the track's margin grown since (both x the time
        since; the margin grows, so this bounds its integral). A barometric error is bounded in
        altitude; an accelerometer's grows with the square of time. One-sided: a barometer below
        the filter does not prove the accelerometer wrong (docs/DESIGN.md D16 rule 20). False
        while a slot of the newest window holds no reading. (A method: it runs on the rare samples
        that leave the barometer out.)"""
        if self._unjudged:
            return False
        dt_ms = now_ms - self.anchor_ms
        if dt_ms > _PART_DT_LIMIT_MS:
            dt_ms = _PART_DT_LIMIT_MS
        grown_mps = self.readmit_tol_mmps // 1000
        if with_margin:
            grown_mps += (self.margin_mmps - self.anchor_margin_mmps) // 1000
            if grown_mps > _PART_VEL_LIMIT_MPS:
                grown_mps = _PART_VEL_LIMIT_MPS
        apart = self._alt[self._head] - filter_alt_mm
        if below:
            apart = -apart
        return apart > lie_mm + grown_mps * dt_ms

    def reads_no_climb(self):
        """0 while the newest window's rate lies farther from zero than ``baro_readmit_mps`` plus
        three times the learnt noise; 1 within it, a barometer at rest (docs/DESIGN.md D16 rule
        20); 2 standing still at zero (rule 23): that rate within _STILL_MMPS plus three times
        the noise of zero, and over the window to the newest judged one it rose against the
        track's by more than _STILL_MMPS and itself changed by less than that plus three times
        the noise. (A method: it runs on the rare samples that take the barometer back.)"""
        noise = _CHANGE_NOISE_K * self._change_avg_mmps
        rate = self.baro_rate_mmps
        tol = self.readmit_tol_mmps + noise
        if not -tol < rate < tol:
            return 0
        tol = _STILL_MMPS + noise
        if not -tol < rate < tol:
            return 1
        # (the newest slot's judgement may wait a sample; an unjudged window fails; a negative
        # index wraps the history)
        head = self._head - 1
        far = head - _WINDOW_SLOTS
        rose = self._diff[head] - self._diff[far]
        if _STILL_MMPS < rose < _VEL_LIMIT_MMPS and -tol < rose - (self._vel[far] - self._vel[head]) < tol:
            return 2
        return 1

    def climbs_away(self, filter_alt_mm, floor_mmps):
        """The barometer climbs fast (``climbs_fast``) and its newest slot reads above
        ``filter_alt_mm``, or less than _NEAR_MM below it: it rises away from the
        accelerometer-carried filter (docs/DESIGN.md D16 rule 18). (A method: it runs on the rare
        samples of an accelerometer-only apogee.)"""
        return self._alt[self._head] - filter_alt_mm > -_NEAR_MM and climbs_fast(self, floor_mmps)


# The per-sample updates: module-level functions taking the arbitration (on MicroPython a method
# call costs about twice a function call; docs/BENCHMARKS.md, "Per-sample cost").


def integrate(arb, dt_ms, acc_kin_mmps2, specific_mmps2, clipped, restart=False):
    """Add one accelerometer reading (kinematic and specific force, mm/s^2) held for dt_ms; with
    ``restart``, to a track started again (``Arbitration.start(0)``: the pad at rest, every
    sample, without the method call and the stores that this reading overwrites)."""
    if dt_ms > _DT_LIMIT_MS:
        dt_ms = _DT_LIMIT_MS
    acc = acc_kin_mmps2
    if acc > _ACC_LIMIT:
        acc = _ACC_LIMIT
    elif acc < -_ACC_LIMIT:
        acc = -_ACC_LIMIT
    size = acc if acc >= 0 else -acc
    spec = specific_mmps2 if specific_mmps2 >= 0 else -specific_mmps2
    if spec > size:
        size = spec if spec < _ACC_LIMIT else _ACC_LIMIT
    if restart:
        arb.valid = arb.upper_valid = True
        arb.upper_extra_mmps = vel = vel_um = margin = margin_um = 0
    else:
        vel = arb.vel_mmps
        vel_um = arb._vel_um
        margin = arb.margin_mmps
        margin_um = arb._margin_um
    if clipped:
        arb.upper_valid = False
    um = vel_um + acc * dt_ms
    vel += um // 1000
    if vel > _VEL_LIMIT_MMPS:  # (a reading stuck at 100 g on the pad for an hour)
        vel = _VEL_LIMIT_MMPS
    elif vel < -_VEL_LIMIT_MMPS:
        vel = -_VEL_LIMIT_MMPS
    arb.vel_mmps = vel
    arb._vel_um = um % 1000
    um = margin_um + (arb.bias_max_mmps2 + (arb.tilt_loss_1024 * size >> 10)) * dt_ms
    arb.margin_mmps = margin + um // 1000
    arb._margin_um = um % 1000


def note_reference(arb):
    """The reference of the accelerometer's calibration in this run of the barometer in use in
    coast (the flight computer calls it once, _DR_REF_MS into the run): the newest judged
    window's barometric rate minus the track's, and the track's; none if it was not judged."""
    dr = arb.dr
    i = arb._head
    if arb.judge_due:  # the newest window's judgement waits for the next sample: the one before
        i = i - 1 if i else _HISTORY_SLOTS - 1
    diff = arb._diff[i]
    if diff != _NO_DIFF:
        dr[_DR_REF_DIFF] = diff
        dr[_DR_REF_TRACK] = arb.baro_rate_mmps - diff


def _calibrate(arb, i, dr):
    """The dead reckoning from a clean run's anchor (history slot ``i``): the barometer's own rate
    over the window that begins there, with the track's mean over it, and the share of the
    track's change that is the accelerometer's error, from how the barometer's rate minus the
    track's changed since the run's reference: where the track reads a change (1 + e) times
    the true one, that difference moves by -e times the true change, and the ratio of the two
    changes is the share e / (1 + e). Left as it is without a reference, on an unjudged window,
    with less than _DR_CAL_MIN_MMPS of change between them, or with a share beyond any part's
    scale error and tilt (_DR_SCALE_LIMIT_Q12): a part that parts from the barometer so far
    lies, and its lie need not scale with what it reads."""
    ref_track = dr[_DR_REF_TRACK]
    j = i + _WINDOW_SLOTS
    if j >= _HISTORY_SLOTS:
        j -= _HISTORY_SLOTS
    diff = arb._diff[j]
    span_ms = arb._t[j] - arb._t[i]
    if ref_track == _NO_REF or diff == _NO_DIFF or span_ms <= 0:
        return
    rise_mm = _clamp(arb._alt[j] - arb._alt[i], _SLOT_STEP_LIMIT_MM)
    rate = rise_mm * 1000 // span_ms
    track = rate - diff
    change = track - ref_track
    if -_DR_CAL_MIN_MMPS < change < _DR_CAL_MIN_MMPS:
        return
    share = _clamp(dr[_DR_REF_DIFF] - diff, _DR_DIFF_LIMIT_MMPS) * 4096 // change
    if -_DR_SCALE_LIMIT_Q12 <= share <= _DR_SCALE_LIMIT_Q12:
        dr[_DR_VEL] = rate
        dr[_DR_TRACK] = track
        dr[_DR_SCALE] = share


def window_decel_mmps2(arb, i):
    """The track's mean deceleration (mm/s^2) over the window that begins at history slot ``i``;
    0 while the history holds no such window."""
    if arb._slots <= _WINDOW_SLOTS:
        return 0
    j = i + _WINDOW_SLOTS
    if j >= _HISTORY_SLOTS:
        j -= _HISTORY_SLOTS
    dt_cs = (arb._t[j] - arb._t[i]) // 10
    if dt_cs <= 0:
        return 0
    return -_clamp(arb._vel[j] - arb._vel[i], _TRACK_CHANGE_LIMIT_MMPS) * 100 // dt_cs


def add_baro(arb, now_ms, alt_mm, fresh):
    """Average a barometric reading (``fresh``) into the current slot. Returns True when the slot
    is full: the caller then closes it (``close_slot``)."""
    if fresh:
        if arb._slots == 0 and arb._alt_n == 0:  # the first reading (the history's test first)
            arb._alt_ref = alt_mm
        d = alt_mm - arb._alt_ref
        if d > _SLOT_STEP_LIMIT_MM:
            d = _SLOT_STEP_LIMIT_MM
        elif d < -_SLOT_STEP_LIMIT_MM:
            d = -_SLOT_STEP_LIMIT_MM
        arb._alt_sum += d
        arb._alt_n += 1
    return now_ms - arb._slot_start_ms >= _SLOT_MS and (
        arb._alt_n or now_ms - arb._slot_start_ms >= _SLOT_WAIT_MS)


def close_slot(arb, now_ms, filter_vel_mmps, filter_bias_mmps2, defer=False):
    """Record the full slot in the history (with the track's velocity, the filter's and the margin
    at its end: half a slot later than the readings' mean, 1 m/s at 4 g) and judge the barometer
    against the accelerometer's bounds, or with ``defer`` leave the judgement to ``judge_late``
    (``judge_due``). (Every fifth sample at 100 Hz, the slowest sample of the coast: each value
    is read once, and the judgement takes the new slot's values from here.)"""
    if defer and arb.judge_due is None and arb.change_below_mmps == _VEL_LIMIT_MMPS:
        # a board stepping as slowly as its slots: before the slot moves on (in coast only: the
        # launch's slowest sample closes a slot right after a judgement)
        window_drift_test(arb)
    head = arb._head + 1
    if head == _HISTORY_SLOTS:
        head = 0
    arb._head = head
    n = arb._alt_n
    alt = arb._alt_ref
    unjudged = arb._unjudged
    if n:
        alt += arb._alt_sum // n
        arb._alt_ref = alt
        arb._alt_sum = arb._alt_n = 0
        if unjudged:
            unjudged -= 1
            arb._unjudged = unjudged
    else:  # no reading in this slot: the windows over it are not judged
        unjudged = _WINDOW_SLOTS + 1
        arb._unjudged = unjudged
    vel = arb.vel_mmps
    if filter_bias_mmps2 > _DR_BIAS_LIMIT:
        filter_bias_mmps2 = _DR_BIAS_LIMIT
    elif filter_bias_mmps2 < -_DR_BIAS_LIMIT:
        filter_bias_mmps2 = -_DR_BIAS_LIMIT
    t_ms = (arb._slot_start_ms + now_ms) >> 1
    arb._alt[head] = alt
    arb._vel[head] = vel
    arb._t[head] = t_ms
    arb._fvel[head] = filter_vel_mmps
    arb._fbias[head] = filter_bias_mmps2
    arb._margin[head] = arb.margin_mmps
    arb._diff[head] = _NO_DIFF
    arb._slot_start_ms = now_ms
    # the running sum over the window's slots (the newest _WINDOW_SLOTS + 1): add the new slot,
    # drop the one that left (re-summing the window cost 13k instructions per judgement)
    win_vel = arb._win_vel + vel
    slots = arb._slots
    if slots > _WINDOW_SLOTS:
        win_vel -= arb._vel[head - _WINDOW_SLOTS - 1]  # (a negative index wraps the history)
    arb._win_vel = win_vel
    if slots < _HISTORY_SLOTS:
        slots += 1
        arb._slots = slots
    if slots > _WINDOW_SLOTS and not unjudged:
        if defer:
            arb.judge_due = True
        else:
            _judge(arb, head, t_ms, alt, win_vel)


def reads_slow(arb, floor_mmps):
    """The barometer, just taken back, climbed slower than the accelerometer's velocity carried on
    from the anchor over the newest judged window, by more than ``floor_mmps`` plus three times
    the learnt noise of its rate: what is left of its fault lies on the early side."""
    diff = arb._diff[arb._head]
    if diff == _NO_DIFF:
        return False
    return diff + arb.anchor_track_mmps - arb.anchor_filter_mmps < -(
        floor_mmps + _CHANGE_NOISE_K * arb._change_avg_mmps)


def climbs_fast(arb, floor_mmps, any_mmps=0):
    """The track bounds the velocity from both sides, and the barometer's newest window climbed
    faster than ``floor_mmps`` plus three times the noise of its rate learnt on the pad
    (docs/DESIGN.md D16 rules 17 and 18). False while a slot of that window holds no reading (its
    rate is then an older window's). With ``any_mmps`` (rule 17), faster than ``any_mmps`` (plus
    the noise) with a track bounding both sides, or else faster than ``floor_mmps`` with a track
    running (a clip in the boost leaves its change in coast whole) and as a coasting rocket
    climbs: over the last window its rate fell by at least
    gravity's share (no thrust: else a negative transient's return setting in) and by no more
    than the track's (else a return decaying), each within _NOT_MOTION_MMPS plus the noise."""
    noise = _CHANGE_NOISE_K * arb.pad_noise_mmps
    rate = arb.baro_rate_mmps
    if not (arb.valid and rate > floor_mmps + noise and not arb._unjudged):
        return False
    if arb.upper_valid and rate > any_mmps + noise:
        return True
    if not any_mmps:
        return False
    if arb._slots < _HISTORY_SLOTS:
        return True
    head = arb._head
    before = head - _WINDOW_SLOTS
    if before < 0:
        before += _HISTORY_SLOTS
    oldest = before - _WINDOW_SLOTS
    if oldest < 0:
        oldest += _HISTORY_SLOTS
    span_ms = arb._t[before] - arb._t[oldest]
    if span_ms <= 0:
        return True
    # (the window's rise clamped as _judge clamps it: 31 bits)
    rose = rate - _clamp(arb._alt[before] - arb._alt[oldest], _SLOT_STEP_LIMIT_MM) * 1000 // span_ms
    tol = _NOT_MOTION_MMPS + noise
    return (rose + _G_MMPS2 * (arb._t[head] - arb._t[before]) // 1000 <= tol
            and rose - (arb._vel[head] - arb._vel[before]) >= -tol)


def judge_late(arb):
    """The judgement ``close_slot`` deferred, of the newest window. It must come before the track,
    the anchor or the history change, and before ``baro_consistent`` or ``baro_rate_mmps`` is read:
    it then gives what it would have on the window's close. Its drift test waits one sample
    more (``window_drift_test``)."""
    arb.judge_due = None
    head = arb._head
    _judge(arb, head, arb._t[head], arb._alt[head], arb._win_vel)


def window_drift_test(arb):
    """The drift test (D16 rule 21, see _DRIFT_MMPS) of the newest judged window, on the sample
    after its judgement: the coast's slot closes and judgements are its slowest samples, this one
    is not."""
    arb.judge_due = False
    run = 0
    if arb.change_below_mmps == _VEL_LIMIT_MMPS and arb.baro_consistent:  # in coast, in use
        head = arb._head
        far = head - _DRIFT_SLOTS  # (a negative index wraps the history)
        diffs = arb._diff
        now = diffs[head]
        drift = diffs[far]
        if (now != _NO_DIFF and drift != _NO_DIFF
                and -_DRIFT_BELOW_MMPS < arb._fvel[head] < _DRIFT_BELOW_MMPS
                and -_DRIFT_BELOW_MMPS < arb.baro_rate_mmps < _DRIFT_BELOW_MMPS
                and arb._t[far] - arb._agree_ms >= _DRIFT_BACK_MS):
            drift -= now  # how much faster than the track the barometer's rate fell
            margins = arb._margin
            if drift > (_DRIFT_MMPS + margins[head] - margins[far]
                        + _CHANGE_NOISE_K * arb._change_avg_mmps):
                run = arb.windows_drifting + 1
                if run >= _DRIFT_RUN:
                    run = 0
                    arb._agree_ms = -1
                    arb.baro_consistent = False
    arb.windows_drifting = run


def _judge(arb, head, t_ms, alt_mm, win_vel_mmps):
    """The barometer's climb rate over the window ending at slot ``head`` (its middle time, mean
    altitude and the window's sum of track velocities given), and its consistency with the
    accelerometer's bounds (``baro_consistent``)."""
    oldest = head - _WINDOW_SLOTS  # (a negative index wraps the history)
    span_ms = t_ms - arb._t[oldest]
    if span_ms <= 0:
        return
    rise_mm = alt_mm - arb._alt[oldest]
    if rise_mm > _SLOT_STEP_LIMIT_MM:
        rise_mm = _SLOT_STEP_LIMIT_MM
    elif rise_mm < -_SLOT_STEP_LIMIT_MM:
        rise_mm = -_SLOT_STEP_LIMIT_MM
    rate = rise_mm * 1000 // span_ms
    arb.baro_rate_mmps = rate
    if not arb.valid:
        arb.baro_consistent = True
        return
    track_mmps = win_vel_mmps // (_WINDOW_SLOTS + 1)
    diff = rate - track_mmps
    arb._diff[head] = diff
    margin = arb.margin_mmps
    # the change test: below baro_change_below_mps (in coast from the tail-off's end at any
    # speed: D16 rule 20) the barometer's lag and the static-port error
    # change slowly, and over half a second the accelerometer knows the change of velocity to
    # about 1 m/s: a barometric rate that changed by far more than the track's is a pressure step
    # (a -60 m step in the late coast pulled the filter's velocity through zero 2.8 s early)
    below = arb.change_below_mmps
    slow = -below < track_mmps < below
    stepped = False
    before = arb._diff[oldest]
    if arb.baro_consistent and before != _NO_DIFF and slow:
        change = diff - before
        if change < 0:
            change = -change
        avg = arb._change_avg_mmps
        if change > (arb.change_tol_mmps + margin - arb._margin[oldest]
                     + _CHANGE_NOISE_K * avg):
            arb._change_run += 1
            stepped = arb._change_run >= _CHANGE_RUN
            # nor is this window a reference for the one half a second on: once the step has left
            # the window the barometer agrees again (as with the bounds), not half a second later
            arb._diff[head] = _NO_DIFF
        else:
            arb._change_run = 0
            if arb._change_learning:
                arb._change_avg_mmps = avg + (change - avg) // _CHANGE_AVG_N
    else:
        arb._change_run = 0  # three windows in a row, each judged by the test
    allowed = margin + arb.tol_mmps
    anchored = arb.anchored
    if anchored:
        # out of use since an anchor: the velocity is known better, from the filter's then, and
        # below baro_change_below_mps to baro_readmit_mps and the learnt noise (a decaying
        # transient's rate still lies by tens of m/s when the bounds' tolerance would take it back)
        diff += arb.anchor_track_mmps - arb.anchor_filter_mmps
        tol = arb.tol_mmps
        readmit_below = arb.readmit_below_mmps
        if -readmit_below < track_mmps < readmit_below:
            tol = arb.readmit_tol_mmps + _CHANGE_NOISE_K * arb._change_avg_mmps
        allowed = margin - arb.anchor_margin_mmps + tol
    if not stepped and -allowed <= diff and (diff <= allowed + arb.upper_extra_mmps or not arb.upper_valid):
        # (a clipped track under-reads: it bounds the velocity from below only; readings left
        # out beyond 1 g widen its upper side)
        agree_ms = arb._agree_ms
        if agree_ms < 0:
            arb._agree_ms = agree_ms = t_ms
        if not arb.baro_consistent and t_ms - agree_ms >= _READMIT_MS:
            arb.baro_consistent = True
        if anchored and arb.baro_consistent:
            arb.anchored = False
    else:
        arb._agree_ms = -1
        arb.baro_consistent = False
