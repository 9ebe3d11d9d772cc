"""Pad calibration: the ground reference (altitude and the accelerometer's 1 g) from quiet pad
samples, re-based on a pressure step, and the board's orientation check (docs/DESIGN.md D4, D8).

Portable and allocation-free per sample. Quiet samples are averaged in blocks of
``_CAL_BLOCK_MS``; the ground reference is the older of the last two complete blocks, so the
samples just before a launch (ignition, first motion) never enter it. With no complete block yet
(a short pad), all quiet samples so far are used.
"""

try:
    from micropython import const
except ImportError:
    def const(x):
        return x

from shared.detector import HAVE_ACCEL, HAVE_BARO

_CAL_BLOCK_MS = const(1000)
_PAD_OFFSET_LIMIT_MM = const(0xFFFFF)  # 2**20 - 1: 1 km
G_MMPS2 = const(9807)
# The pad reading of the axis must be within 50% of 1 g (see check_orientation): a wrong part or
# range, an inverted mount, or a board lying down (docs/DESIGN.md D4).
_ONE_G_MIN = const(4903)
_ONE_G_MAX = const(14710)
# On the pad a barometric jump larger than this (mm) is a pressure step (av-bay sealed, a gust,
# a glitch), not a climb: the filter and the ground reference re-base on the new level.
PAD_BARO_JUMP_MM = const(50000)

# Error flags (bits of FlightComputer.errors that this module owns).
ERR_ORIENTATION = const(1)  # pad accelerometer reading is not about +1 g
ERR_PAD_BARO_STEP = const(4)  # the barometer jumped on the pad (re-based)
ERR_BARO_ERRATIC = const(8)  # repeated jumps on the pad: a faulty barometer; launch is forbidden
PAD_ERRORS = const(13)  # ERR_ORIENTATION | ERR_PAD_BARO_STEP | ERR_BARO_ERRATIC


class PadCalibration:
    """Ground references from the pad (see the module docstring)."""

    def __init__(self, config, ground_alt_mm=None):
        self.has_accel = config.has_accel
        self.launch_accel_mmps2 = config.launch_accel_mmps2
        self.ground_fixed = ground_alt_mm is not None
        self.ground_alt_mm = ground_alt_mm if ground_alt_mm is not None else 0
        self.one_g_mmps2 = G_MMPS2
        self.cal_samples = 0  # quiet pad samples that went into the current reference
        self.errors = 0  # PAD_ERRORS bits
        self._jumps = 0
        self._last_jump_ms = 0
        self._ref_mm = 0  # the altitude the block sums are offsets from
        self._blk_alt = 0
        self._blk_acc = 0
        self._blk_n = 0
        self._blk_start_ms = 0
        self._prev_alt = 0
        self._prev_acc = 0
        self._prev_n = 0
        self._all_alt = 0
        self._all_acc = 0
        self._all_n = 0

    def start(self, alt_mm, have):
        """First sample: the provisional ground is its barometric altitude. Returns that datum."""
        self._ref_mm = alt_mm if have & HAVE_BARO else 0
        if not self.ground_fixed:
            self.ground_alt_mm = self._ref_mm
        return self._ref_mm

    def update(self, now_ms, alt_mm, accel_mmps2, have, kf):
        """Average a quiet pad sample into the references; re-base ``kf`` on a pressure step."""
        if have & HAVE_BARO:
            jump = alt_mm - (kf.alt_q4 >> 4)
            if jump > PAD_BARO_JUMP_MM or jump < -PAD_BARO_JUMP_MM:
                self.errors |= ERR_PAD_BARO_STEP
                # one step is weather or the av-bay; three within a second is a broken sensor
                self._jumps = self._jumps + 1 if now_ms - self._last_jump_ms < 1000 else 1
                self._last_jump_ms = now_ms
                if self._jumps >= 3:
                    self.errors |= ERR_BARO_ERRATIC
                kf.reset(alt_mm, 0, 0)
                self._ref_mm = alt_mm
                self._blk_alt = self._blk_acc = self._blk_n = 0
                self._prev_n = self._all_n = 0
                self._all_alt = self._all_acc = 0
                if not self.ground_fixed:
                    self.ground_alt_mm = alt_mm
                return
            if self.errors & ERR_BARO_ERRATIC and now_ms - self._last_jump_ms > 2000:
                self.errors &= ~ERR_BARO_ERRATIC
        if have & HAVE_ACCEL:
            limit = self.launch_accel_mmps2
            quiet = -limit < accel_mmps2 - self.one_g_mmps2 < limit
            acc = accel_mmps2
        else:
            quiet = True
            acc = G_MMPS2
        if not quiet:
            return
        d_alt = alt_mm - self._ref_mm if have & HAVE_BARO else 0
        # bounded so that a block's sum stays in 31 bits (1 km x 200 samples at 200 Hz) even if
        # the board sits in pad mode while the barometer sees a flight (launch refused)
        if d_alt > _PAD_OFFSET_LIMIT_MM:
            d_alt = _PAD_OFFSET_LIMIT_MM
        elif d_alt < -_PAD_OFFSET_LIMIT_MM:
            d_alt = -_PAD_OFFSET_LIMIT_MM
        self._blk_alt += d_alt
        self._blk_acc += acc
        self._blk_n += 1
        if self._prev_n == 0:
            self._all_alt += d_alt
            self._all_acc += acc
            self._all_n += 1
        if now_ms - self._blk_start_ms >= _CAL_BLOCK_MS:
            # two blocks (2 s) so that coarse quantisation or handling cannot make it flicker
            self.check_orientation((self._blk_acc + self._prev_acc) // (self._blk_n + self._prev_n))
            if self._prev_n:
                self._apply(self._prev_alt, self._prev_acc, self._prev_n)
            self._prev_alt = self._blk_alt
            self._prev_acc = self._blk_acc
            self._prev_n = self._blk_n
            self._blk_alt = self._blk_acc = self._blk_n = 0
            self._blk_start_ms = now_ms
        elif self._prev_n == 0:
            self._apply(self._all_alt, self._all_acc, self._all_n)

    def check_orientation(self, one_g):
        """Quiet pad readings must average 1 g +-50% on the axis: catches a wrong part (ADXL345 for
        ADXL375: 12.5 g or 0.08 g), a range setting off by 2 or more, an inverted mount (-1 g), a
        board lying down (0 g), and passes an ADXL375 at the edge of its datasheet offset
        (+-0.4 g) and scale (+-5%) on a rail tilted up to 30 degrees. Flags ERR_ORIENTATION, which
        forbids launch, until the readings pass again."""
        if not self.has_accel:
            return
        if _ONE_G_MIN <= one_g <= _ONE_G_MAX:
            self.errors &= ~ERR_ORIENTATION
        else:
            self.errors |= ERR_ORIENTATION

    def _apply(self, alt_sum, acc_sum, n):
        """Take averages as the ground references. Sums are of altitude offsets from _ref_mm
        (metres) and of ~1 g readings over a few hundred samples: well inside 31 bits. An
        accelerometer average outside 1 g +-50% is not used (a short pad may hold the first
        motion): the nominal 1 g stays."""
        if not self.ground_fixed:
            self.ground_alt_mm = self._ref_mm + alt_sum // n
        one_g = acc_sum // n
        if self.has_accel and _ONE_G_MIN <= one_g <= _ONE_G_MAX:
            self.one_g_mmps2 = one_g
        self.cal_samples = n
