"""Pad calibration: the ground reference (altitude and the accelerometer's 1 g) from quiet pad
samples, re-based on a pressure step, and the board's orientation check (docs/DESIGN.md D4, D8).

Portable and allocation-free per sample. Quiet samples are averaged in blocks of
``_CAL_BLOCK_MS``; the ground reference is the older of the last two complete blocks, so the
samples just before a launch (ignition, first motion) never enter it. With no complete block yet
(a short pad), all quiet samples so far are used.

Each sensor's readings are averaged apart: the sensors need not share samples (a barometer slower
than the accelerometer, or each sensor on its own row), and a sample without a reading of one
sensor adds nothing to that sensor's average. A barometric reading is quiet if the accelerometer
readings on both sides of it are (it waits for the next one's verdict); with no accelerometer
reading for _ACCEL_HOLD_MS it is judged alone. When the first samples carry no barometric reading,
the first one is the reference (not a pressure step).
"""

try:
    from micropython import const
except ImportError:
    def const(x):
        return x

from shared.detector import HAVE_ACCEL, HAVE_BARO
from shared.physics import G_MMPS2

_CAL_BLOCK_MS = const(1000)
_PAD_OFFSET_LIMIT_MM = const(0xFFFFF)  # 2**20 - 1: 1 km
# The pad reading of the axis must be within 50% of 1 g (see _check_orientation): a wrong part or
# range, an inverted mount, or a board lying down (docs/DESIGN.md D4).
_ONE_G_MIN = const(4903)
_ONE_G_MAX = const(14710)
# On the pad a barometric jump from the filter larger than this (mm) is not a climb: a pressure
# step (av-bay sealed, a gust) when the next reading stays with it, and the filter and the ground
# reference re-base on the new level; else a glitch, not used.
PAD_BARO_JUMP_MM = const(50000)
# A pad sample pushing up (0.5 g above the 1 g reference) while the barometer reads a climb (3 m:
# three times a quiet pad's noise) and the filter climbs (3 m/s) is not quiet: a rocket of low
# thrust-to-weight (below launch_accel_mps2) must not calibrate its own boost into 1 g and the
# ground. A board at rest that reads too much (a wrong range) does not climb: its orientation
# check still sees it.
_PUSH_MMPS2 = const(4903)
_QUIET_CLIMB_MM = const(3000)
_QUIET_SPEED_MMPS = const(3000)
# A climb that outruns the pad's filter on the barometer alone (update_pad): the filter's upward
# acceleration below 100 g (the hardest boosts reach 60 to 100 g; a pressure step read by the
# filter, far more), and the reading within 1 km/s (mm per ms) of the last one, taken less than a
# second before (which also keeps the product in 31 bits)
_CLIMB_ACC_MAX_MMPS2 = const(980700)
_CLIMB_MM_PER_MS = const(1000)
_CLIMB_GAP_MAX_MS = const(1000)

# Error flags (bits of FlightComputer.errors that this module owns).
ERR_ORIENTATION = const(1)  # pad accelerometer reading is not about +1 g
ERR_PAD_BARO_STEP = const(4)  # the barometer jumped on the pad (a step, or a glitch)
ERR_BARO_ERRATIC = const(8)  # repeated steps on the pad: a faulty barometer; no launch by height
PAD_ERRORS = const(13)  # ERR_ORIENTATION | ERR_PAD_BARO_STEP | ERR_BARO_ERRATIC
# The ground at launch is the reference as it stood at least this long before the launch sample
# (two history slots of _HISTORY_MS): ignition, first motion and a bad reading on the launch
# sample itself (which the re-base above would take as the ground) never enter it.
_HISTORY_MS = const(100)
# An accelerometer verdict (quiet or not) stands for this long: the period of the slowest rate the
# filter knows (10 Hz). A barometric reading after a longer silence of the accelerometer is judged
# alone, as on a board without one.
_ACCEL_HOLD_MS = const(100)


class PadCalibration:
    """Ground references from the pad (see the module docstring)."""

    def __init__(self, config, ground_alt_mm=None):
        self.has_baro = config.has_baro
        self.has_accel = config.has_accel
        self.launch_accel_mmps2 = config.launch_accel_mmps2
        self.ground_fixed = ground_alt_mm is not None
        self.ground_alt_mm = ground_alt_mm if ground_alt_mm is not None else 0
        self.one_g_mmps2 = G_MMPS2
        self.cal_samples = 0  # quiet pad samples that went into the current reference
        self.errors = 0  # PAD_ERRORS bits
        self.upright = False  # the latest orientation check passed (none yet: False)
        self._jumps = 0
        self._last_jump_ms = 0
        self._ref_mm = 0  # the altitude the block sums are offsets from
        self._ref_pending = False  # no barometric reading yet: the reference is the first one
        # sums and counts of quiet pad readings, each sensor apart: this block and the previous one
        # (altitude offsets from _ref_mm; accelerometer readings). Before the first complete block
        # (no quiet reading in the previous one) this block holds every quiet reading so far: a
        # block that ends empty adds nothing, a re-base empties both
        self._blk_alt = self._blk_alt_n = self._blk_acc = self._blk_acc_n = 0
        self._blk_start_ms = 0
        self._prev_alt = self._prev_alt_n = self._prev_acc = self._prev_acc_n = 0
        self._accel_quiet = True  # the verdict of the last accelerometer reading
        self._accel_ms = 0  # when it was taken
        self._pend_alt = self._pend_alt_n = 0  # barometric readings awaiting the next verdict
        self._baro_ms = -1  # when the last barometric reading was taken (-1: none since a re-base
        # or a jump)
        self._baro_alt_mm = 0  # that reading
        self._hist_ms = 0  # when the newest history slot was taken
        self._hist0 = 0  # the ground reference at the last three 100 ms ticks, newest first
        self._hist1 = 0
        self._hist2 = 0

    def start(self, alt_mm, have):
        """First sample: the provisional ground is its barometric altitude. Returns that datum."""
        self._ref_mm = alt_mm if have & HAVE_BARO else 0
        self._ref_pending = self.has_baro and not have & HAVE_BARO
        if not self.ground_fixed:
            self.ground_alt_mm = self._ref_mm
        self._hist0 = self._hist1 = self._hist2 = self.ground_alt_mm
        return self._ref_mm

    def launch_ground(self):
        """The ground reference from the samples ending at least 0.2 s before now (on a pad
        shorter than that: the first sample's)."""
        return self._hist2

    def _rebase(self, alt_mm, kf):
        """Restart the filter and the averages at the barometric altitude ``alt_mm``."""
        kf.reset(alt_mm, 0, 0)
        self._ref_mm = alt_mm
        self._blk_alt = self._blk_alt_n = self._blk_acc = self._blk_acc_n = 0
        self._prev_alt = self._prev_alt_n = self._prev_acc = self._prev_acc_n = 0
        self._pend_alt = self._pend_alt_n = 0
        self._baro_ms = -1
        if not self.ground_fixed:
            self.ground_alt_mm = alt_mm


def update_pad(pad, now_ms, alt_mm, accel_mmps2, have, kf):
    """Average a quiet pad sample's readings into the references; re-base ``kf`` on a pressure
    step (or on the first barometric reading when the first samples had none). Returns ``have``,
    without the barometer when its reading is a glitch (for the filter too).

    A module-level function taking the calibration, whose usual path calls no method: on
    MicroPython a method call costs as much as a dozen arithmetic operations, a function call half
    as much (docs/BENCHMARKS.md, "Per-sample cost")."""
    if now_ms - pad._hist_ms >= _HISTORY_MS:  # the history of the ground reference
        pad._hist2 = pad._hist1
        pad._hist1 = pad._hist0
        pad._hist0 = pad.ground_alt_mm
        pad._hist_ms = now_ms
    baro = have & HAVE_BARO
    if baro:
        if pad._ref_pending:  # the first barometric reading: the first samples had none
            pad._ref_pending = False
            pad._rebase(alt_mm, kf)
            pad._hist0 = pad._hist1 = pad._hist2 = pad.ground_alt_mm
            return have
        jump = alt_mm - (kf.alt_q4 >> 4)
        if jump > PAD_BARO_JUMP_MM or jump < -PAD_BARO_JUMP_MM:
            acc = kf.acc_q4 >> 4
            if (not pad.has_accel and jump > 0 and kf.vel_q4 >> 4 > _QUIET_SPEED_MMPS
                    and _PUSH_MMPS2 < acc < _CLIMB_ACC_MAX_MMPS2
                    and pad._baro_ms >= 0 and now_ms - pad._baro_ms < _CLIMB_GAP_MAX_MS
                    and alt_mm - pad._baro_alt_mm <= (now_ms - pad._baro_ms) * _CLIMB_MM_PER_MS):
                # on the barometer alone (its launch by height) a climb that outran the pad's
                # filter, not a step: the filter climbs and accelerates upward as a boost does, and
                # the reading moved on from the last one no faster than a rocket (a 200 m step in
                # one reading is not a climb). It takes the reading's altitude and keeps its
                # velocity; the ground stays. (With an accelerometer its boost launches first, and
                # a knock moves the filter: a jump there stays a step or a glitch)
                kf.set_altitude(alt_mm)
                pad._baro_ms = now_ms
                pad._baro_alt_mm = alt_mm
                return have
            pad.errors |= ERR_PAD_BARO_STEP
            # a step stays: the reading before this one jumped too (a reading near the filter
            # sets ``_baro_ms``, a jump clears it). A single reading off and back is a glitch (a
            # bus error, a reading taken mid-conversion): not used, not a step
            if pad._baro_ms >= 0:
                pad._baro_ms = -1
                return have & HAVE_ACCEL
            # one step is weather or the av-bay; three within a second is a broken sensor
            pad._jumps = pad._jumps + 1 if now_ms - pad._last_jump_ms < 1000 else 1
            pad._last_jump_ms = now_ms
            if pad._jumps >= 3:
                pad.errors |= ERR_BARO_ERRATIC
            pad._rebase(alt_mm, kf)
            return have
        if pad.errors & ERR_BARO_ERRATIC and now_ms - pad._last_jump_ms > 2000:
            pad.errors &= ~ERR_BARO_ERRATIC
        pad._baro_ms = now_ms
        pad._baro_alt_mm = alt_mm
        d_alt = alt_mm - pad._ref_mm
        # bounded so that a block's sum stays in 31 bits (1 km x 200 samples at 200 Hz) even if
        # the board sits in pad mode while the barometer sees a flight (launch refused)
        if d_alt > _PAD_OFFSET_LIMIT_MM:
            d_alt = _PAD_OFFSET_LIMIT_MM
        elif d_alt < -_PAD_OFFSET_LIMIT_MM:
            d_alt = -_PAD_OFFSET_LIMIT_MM
    if have & HAVE_ACCEL:
        limit = pad.launch_accel_mmps2
        acc_kin = accel_mmps2 - pad.one_g_mmps2
        # quiet: no boost, and not climbing under a push (a slow boost) by the barometer's
        # reading on this sample or just before it
        quiet = -limit < acc_kin < limit and not (
            acc_kin > _PUSH_MMPS2 and pad._baro_ms >= 0 and now_ms - pad._baro_ms < _ACCEL_HOLD_MS
            and kf.vel_q4 >> 4 > _QUIET_SPEED_MMPS
            and pad._baro_alt_mm - pad.ground_alt_mm > _QUIET_CLIMB_MM)
        # the barometric readings since the previous accelerometer reading were quiet if the
        # accelerometer readings on both sides of them are (none on the usual sample: the
        # pending sums are then empty already)
        pend_n = pad._pend_alt_n
        if pend_n:
            if quiet and pad._accel_quiet:
                _add_alt(pad, pad._pend_alt, pend_n)
            pad._pend_alt = pad._pend_alt_n = 0
        pad._accel_quiet = quiet
        pad._accel_ms = now_ms
        if not quiet:
            return have
        if baro:  # (_add_alt written out: the usual pad sample)
            pad._blk_alt += d_alt
            pad._blk_alt_n += 1
        pad._blk_acc += accel_mmps2
        pad._blk_acc_n += 1
    elif baro:
        if not pad.has_accel or now_ms - pad._accel_ms >= _ACCEL_HOLD_MS:
            _add_alt(pad, d_alt, 1)  # no accelerometer (lately): the barometer alone
        elif pad._accel_quiet:
            pad._pend_alt += d_alt  # quiet if the next accelerometer reading is
            pad._pend_alt_n += 1
    first = pad._prev_alt_n + pad._prev_acc_n == 0  # no complete block yet
    if now_ms - pad._blk_start_ms >= _CAL_BLOCK_MS:
        # two blocks (2 s) so that coarse quantisation or handling cannot make it flicker
        n = pad._blk_acc_n + pad._prev_acc_n
        if n:
            _check_orientation(pad, (pad._blk_acc + pad._prev_acc) // n)
        if not first:
            _apply(pad, pad._prev_alt, pad._prev_alt_n, pad._prev_acc, pad._prev_acc_n)
        pad._prev_alt = pad._blk_alt
        pad._prev_alt_n = pad._blk_alt_n
        pad._prev_acc = pad._blk_acc
        pad._prev_acc_n = pad._blk_acc_n
        pad._blk_alt = pad._blk_alt_n = pad._blk_acc = pad._blk_acc_n = 0
        pad._blk_start_ms = now_ms
    elif first:  # all quiet readings so far: this block's (every sample of the first second)
        _apply(pad, pad._blk_alt, pad._blk_alt_n, pad._blk_acc, pad._blk_acc_n)
    return have


def _check_orientation(pad, one_g):
    """Quiet pad readings must average 1 g +-50% on the axis: catches a wrong part (ADXL345 for
    ADXL375: 12.5 g or 0.08 g), a range setting off by 2 or more, an inverted mount (-1 g), a
    board lying down (0 g), and passes an ADXL375 at the edge of its datasheet offset
    (+-0.4 g) and scale (+-5%) on a rail tilted up to 30 degrees. Flags ERR_ORIENTATION, which
    forbids launch, until the readings pass again."""
    if not pad.has_accel:
        return
    if _ONE_G_MIN <= one_g <= _ONE_G_MAX:
        pad.errors &= ~ERR_ORIENTATION
        pad.upright = True
    else:
        pad.errors |= ERR_ORIENTATION
        pad.upright = False


def _apply(pad, alt_sum, alt_n, acc_sum, acc_n):
    """Take averages as the ground references. Sums are of altitude offsets from _ref_mm
    (metres) and of ~1 g readings over a few hundred samples: well inside 31 bits. An
    accelerometer average outside 1 g +-50% is not used (a short pad may hold the first
    motion): the nominal 1 g stays. (A module-level function: in the first second it runs on
    every pad sample.)"""
    if alt_n:
        if not pad.ground_fixed:
            pad.ground_alt_mm = pad._ref_mm + alt_sum // alt_n
        pad.cal_samples = alt_n
    if acc_n:
        one_g = acc_sum // acc_n
        if pad.has_accel and _ONE_G_MIN <= one_g <= _ONE_G_MAX:
            pad.one_g_mmps2 = one_g
        if not alt_n:
            pad.cal_samples = acc_n


def _add_alt(pad, alt_sum, n):
    """Add barometric offsets to the block's sums (readings that waited for the next
    accelerometer verdict, or without an accelerometer). A module-level function: on MicroPython
    a method call costs up to three times a function call."""
    pad._blk_alt += alt_sum
    pad._blk_alt_n += n
