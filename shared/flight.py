"""Deploy state machine: decides, sample by sample, when each pyro channel fires.

Portable and allocation-free per sample (MicroPython and CPython). One ``FlightComputer`` per
flight; call ``step()`` once per sample with integer readings:

- ``dt_us``: microseconds since the previous sample (the first sample's value is ignored);
- ``alt_mm``: barometric altitude in mm, any datum (``shared.altitude.pressure_to_alt_mm``);
- ``accel_mmps2``: specific force along the rocket's axis, mm/s^2, positive towards the nose
  (+9807 standing on the pad, about 0 in drag-free coast);
- ``have``: which readings are fresh (``HAVE_BARO | HAVE_ACCEL``; a missing or stale reading is
  never used: the filter predicts across it). The sensors need not share samples: a barometer
  slower than the accelerometer, or each sensor on its own sample, is the same flight. Every
  decision uses each sensor's readings at their own times (shared/detector.py): the boost timer,
  the accelerometer's integrals and its averaged reading count the accelerometer's own intervals,
  the pad calibration averages each sensor's readings apart (shared/padcal.py), and a sample
  without a reading of one sensor holds that sensor's last verdict.

After ``step()``: ``state``, ``events`` (bit mask of what happened at this sample),
``pyro_drogue`` / ``pyro_main`` / ``pyro_backup_drogue`` / ``pyro_backup_main`` (output levels to
drive now), ``agl_mm``, ``vel_mmps``.

Each sample flows one way: sensor health (``shared/health.py``) -> pad calibration on the pad
(``shared/padcal.py``) -> the filter (``shared/detector.py``) -> the transition of the current
state (``_transition``: one branch per state) -> proof of flight -> pyro timing.

Transitions (``_transition``), each branch opening with its rule:

| state | to | condition | configuration key |
|---|---|---|---|
| pad | boost | boost acceleration sustained (barometer-only: proof climb | `launch_accel_mps2`, |
| | | and speed); never with ERR_ORIENTATION; the height never | `launch_accel_time_s` |
| | | with ERR_BARO_ERRATIC | |
| boost..coast | pad | not proven within 10 s of launch, still near the pad | `proof_climb_m` |
| boost | fast/coast | filtered acceleration below -2.5 m/s^2, or the timeout | `max_boost_s` |
| fast/coast | boost | ignition: the boost acceleration sustained again (staging, | `launch_accel_mps2`, |
| | | an air-start), before apogee, a barometer in use agreeing | `launch_accel_time_s` |
| fast | coast | estimated speed at or below the Mach lockout, and the time | `mach_lockout_mps`, |
| | | lockout after launch over | `mach_lockout_s` |
| coast | fast | estimated speed above the Mach lockout | `mach_lockout_mps` |
| boost..coast | drogue | proven, and apogee (+ delay) or the backup timer | `apogee_delay_s`, |
| | | | `backup_drogue_s` |
| drogue | main | proven, the guard time after the drogue, descending; at or | `main_deploy_m`, |
| | | below the main altitude if the maximum rose `main_margin_m` | `main_guard_s`, |
| | | above it, else at once (barometer usable) | `main_margin_m` |
| drogue | main | barometer lost or frozen (or not descending, D16 rule 24): | `main_delay_s`, |
| | | the last steady descent reaches the main altitude (none | `main_backup_s` |
| | | seen: `main_delay_s` after the drogue), | |
| | | or main_backup_s after the drogue; no barometer on the board: | |
| | | `main_delay_s` after the drogue | |
| | | main_deploy_m 0: never (no main, a single deployment) | |
| main | landed | altitude within a band over a window | `landed_alt_m` |
| drogue | landed | the same, when there is no main (main_deploy_m 0) | `landed_alt_m` |
| drogue, | (backup | proven, `backup_drogue_delay_s` after the drogue fired | `backup_drogue_delay_s` |
| main | drogue) | | |
| main | (backup | proven, `backup_main_delay_s` after the main fired at the | `backup_main_m`, |
| | main) | earliest; at or below `backup_main_m` (no usable | `backup_main_delay_s` |
| | | barometer: at once) | |

Apogee itself is declared by the filter's rule only while the barometer is in use (``mode``)
and ``_apogee_enabled()``: coast, proven,
above the proof climb, after the lockout, an averaged deceleration between ``coast_decel_mps2``
and 10 g, the accelerometer's lowest possible velocity at or below ``apogee_guard_mps``, and,
once the barometer was left out in coast, the accelerometer's velocity dead-reckoned from the
filter's before the fault at or below ``dead_reckoning_guard_mps``; and the ballistic floor
(``shared/ballistic.py``: without an accelerometer in use, set by a barometric change no coasting
rocket can make; with both sensors, by the barometer's exclusion) at or below zero. A declared
apogee is withdrawn while the barometer in use climbs fast (D16 rule 17), and while a barometer
that stands still has pulled the filter down faster than the accelerometer's track allows
(rule 22).
Without a usable barometer (``mode`` accel only) apogee is the accelerometer's highest possible
velocity reaching zero, with the filter's (``_accel_only_apogee``); with no usable sensor, only the
backup timer. The decision mode and the barometer's exclusion come from ``_arbitrate``
(docs/DESIGN.md D16); there an accelerometer that a live barometer contradicts beyond any
barometric error is retired for the flight (rule 14).

The backup channels (``_backup_rule``, off by default) change no state: each fires at most once,
only after its primary fired and never on the ground (landed).

Safety (docs/DESIGN.md D1): every firing path (apogee, apogee delay, backup timer,
main, the backup channels) requires ``flight_proven``: a boost sustained for
``launch_accel_time_s`` *and* a climb of
``proof_climb_m`` that the barometer holds for a second (barometer-only boards: that climb and
``proof_speed_mps``; accelerometer-only boards: the boost, and that speed and climb integrated
from it). Apogee
further requires coast (after burnout, below the Mach lockout), an altitude above the proof climb,
and an averaged deceleration beyond ``coast_decel_mps2``: coasting flight decelerates at about g,
a knock or a pressure step on the pad does not.
"""

import struct

try:
    from micropython import const
except ImportError:
    def const(x):
        return x

from shared import ballistic
from shared.apogee import SeedRule, VelocityRule
from shared.arbitration import (
    Arbitration,
    add_baro,
    climbs_fast,
    close_slot,
    integrate,
    judge_late,
    note_reference,
    reads_slow,
    window_drift_test,
)
from shared.attrs import make_room
from shared.detector import Detector
from shared.gains_table import PROJECT, PROJECT_LOW_NOISE
from shared.health import SensorHealth, check_health
from shared.kalman import RATE_LIMIT_Q4
from shared.padcal import (  # noqa: F401 (the error flags are re-exported)
    ERR_BARO_ERRATIC,
    ERR_ORIENTATION,
    ERR_PAD_BARO_STEP,
    PAD_BARO_JUMP_MM,
    PAD_ERRORS,
    PadCalibration,
    update_pad,
)
from shared.physics import G_MMPS2

# Folded copies of other modules' constants (each _NAME is shared.*'s NAME; see shared/health.py):
# shared.detector's reading masks and correction models, shared.health's HEALTH_*_BAD
_HAVE_BARO = const(1)
_HAVE_ACCEL = const(2)
_MODEL_PLAIN = const(0)
_MODEL_BIAS = const(1)
_MODEL_GRAVITY = const(2)
_HEALTH_BARO_BAD = const(67)
_HEALTH_ACCEL_BAD = const(60)

# States, in flight order.
PAD = const(0)
BOOST = const(1)
FAST = const(2)  # coast above the Mach lockout: barometer de-weighted, no apogee
COAST = const(3)
DROGUE = const(4)
MAIN = const(5)
LANDED = const(6)
STATE_NAMES = ("pad", "boost", "fast", "coast", "drogue", "main", "landed")

# Event bits in ``events`` (several can happen on one sample).
EV_LAUNCH = const(1)
EV_BURNOUT = const(2)
EV_APOGEE = const(4)
EV_DROGUE = const(8)
EV_MAIN = const(16)
EV_LANDED = const(32)
EV_HEALTH = const(64)  # a sensor's health changed (shared.health.HEALTH_* in health.flags)
EV_MODE = const(128)  # the sensors the decisions rest on changed (``mode``, MODE_NAMES)
# the backup channels fired (beyond the log record's event byte: the log keeps their output levels,
# shared/logformat.py FLAG_PYRO_BACKUP_*)
EV_BACKUP_DROGUE = const(256)
EV_BACKUP_MAIN = const(512)
# a motor lit in coast (staging, an air-start): back to boost (beyond the log record's event byte:
# the log keeps the state, which goes from fast or coast back to boost)
EV_IGNITION = const(1024)
EVENT_NAMES = ("launch", "burnout", "apogee", "drogue", "main", "landed", "health", "mode",
               "backup_drogue", "backup_main", "ignition")

# Decision modes (``mode``): which sensors are usable (docs/DESIGN.md, "Sensor arbitration").
MODE_TIMER = const(0)  # neither: the backup timers only
MODE_BARO = const(1)  # barometer only: speed and time lockouts (mach_lockout_mps, mach_lockout_s)
MODE_ACCEL = const(2)  # accelerometer only: apogee when its highest possible velocity is <= 0
MODE_BOTH = const(3)
MODE_NAMES = ("timer only", "baro only", "accel only", "both")

_PROOF_HOLD_MS = const(1000)  # the proof climb must be held this long
# Accelerometer-only boards cannot see a climb, so their boost must outlast any knock or drop.
_ACCEL_ONLY_BOOST_MS = const(300)
_DECEL_TAU_MS = const(500)  # time constant of the averaged acceleration used by the apogee gate
_EMA_STEP_LIMIT = const(0xFFFFF)  # 2**20 - 1: keeps (x - avg) * dt_ms within 31 bits (dt_ms <= 1000)
# Barometer-only apogee needs the filter to track the barometer (AltOS's "not transonic" check):
# the squared distance between them, each capped at _RESID_CAP_M, averaged over this time (AltOS:
# 1/16 per sample at 100 Hz)
_RESID_TAU_MS = const(160)
_RESID_CAP_M = const(127)
# Innovation gates after burnout (shared/detector.py): coasting flight changes its acceleration
# smoothly, so a reading this far from the estimate is an ejection charge, a shock or a pressure
# transient. 50 m is eight times the barometer noise the gains assume; 30 m/s^2 is three g.
GATE_ALT_MM = const(50000)
_LATE_COAST_MMPS = const(30000)  # below this vertical speed in coast, acceleration = -g
GATE_ACC_MMPS2 = const(30000)
_GATE_START_MS = const(500)
# the track's own limit (arbitration._VEL_LIMIT_MMPS, 4.2 km/s): the change test in coast runs at
# every speed (D16 rule 20)
_ANY_SPEED_MMPS = const(0x3FFFFF)
# After burnout drag only decelerates: a kinematic acceleration above this (an axial specific force
# above +0.5 g) is the motor's tail-off, an ejection charge, a shock, a tumbling rocket, or a motor
# lighting in coast (staging, an air-start: the boost rule takes the flight back to boost once the
# thrust is sustained). (-G_MMPS2 // 2, written out: on MicroPython an imported constant is a
# global, not folded; tests/shared/test_flight.py checks it)
_NOT_DRAG_MMPS2 = const(-4904)
# The detector's phase (``_det_phase``): the state (0 to 6) plus one of these flags
_PHASE_RESUMING = const(8)  # a resumed filter settling
_PHASE_TAIL_OFF = const(16)  # within _GATE_START_MS of burnout
# the largest clipped reading the filter's acceleration takes (it holds at most RATE_LIMIT_Q4)
_CLIP_ACC_LIMIT_MMPS2 = const(0x7FFFFF)  # RATE_LIMIT_Q4 >> 4: 855 g
COAST_ACC_MAX_Q4 = const(-78456)  # -0.5 g in 1/16 mm/s^2: the most a coasting rocket's vertical
# acceleration can be (it is -g - drag going up; -0.5 g leaves room for tilt and noise)
# Near apogee vertical drag vanishes: the averaged acceleration must lie between -10 g and
# -coast_decel_mps2. A filter re-converging from a large error (the barometer lying through Mach)
# swings beyond -10 g; a tumbling rocket's (319-005) stays within it.
_APOGEE_DECEL_MAX_MMPS2 = const(98067)
# On the barometer alone the bound is 2 g: at apogee the vertical drag vanishes (it is the drag
# times the vertical share of the speed), so a coasting rocket's vertical acceleration there is
# -g; a filter beyond -2 g is still ringing from its boost, not describing a coast (D16 rule 12)
_BARO_APOGEE_DECEL_MAX_MMPS2 = const(19613)
# An accelerometer whose readings in coast jump by more than this on average from one to the next
# (``SensorHealth.acc_jitter``) reads noise of more than about 3.9 g rms, no drag: drag changes
# by milli-g per reading, and the real logs' coasts jump by at most 2.5 g on average (319-005,
# a tumbling rocket). Its readings above -0.5 g are left out as not drag, so its noise, no longer
# zero-mean, would pull the velocity down by several g (D16 rule 15)
_ACCEL_NOISY_MMPS2 = const(39227)

# No filter apogee while the barometer in use climbs faster than _BARO_CLIMB_FAST_MMPS, or faster
# than _BARO_CLIMB_HOLD_MMPS as a coasting rocket does (``climbs_fast``), each plus three times
# its rate's noise learnt on the pad (D16 rule 17). At a true apogee the 0.5 s window lags by
# g x 0.25 s, 2.5 m/s, and a quantised part's rate reads a step more (AltOS's 1.3 m steps:
# 2.6 m/s), which its noise at rest on the pad does not show. Below 20 m/s a negative transient's
# return (its rate rising, or falling faster than the track's) does not hold the filter; above
# it, held whatever the rate does, the filter may lie too (pulled down before the barometer was
# left out: seed 6's rocket 206 of the random rockets fired 0.9 s early without that tier)
_BARO_CLIMB_HOLD_MMPS = const(6000)
_BARO_CLIMB_FAST_MMPS = const(20000)
# Nor, while the track runs (the rule reads only its changes, which a clip in the boost leaves
# whole in coast), while the barometer stands still: its rate rose
# against the track's by more than _STOOD_MMPS (half of g x 0.5 s) over the _STOOD_SLOTS (0.5 s)
# to its newest judged window (a coasting barometer's rate falls with the track's; a frozen one's
# stands, so it rises against it by g x 0.5 s), while over the arbitration's history (_FALL_SLOTS
# of its 50 ms slots: 1.5 s) the filter's velocity fell faster than the track by more than the
# margin the track grew (its bias and tilt bounds: the barometer pulled the filter down faster
# than the accelerometer allows) and the filter's velocity then, carried on by the track and that
# margin, still climbs (D16 rule 22). A barometer frozen under its noise 2 s before apogee stands
# at zero, and the filter, pulled down, crossed zero 0.5 to 1.1 s early. The carried velocity
# bounds the wait. Without the stillness, a filter converging after a transient (its fall then
# leads the track's too) was held up to the backup timer, and one on a truthful barometer beside
# an accelerometer reading zeros (its track misses the drag) 0.7 s
_FALL_SLOTS = const(30)
_STOOD_SLOTS = const(10)
_STOOD_MMPS = const(2452)
# No accelerometer-only apogee while the barometer left out climbs faster than this (plus three
# times its pad noise) away from the accelerometer-carried filter (D16 rule 18): twice the 0.5 s
# window's lag at a true apogee. A negative transient's return climbs from below the filter
_BARO_AWAY_MMPS = const(5000)

# The filter's velocity is trusted as the start of an accelerometer-only bound only after the
# barometer corrected it this long in coast: the bias model's settling (about 2.5 s) plus the
# 1.6 s of history the anchor reaches back (shared/arbitration.py)
_ANCHORED_MS = const(4000)
# The dead reckoning's calibration takes its reference this far into a run of the barometer in use
# in coast: the run's first window (0.5 s) then lies in it (shared/arbitration.py note_reference)
_DR_REF_MS = const(1000)
# A barometer that parted from the filter beyond any barometric error retires the accelerometer
# (D16 rule 14) only if it read nothing impossible (a spike, shared/health.py) for this long:
# readings of a broken part (random kilometres) part from anything
_BARO_CLEAN_MS = const(2000)
# Nor can an accelerometer read one value near zero (within _HELD_NEAR_ZERO_MMPS2: a failed bus
# reads zero bytes, 0 or -1 LSB) for accel_stuck_s while the rocket climbs faster than
# _HELD_FAST_MMPS: its drag is then larger, and changes by a part's least significant bit within
# tenths of a second. (The real logs hold a value longest at 39 m/s: -1.09 m/s^2 for 1.36 s, a
# 0.54 m/s^2 part 5 s before apogee; and at full scale in a clipped boost, far from zero.)
_HELD_FAST_MMPS = const(50000)
_HELD_NEAR_ZERO_MMPS2 = const(490)  # 0.05 g
_DESCENT_MIN_MMPS = const(2000)  # a slower "descent" under a parachute is not one to predict from
# the descent rate predicts the main's time only once it is steady (the parachute open, drag =
# weight): the filter's acceleration small, and its velocity and the barometer's rate agreeing
_STEADY_ACC_MMPS2 = const(2000)
_STEADY_RATE_MMPS = const(3000)
_STEADY_MIN_DS = const(20)  # 2 s of steady descent give its mean rate
# Under a parachute the rocket descends steadily at drag = weight: a barometer that has not
# descended by _DESCENT_MIN_MMPS x the time since its last steady descent, this long after it,
# stopped reading the descent (frozen; D16 rule 24). The real logs go up to 8.7 s without a
# steady-descent sample (swinging, quantised parts) while descending 10 to 30 m/s
_NO_DESCENT_MS = const(3000)
# ... and from the first sample under the drogue, while no steady descent has shown: the real
# logs' first steady descent comes 1.2 to 12 s after the drogue (an apogee's slow start, a
# swinging rocket), but every one of them has fallen by far more than 2 m/s x 10 s by then (a
# drogue on the backup timer in the climb: its barometer climbs, and moves as much)
_NO_DESCENT_FIRST_MS = const(10000)

_RECORD_FORMAT = "<IIII"
_RECORD_VERSION = const(3)
STATE_RECORD_SIZE = const(16)  # struct.calcsize(_RECORD_FORMAT): the RP2040's four scratch words
_RESUME_SETTLE_MS = const(2000)
_FALSE_LAUNCH_MS = const(10000)  # a launch not proven within this, near the pad, was not one
# The accelerometer's own account of the boost (proof of flight): the kinematic acceleration is
# integrated from the first sample of a push above this on the pad (or from launch), signed, until
# proof. Bounds keep every product inside 31 bits: |a| < 2**20 mm/s^2 (107 g), dt <= 1000 ms,
# |v| < 2**20 mm/s (1 km/s: the proof speed is tens of m/s).
_PUSH_MMPS2 = const(4903)  # 0.5 g: a motor lighting; well above pad noise and the 1 g calibration error
_INT_LIMIT = const(0xFFFFF)
# Both sensors: during the proof hold the barometer's climb and the accelerometer's integrated
# height agree within 10 m + 1/4 of the climb (tilt up to 40 degrees, barometer lag, calibration).
_AGREE_MM = const(10000)

# An accelerometer reading stands for the time since the previous one (its own interval). For the
# boost timer at most this long: the period of the slowest rate the filter knows (10 Hz); after a
# longer silence a boosting reading counts as one such period. Its integrals and averages take up
# to _ACCEL_AGE_LIMIT_US (their own limit of 1 s).
_ACCEL_HOLD_US = const(100000)
_ACCEL_AGE_LIMIT_US = const(1000000)

# Error flags in ``errors`` (ERR_ORIENTATION, ERR_PAD_BARO_STEP and ERR_BARO_ERRATIC come from
# shared/padcal.py).
ERR_ACCEL_CLIPPED = const(2)  # at least one reading at the accelerometer's full scale
ERR_FALSE_LAUNCH = const(16)  # a launch without proof of flight went back to pad mode


class FlightComputer:
    """The flight state machine over the Kalman detector. See the module docstring."""

    def __init__(self, config, ground_alt_mm=None, table=None):
        self.cfg = config
        if table is None:
            table = PROJECT_LOW_NOISE if config.low_noise_baro else PROJECT
        rule = SeedRule() if config.seed_rule else VelocityRule()
        self.det = Detector(table, rule)
        self.det.step_rate_mmps = config.baro_step_rate_mmps
        self.kf = self.det.kf
        # the bias state explains at most the error budget of the accelerometer (bias, and tilt
        # seen as a constant offset of g): a barometric lie is not an accelerometer bias
        self.kf.bias_limit_q4 = (config.accel_bias_max_mmps2
                                 + (config.tilt_loss_1024 * G_MMPS2 >> 10)) << 4
        self.health = SensorHealth(config)
        self.health.start_watch(config)
        # (with the ballistic check of a coast without the accelerometer, D16 rule 10)
        self.arb = Arbitration(config, ballistic.Ballistic(config))
        self.health.arb = self.arb  # (the path of D16 rule 19)
        self.mode = (MODE_BARO if config.has_baro else 0) | (MODE_ACCEL if config.has_accel else 0)
        self.baro_excluded = False  # coast: the barometer disagrees with the accelerometer's bounds
        # re-take the barometer's altitude at its next reading (after a resume, or the barometer
        # back from an exclusion)
        self._reanchor = False
        self._steady_agl_mm = 0  # steady descent: where it began, and its last barometric
        self._steady_ms = -1  # reading that moved
        self._good_agl_mm = 0
        self._good_ms = -1
        self._arb_ms = 0  # now_ms the track was last brought up to date (see _arbitrate)
        self._baro_coast_ms = 0  # how long the barometer has been in use in coast, without a break
        self._filter_anchored = False  # the barometer was in use long enough before it was lost
        # the barometer was left out in coast after correcting the filter long enough: until
        # apogee the accelerometer's dead-reckoned velocity guards it (_apogee_enabled)
        self._dead_reckoning = False
        self.pad = PadCalibration(config, ground_alt_mm)
        self.state = PAD
        self.events = 0
        self.errors = 0
        self.started = False
        self.now_ms = 0
        self._us_rem = 0
        self.ground_alt_mm = self.pad.ground_alt_mm  # copied from self.pad while on the pad
        self.one_g_mmps2 = G_MMPS2
        # flight
        self.boost_ms = 0  # how long the boost acceleration has been sustained
        self.boost_max_ms = 0  # the longest such stretch
        self._accel_age_us = 0  # time since the last accelerometer reading (capped)
        self._accel_interval_us = _ACCEL_HOLD_US  # between its last two readings (capped)
        self.launched = False
        self.flight_proven = False
        self.climb_ms = 0  # time above proof_climb_m, less the time below since (barometer)
        self.launch_ms = 0
        self.ignition_ms = 0  # when the current burn began: the launch, or a motor lit in coast
        self.launch_by_height = False  # launched on height and speed, not on the boost
        self.acc_dv_mmps = 0  # speed integrated from the accelerometer since the push began
        self.acc_dv_max_mmps = 0
        self.acc_h_mm = 0  # height integrated from it
        # both sensors: where the proof counts the two climbs from (the barometer's reading, mm
        # above the pad, and acc_h_mm): the pad, or where the barometer last came back into use
        self.proof_ref_baro_mm = 0
        self.proof_ref_acc_mm = 0
        self.acc_clipped = False  # a clipped reading entered them: they are lower bounds
        # averaged measured kinematic acceleration, mm/s^2 (apogee gate, false launch; not kept
        # once proven and coast_measured)
        self.acc_meas_avg = 0
        # the accelerometer itself has shown a coast (averaged at or below -coast_decel_mps2 after
        # launch): a rocket standing on the pad reads +1 g and never does; once seen, the board's
        # later shocks (ejection, a tumble) do not undo it
        self.coast_measured = False
        self.acc_account = True  # False after a resume: the integrals above restarted mid-flight
        self.burnout_ms = 0
        self.max_agl_mm = 0
        self.max_vel_mmps = 0
        self.acc_avg_q4 = 0
        # averaged squared distance between the barometer and the filter after its correction,
        # 1/16 m^2 (_RESID_TAU_MS, _RESID_CAP_M): small while the filter tracks the barometer
        self.resid_sq_avg_q4 = 0
        # when that average last exceeded baro_diverged_m^2 in flight (so that the first samples pass)
        self.off_baro_ms = -config.baro_settle_ms
        # when the barometer last came back into use reading slower than the accelerometer's
        # velocity (D16 rule 9)
        self.baro_back_ms = -config.baro_settle_ms
        self.apogee_ms = -1
        self.drogue_due_ms = -1
        self.drogue_fired_ms = -1
        self.main_fired_ms = -1
        self.backup_drogue_fired_ms = -1
        self.backup_main_fired_ms = -1
        self.pyro_drogue = False
        self.pyro_main = False
        self.pyro_backup_drogue = False
        self.pyro_backup_main = False
        self._det_phase = -1  # the phase the detector is configured for (see step)
        self._pulses = 0  # pulses on (_pyro ends them; 0: nothing to do)
        self._land_start_ms = 0
        self._land_min_mm = 0
        self._land_max_mm = 0
        self.agl_mm = 0
        self.baro_agl_mm = 0  # last fresh barometric reading above the pad (unfiltered)
        self.vel_mmps = 0
        self.settle_until_ms = 0  # after a resume: no apogee decision before this
        self._gap_us = 0  # after a resume: the time the reset cost, predicted across
        # room in the attribute tables of the objects each sample uses (MicroPython's speed)
        for obj in (self, config, self.det, self.kf, self.health, self.arb, self.pad, self.arb.ballistic):
            make_room(obj)

    def step(self, dt_us, alt_mm, accel_mmps2, have):
        """Process one sample; see the module docstring for units and outputs.

        The per-sample work is done by module-level functions taking the flight computer, and an
        attribute used more than once is read into a local: on MicroPython a method call on this
        object costs twice a function call, an attribute load three local loads (docs/BENCHMARKS.md,
        "Per-sample cost")."""
        cfg = self.cfg
        self.events = 0
        if self._gap_us:
            dt_us += self._gap_us
            self._gap_us = 0
        now_ms = self.now_ms
        started = self.started
        if not started:
            dt_us = 0
        else:
            total = self._us_rem + dt_us
            now_ms += total // 1000
            self.now_ms = now_ms
            self._us_rem = total % 1000
        dt_ms = dt_us // 1000
        state = self.state
        health = self.health
        have = check_health(health, now_ms, dt_ms, alt_mm, accel_mmps2, have,
                            self.launched and state <= DROGUE)
        if not started:
            # the first sample: the pad calibration and the filter start from its usable readings
            self.started = True
            self.det.start(self.pad.start(alt_mm, have), 0)
            self.ground_alt_mm = self.pad.ground_alt_mm
        if health.changed:
            self.events |= EV_HEALTH
        clipped = health.clipped
        measured_acc = have & _HAVE_ACCEL  # a usable reading, before the phase's own choice
        accel_read = measured_acc or clipped  # (a clipped reading: alive, at full scale)
        if clipped:
            self.errors |= ERR_ACCEL_CLIPPED
        # the accelerometer's own interval: the time since its previous reading (0: none now).
        # The ascent's averages and timers and the integrals until proof use it; after the drogue,
        # proven (both for good), nothing does
        if state < DROGUE or not self.flight_proven:
            accel_since_us = self._accel_age_us + dt_us
            if accel_since_us > _ACCEL_AGE_LIMIT_US:
                accel_since_us = _ACCEL_AGE_LIMIT_US
            if accel_read:
                self._accel_age_us = 0
                # the boost timer's: at most _ACCEL_HOLD_US; its period the shorter of the last two
                accel_interval_us = accel_since_us if accel_since_us < _ACCEL_HOLD_US else _ACCEL_HOLD_US
                accel_period_us = self._accel_interval_us
                if accel_period_us > accel_interval_us:
                    accel_period_us = accel_interval_us
                self._accel_interval_us = accel_interval_us
            else:
                self._accel_age_us = accel_since_us
                accel_since_us = accel_interval_us = accel_period_us = 0
        kf = self.kf
        if state == PAD:
            pad = self.pad
            have = update_pad(pad, now_ms, alt_mm, accel_mmps2, have, kf)
            self.errors = (self.errors & ~PAD_ERRORS) | pad.errors
            self.ground_alt_mm = pad.ground_alt_mm
            self.one_g_mmps2 = pad.one_g_mmps2
            if (-_HELD_NEAR_ZERO_MMPS2 < accel_mmps2 < _HELD_NEAR_ZERO_MMPS2 and have & _HAVE_ACCEL
                    and pad.upright and health.accel_held_near_zero_ms(
                        now_ms, _HELD_NEAR_ZERO_MMPS2) >= cfg.accel_stuck_ms):
                # D16 rule 14 on the pad: upright (its orientation checked) an accelerometer reads
                # 1 g; one value near zero held accel_stuck_s is a failed bus (zero bytes), or a
                # free fall of 1.2 m that no pad allows. Retired for the flight: the board
                # launches and proves its flight on the barometer alone, and the pad no longer
                # judges its orientation by it (its zeros in the pad's averages would refuse the
                # launch). A board never read upright (a part reading zeros from power-on, a
                # board lying down) keeps its launch refused
                health.retire_accel(False)
                self.arb.stop()
                pad.has_accel = False
        acc_kin = accel_mmps2 - self.one_g_mmps2
        coasting = state == FAST or state == COAST
        if (coasting and health.acc_jitter > _ACCEL_NOISY_MMPS2 and health.accel_ok
                and now_ms - self.burnout_ms >= _GATE_START_MS):
            # D16 rule 15: past the motor's tail-off, an accelerometer that jumps like noise of
            # several g reads no drag; the board flies on as one without it (as rule 14)
            _retire_accel(self, now_ms, True)
            have &= _HAVE_BARO
        have = _arbitrate(self, now_ms, state, alt_mm, accel_mmps2, acc_kin, have, clipped)
        mode = self.mode
        prior_vel_mmps = kf.vel_q4 >> 4
        if prior_vel_mmps > cfg.mach_lockout_mmps:
            _set_baro_weight(kf, cfg, state, mode, prior_vel_mmps)
        else:  # (_set_baro_weight's first test: below the lockout speed, full weight)
            kf.baro_weight_256 = 256
        if have & _HAVE_BARO and self._reanchor:
            # after a reset, or the barometer back from an exclusion: its altitude, not its path
            self._reanchor = False
            kf.set_altitude(alt_mm)
            # the distance to the barometer starts again from here too: the average of the old
            # filter's (out of use, it was not updated) is no measure of this one (D16 rule 13)
            self.resid_sq_avg_q4 = 0
            # a proof still owed counts both climbs from here (_check_proof)
            self.proof_ref_baro_mm = alt_mm - self.ground_alt_mm
            self.proof_ref_acc_mm = self.acc_h_mm
        resuming = now_ms < self.settle_until_ms
        if coasting and acc_kin > _NOT_DRAG_MMPS2:
            have &= _HAVE_BARO  # not drag: the reading is not used
        # the detector's configuration for the phase, set when the phase changes: the state, a
        # resumed filter settling, the first 0.5 s after burnout (the motor's tail-off is a real,
        # fast change: no gates yet)
        phase = state
        if resuming:
            phase += _PHASE_RESUMING
        elif state >= FAST and now_ms - self.burnout_ms < _GATE_START_MS:
            phase += _PHASE_TAIL_OFF
        det = self.det
        if phase != self._det_phase:
            self._det_phase = phase
            _configure_detector(det, cfg, state, resuming, phase != state)
            if phase == COAST or phase == FAST:
                # the change test, from the tail-off's end, at any speed, above the Mach lockout
                # too (a barometer that freezes at speed falls to zero within a window, D16 rule
                # 20; back to baro_change_below_mps at an ignition and at the drogue)
                self.arb.change_below_mmps = _ANY_SPEED_MMPS
        if state >= DROGUE or resuming:
            # under a parachute the orientation is unknown; a resumed filter follows the
            # barometer alone (see restore_state)
            have &= _HAVE_BARO
        # the correction model (tools/gen_gains.py explains the physics and the numbers; written
        # out: every coast sample). In coast the accelerometer's bias estimated, and below
        # _LATE_COAST_MMPS the acceleration taken as -g, which needs the barometer (one excluded by
        # the arbitration leaves the bias model to correct with the accelerometer alone). Fast
        # (above the Mach lockout) the plain model: a bias learnt from a barometer that lies
        # through Mach would carry the lie into the velocity. After a reset the plain model: the
        # saved velocity may be old, the filter re-learns it.
        if state != COAST or resuming:
            det.model = _MODEL_PLAIN
        elif -_LATE_COAST_MMPS < prior_vel_mmps < _LATE_COAST_MMPS and mode & MODE_BARO:
            det.model = _MODEL_GRAVITY
        else:
            det.model = _MODEL_BIAS
        if dt_us:
            if state == COAST:
                bal = self.arb.ballistic
                if bal.floor_set:
                    ballistic.fall(bal, now_ms)
                # nor while the ballistic floor is above zero (D16 rule 10; tested here, last,
                # where it costs only the samples that pass every other test)
                enabled = _apogee_enabled(self, cfg, now_ms) and not bal.holds
            else:
                enabled = False
            if cfg.baro_lag_ms and have & _HAVE_BARO:
                # the reading shows the altitude of baro_lag_ms ago: h(t) ~ h(t - lag) + v lag
                # (velocity in cm/s so that the product stays in 31 bits)
                alt_mm += (self.vel_mmps // 10) * cfg.baro_lag_ms // 100
            # the filter decides only while the barometer is in use: with no usable sensor
            # (mode 0: a barometer-only board whose barometer froze or died) its velocity is a
            # prediction that no reading supports, and only the backup timer may fire
            filter_decides = enabled and mode & MODE_BARO
            if filter_decides and not health.accel_ok and det.inside_us[0] >= 0:
                # nor, with the barometer alone, while the filter re-converges after its gate
                # re-synchronised (open until the innovation stayed inside it GATE_REARM_US): its
                # velocity swings through the linear filter's transient, no measurement of the
                # motion (a 290 m transient in mid coast: +150 m/s, then zero at 50 m/s climbing)
                filter_decides = False
            if filter_decides and (now_ms - self.baro_back_ms < cfg.baro_settle_ms
                                   or self.baro_back_ms >= 0 and kf.bias_q4 >= kf.bias_limit_q4
                                   and self.arb.upper_valid
                                   and self.arb.dead_reckoned_mmps() > cfg.dead_reckoning_guard_mmps):
                # nor for baro_settle_s after the barometer came back reading slower than the
                # accelerometer carries the velocity on (baro_back_ms, _arbitrate): a transient's
                # decay, taken back inside the tolerance, lies on the early side, and the filter
                # follows it through zero (docs/DESIGN.md D16 rule 9). Nor after that, once it came
                # back so in this flight (baro_back_ms at boot is negative), while the filter
                # blames the accelerometer for all the error it can have on the side that drops
                # the velocity (its bias estimate at its upper bound) and the accelerometer's own
                # account (rule 7's dead reckoning; not after a clip) says the rocket still climbs:
                # an exponential decay lies for seconds after the wait. Unless the filter already
                # descends faster than that tolerance, or the dead-reckoning guard (rule 7)
                # holds the apogee until the accelerometer's own estimate says apogee
                filter_decides = health.accel_ok and (
                    prior_vel_mmps <= -cfg.baro_readmit_mmps or self._dead_reckoning)
            if clipped and state == BOOST and self.arb.baro_consistent and kf.acc_q4 >> 4 < acc_kin:
                # a reading clipped at full scale is left out of the filter, but proves at least
                # that much acceleration: the filter's is held at or above it, not at the value
                # it had when the part began to clip (a C6 peaking at 19 g on a 16 g part: its
                # velocity 11 m/s slow at burnout, 3 m/s with this); not while the barometer
                # contradicts the accelerometer's bounds (a part stuck at full scale in coast
                # reads as a motor lit: the barometer, not the part, must then end that boost)
                kf.acc_q4 = acc_kin << 4 if acc_kin < _CLIP_ACC_LIMIT_MMPS2 else RATE_LIMIT_Q4
            apogee = det.step(dt_us, alt_mm, acc_kin, have, filter_decides)
            if apogee and self.arb.valid:
                # D16 rule 22 (_FALL_SLOTS): the filter's velocity 1.5 s ago, the track's change
                # since and the margin grown since, and the barometer's rate against the track's
                # over the 0.5 s to the newest judged window (the newest slot's judgement may wait
                # a sample; an unjudged one fails the test; a negative index wraps the history)
                arb = self.arb
                head = arb._head
                far = head - _FALL_SLOTS
                fell = arb._fvel[far]
                carried = arb._vel[head] - arb._vel[far]
                grown = arb._margin[head] - arb._margin[far]
                stood = arb._diff[head - 1] - arb._diff[head - 1 - _STOOD_SLOTS]
                if (fell - arb._fvel[head] > grown - carried and fell + carried + grown > 0
                        and _STOOD_MMPS < stood < _ANY_SPEED_MMPS):
                    det.withdraw_apogee()
                    apogee = False
            if apogee and climbs_fast(self.arb, _BARO_CLIMB_HOLD_MMPS, _BARO_CLIMB_FAST_MMPS):
                # D16 rule 17: nor, while the accelerometer's track runs, while the barometer climbs
                # fast (faster than 20 m/s with the track bounding both sides; faster than 6 m/s
                # as a coasting rocket climbs). At a true apogee its 0.5 s window reads about
                # +2.5 m/s; faster, the rocket climbs, or the barometer lies upward (a transient,
                # which only delays: by its rise, or a negative one held to apogee by its return).
                # An accelerometer reading six times the drag after a Mach 2.4 burnout pulled the
                # filter through zero at 531 m/s. (Without a track, rules 5, 10, 11 and 12 hold
                # the filter.) Tested on the apogee the rule declared, not before it, so that the
                # coast's other samples do not pay for the test
                det.withdraw_apogee()
                apogee = False
            if mode == MODE_ACCEL and enabled:
                apogee = _accel_only_apogee(self)
        else:
            apogee = False
        ground_mm = self.ground_alt_mm
        agl_mm = (kf.alt_q4 >> 4) - ground_mm
        vel_mmps = kf.vel_q4 >> 4
        self.agl_mm = agl_mm
        self.vel_mmps = vel_mmps
        if have & _HAVE_BARO:
            self.baro_agl_mm = alt_mm - ground_mm
            if (state == DROGUE and health.baro_moved
                    and -_STEADY_ACC_MMPS2 < kf.acc_q4 >> 4 < _STEADY_ACC_MMPS2
                    and -_STEADY_RATE_MMPS < self.arb.baro_rate_mmps - vel_mmps < _STEADY_RATE_MMPS
                    and self.arb.baro_rate_mmps < -_DESCENT_MIN_MMPS):
                if self._steady_ms < 0:
                    self._steady_ms = now_ms  # the steady descent began
                    self._steady_agl_mm = agl_mm
                self._good_agl_mm = agl_mm
                self._good_ms = now_ms
        if state < DROGUE:
            # the averages of the ascent's decisions (the apogee gate, a false launch at rest); the
            # measured acceleration's only while something reads it: a false launch (not proven)
            # or the coast it shows (not yet seen); both settle for good
            if measured_acc and not (self.flight_proven and self.coast_measured):
                accel_ms = accel_since_us // 1000
            else:
                accel_ms = -1
            _update_averages(self, cfg, state, kf, dt_ms, alt_mm, have, acc_kin, accel_ms)
        if state <= COAST:
            # (in fast and coast too: a motor lit in coast, staging or an air-start; there, a
            # reading below the boost only ends a run, written out: most coast samples)
            if state <= BOOST or acc_kin > cfg.launch_accel_mmps2 or clipped:
                _update_boost(self, cfg, accel_interval_us, accel_period_us, acc_kin, measured_acc, clipped)
            elif measured_acc:
                self.boost_ms = 0
        if accel_read and not self.flight_proven:
            _integrate_accel(self, state, accel_since_us // 1000, acc_kin, clipped)
        _transition(self, cfg, state, apogee)
        agl_mm = self.agl_mm  # (a launch re-bases it)
        if agl_mm > self.max_agl_mm:
            self.max_agl_mm = agl_mm
        if vel_mmps > self.max_vel_mmps:
            self.max_vel_mmps = vel_mmps
        if self.launched and not self.flight_proven:
            _check_proof(self, cfg, dt_ms)
        if self._pulses:
            _pyro(self, now_ms)

    def _launch(self, by_height):
        """Leave the pad. The ground is the reference from the samples ending at least 0.2 s
        before (a bad reading on this sample re-based it: the filter goes back with it)."""
        self.launched = True
        self.launch_by_height = by_height
        self.launch_ms = self.ignition_ms = self.now_ms
        self.state = BOOST
        self.events |= EV_LAUNCH
        self.arb.note_launch()
        ground = self.pad.launch_ground()
        jump = self.ground_alt_mm - ground
        if jump > PAD_BARO_JUMP_MM or jump < -PAD_BARO_JUMP_MM:
            self.kf.set_altitude(ground)
        self.ground_alt_mm = ground
        self.agl_mm = (self.kf.alt_q4 >> 4) - ground

    def _fire_drogue(self):
        self.drogue_fired_ms = self.now_ms
        self.pyro_drogue = True
        self._pulses += 1
        self.events |= EV_DROGUE
        self.state = DROGUE
        # the coast's change test at any speed, and its drift test, end (D16 rules 20 and 21)
        self.arb.change_below_mmps = self.cfg.baro_change_below_mmps
        self._land_start_ms = self.now_ms
        self._land_min_mm = self._land_max_mm = self.agl_mm

    def _fire_main(self):
        self.main_fired_ms = self.now_ms
        self.pyro_main = True
        self._pulses += 1
        self.events |= EV_MAIN
        self.state = MAIN

    def _fire_backup_drogue(self):
        self.backup_drogue_fired_ms = self.now_ms
        self.pyro_backup_drogue = True
        self._pulses += 1
        self.events |= EV_BACKUP_DROGUE

    def _fire_backup_main(self):
        self.backup_main_fired_ms = self.now_ms
        self.pyro_backup_main = True
        self._pulses += 1
        self.events |= EV_BACKUP_MAIN

    # Resume after a reset in flight (docs/DESIGN.md D3, D14). The record is the smallest that
    # allows a safe resume: four words of 30 bits (16 bytes: the RP2040's four free watchdog
    # scratch registers; ESP32 RTC memory; or a file), each a non-negative small int so that
    # packing allocates nothing on a 32-bit board:
    #   w0: version (3) | state (3) | flags (4: launched, proven, drogue fired, main fired)
    #       | errors (5) | check (15)
    #   w1: time since launch in 10 ms (20: 2.9 h) | flags (2: backup drogue fired, backup main
    #       fired) | pad 1 g - 9807 in 16 mm/s^2, +128 (8)
    #   w2: ground altitude in 0.5 m, +2**17 (18: +-65 km) | velocity in m/s, +2048 (12)
    #   w3: maximum altitude above the pad in 2 m (14: 32 km) | drogue time since launch in
    #       0.1 s (16; fired, or due after an apogee; 0xFFFF none)
    # The altitude is not kept: the first barometric reading gives it. The device saves the record
    # every 0.1 s in flight; a reset costs time the board cannot see, so the device passes the
    # worst case (``gap_ms``: the boot time plus, after a watchdog reset, its timeout) and the
    # filter predicts across it. The filter then re-converges for _RESUME_SETTLE_MS (altitude from
    # the barometer, no gates, no apogee decision; the timers and the main still work), and a proof
    # still owed comes from one sensor (the accelerometer's integrals restarted).

    def save_state(self, buf):
        """Pack the flight's state into ``buf`` (bytearray of STATE_RECORD_SIZE); no allocation."""
        flags = (self.launched | self.flight_proven << 1 | (self.drogue_fired_ms >= 0) << 2
                 | (self.main_fired_ms >= 0) << 3)
        t10 = _field((self.now_ms - self.launch_ms) // 10, 0xFFFFF)
        one_g = _field((self.one_g_mmps2 - G_MMPS2) // 16 + 128, 0xFF)
        backups = (self.backup_drogue_fired_ms >= 0) | (self.backup_main_fired_ms >= 0) << 1
        w1 = t10 << 10 | backups << 8 | one_g
        ground = _field(self.ground_alt_mm // 500 + 0x20000, 0x3FFFF)
        vel = _field(self.vel_mmps // 1000 + 2048, 0xFFF)
        w2 = ground << 12 | vel
        drogue_ms = self.drogue_fired_ms if self.drogue_fired_ms >= 0 else self.drogue_due_ms
        drogue = _field((drogue_ms - self.launch_ms) // 100, 0xFFFE) if drogue_ms >= 0 else 0xFFFF
        w3 = _field(self.max_agl_mm // 2000, 0x3FFF) << 16 | drogue
        head = _RECORD_VERSION << 12 | self.state << 9 | flags << 5 | (self.errors & 31)
        w0 = head << 15 | _check(head, w1, w2, w3)
        struct.pack_into(_RECORD_FORMAT, buf, 0, w0, w1, w2, w3)

    def restore_state(self, buf, gap_ms=0):
        """Resume from a record written by ``save_state``, ``gap_ms`` after it was written. Returns
        False (and changes nothing) if the record is not a valid in-flight record."""
        w0, w1, w2, w3 = struct.unpack_from(_RECORD_FORMAT, buf, 0)
        head = w0 >> 15
        state = head >> 9 & 7
        if head >> 12 != _RECORD_VERSION or w0 & 0x7FFF != _check(head, w1, w2, w3) or not (
                PAD < state <= LANDED):
            return False
        flags = head >> 5 & 15
        self.state = state
        self.errors = head & 31
        self.launched = bool(flags & 1)
        self.flight_proven = bool(flags & 2)
        self.launch_ms = 0
        self.now_ms = (w1 >> 10) * 10
        self.burnout_ms = self.now_ms
        self.one_g_mmps2 = G_MMPS2 + ((w1 & 0xFF) - 128) * 16
        self.ground_alt_mm = ((w2 >> 12) - 0x20000) * 500
        vel_mmps = ((w2 & 0xFFF) - 2048) * 1000
        self.max_agl_mm = (w3 >> 16) * 2000
        self.max_vel_mmps = vel_mmps if vel_mmps > 0 else 0
        drogue = w3 & 0xFFFF
        if flags & 4:
            self.drogue_fired_ms = drogue * 100
            self.apogee_ms = self.drogue_fired_ms
        elif drogue != 0xFFFF:
            self.drogue_due_ms = drogue * 100
            self.apogee_ms = self.drogue_due_ms - self.cfg.apogee_delay_ms
        if flags & 8:
            self.main_fired_ms = self.now_ms
        if w1 & 0x100:
            self.backup_drogue_fired_ms = self.now_ms
        if w1 & 0x200:
            self.backup_main_fired_ms = self.now_ms
        pad = self.pad
        pad.ground_fixed = True
        pad.ground_alt_mm = self.ground_alt_mm
        pad.one_g_mmps2 = self.one_g_mmps2
        pad.errors = self.errors & PAD_ERRORS
        self.started = True
        kf = self.kf
        kf.reset(self.ground_alt_mm + self.max_agl_mm, vel_mmps,
                 -G_MMPS2 if FAST <= state <= COAST else 0)
        self.agl_mm = self.max_agl_mm
        self.vel_mmps = vel_mmps
        self.det.forget_period()
        self._gap_us = gap_ms * 1000  # the next step predicts across the reset
        self.settle_until_ms = self.now_ms + gap_ms + _RESUME_SETTLE_MS
        self.acc_account = False  # proof, if still owed, from one sensor alone
        self._reanchor = True  # the barometer's altitude, not the saved one
        self._land_start_ms = self.now_ms
        self._land_min_mm = self._land_max_mm = self.max_agl_mm
        return True



# The per-sample work of FlightComputer.step: module-level functions taking the flight computer
# (see step).


def _set_baro_weight(kf, cfg, state, mode, vel_mmps):
    """AltOS-style Mach de-weighting: full weight up to the lockout speed, then a ramp down to
    mach_baro_weight_pct at 1.32 x lockout; ascent only, and only while the accelerometer is
    in use: de-weighting the only sensor would leave the filter coasting on an acceleration
    no reading corrects (an accelerometer lost in boost kept the motor's thrust in it)."""
    over = vel_mmps - cfg.mach_lockout_mmps
    if state >= DROGUE or not mode & MODE_ACCEL or over <= 0:
        kf.baro_weight_256 = 256
        return
    span = cfg.mach_lockout_mmps * 32 // 100
    if over >= span:
        kf.baro_weight_256 = cfg.mach_baro_weight_256
    else:
        kf.baro_weight_256 = 256 - (256 - cfg.mach_baro_weight_256) * (over >> 4) // (span >> 4)


def _configure_detector(det, cfg, state, resuming, settling):
    """The detector's gates, acceleration ceiling and use of the accelerometer for the phase
    (``settling``: resuming, or within 0.5 s of burnout)."""
    if state >= FAST and not settling:
        det.gate_alt_mm = GATE_ALT_MM
        det.gate_acc_mmps2 = GATE_ACC_MMPS2
    elif state == BOOST and not resuming:
        det.gate_alt_mm = cfg.boost_gate_mm  # a wide gate from the first sample of boost
        det.gate_acc_mmps2 = 0
    else:
        det.gate_alt_mm = 0
        det.gate_acc_mmps2 = 0
    # coasting: gravity and drag, never an upward push
    det.acc_max_q4 = COAST_ACC_MAX_Q4 if state == FAST or state == COAST else RATE_LIMIT_Q4
    det.accel_off = state >= DROGUE or resuming  # (step uses the barometer alone then)


def _apogee_enabled(fc, cfg, now_ms):
    """The filter's apogee is allowed (in coast: the caller's test)."""
    arb = fc.arb
    # the accelerometer's lowest possible velocity first (``Arbitration.lower_mmps``, written out:
    # this runs on every coast sample): it holds the apogee off through most of the coast, and
    # then the rest of the rule is not evaluated
    if arb.valid and arb.vel_mmps - arb.margin_mmps > cfg.apogee_guard_mmps:
        return False
    accel_ok = fc.health.accel_ok
    return (fc.flight_proven and fc.drogue_fired_ms < 0
            and fc.apogee_ms < 0 and now_ms >= fc.settle_until_ms
            and now_ms - fc.launch_ms >= cfg.apogee_lockout_ms
            and fc.agl_mm >= cfg.proof_climb_mm
            and not (fc._dead_reckoning and arb.valid
                     and arb.dead_reckoned_mmps() > cfg.dead_reckoning_guard_mmps)
            and cfg.coast_decel_mmps2 << 4 <= -fc.acc_avg_q4 <= _APOGEE_DECEL_MAX_MMPS2 << 4
            and (fc.coast_measured or not accel_ok)
            # without the accelerometer (D16 rule 5): the filter tracks the barometer, within 2 g
            # of its deceleration (rule 12), and settled baro_settle_s since it was baro_diverged_m
            # off it; after a clipped boost (its track bounds the velocity from below only) the
            # settle alone (rule 11), and so once a frozen or lost accelerometer ended the track
            # (not after a reset: there the resumed filter's own settle applies)
            and (accel_ok and (arb.upper_valid or not arb.valid and fc.settle_until_ms)
                 or (accel_ok or fc.resid_sq_avg_q4 < cfg.baro_track_sq_q4
                     and -fc.acc_avg_q4 <= _BARO_APOGEE_DECEL_MAX_MMPS2 << 4)
                 and now_ms - fc.off_baro_ms >= cfg.baro_settle_ms))


def _update_averages(fc, cfg, state, kf, dt_ms, alt_mm, have, acc_kin, accel_ms):
    """The ascent's averages: the filter's acceleration and the squared distance between the
    barometer and the filter (the apogee gate), and the measured acceleration (a usable reading,
    held ``accel_ms``; -1: none) with the coast it shows.

    Each is an exponential average with its time constant tau, in 31 bits: avg += (x - avg) dt /
    tau, dt at most tau, the step x - avg clamped to 2**20 (written out: a helper's three calls
    cost a quarter of this function on MicroPython)."""
    avg = fc.acc_avg_q4
    step = kf.acc_q4 - avg
    if step > _EMA_STEP_LIMIT:
        step = _EMA_STEP_LIMIT
    elif step < -_EMA_STEP_LIMIT:
        step = -_EMA_STEP_LIMIT
    fc.acc_avg_q4 = avg + step * (dt_ms if dt_ms < _DECEL_TAU_MS else _DECEL_TAU_MS) // _DECEL_TAU_MS
    if have & _HAVE_BARO:
        resid_m = (alt_mm - (kf.alt_q4 >> 4)) // 1000
        if resid_m < 0:
            resid_m = -resid_m
        if resid_m > _RESID_CAP_M:
            resid_m = _RESID_CAP_M
        # (no clamp: the squares lie within 0..2**18, and so does their average)
        avg = fc.resid_sq_avg_q4
        avg += ((resid_m * resid_m << 4) - avg) * (
            dt_ms if dt_ms < _RESID_TAU_MS else _RESID_TAU_MS) // _RESID_TAU_MS
        fc.resid_sq_avg_q4 = avg
        if avg > cfg.baro_diverged_sq_q4 and state:  # (on the pad: the ground reference's)
            fc.off_baro_ms = fc.now_ms
    if accel_ms >= 0:
        avg = fc.acc_meas_avg
        step = acc_kin - avg
        if step > _EMA_STEP_LIMIT:
            step = _EMA_STEP_LIMIT
        elif step < -_EMA_STEP_LIMIT:
            step = -_EMA_STEP_LIMIT
        avg += step * (accel_ms if accel_ms < _DECEL_TAU_MS else _DECEL_TAU_MS) // _DECEL_TAU_MS
        fc.acc_meas_avg = avg
        if state != PAD and avg <= -cfg.coast_decel_mmps2:
            fc.coast_measured = True


def _update_boost(fc, cfg, accel_interval_us, accel_period_us, acc_kin, have, clipped):
    """Boost time (pad to coast): a boosting accelerometer reading (or one clipped upwards) after a
    boosting one adds the time between them, the first of a run one accelerometer period (a long
    silence before it is not known to be boost); a sample without an accelerometer reading leaves
    it as it is."""
    if not (have & _HAVE_ACCEL or clipped):
        return
    if acc_kin > cfg.launch_accel_mmps2 or clipped and acc_kin > 0:
        boost_ms = fc.boost_ms
        boost_ms += (accel_interval_us if boost_ms else accel_period_us) // 1000
        fc.boost_ms = boost_ms
        if boost_ms > fc.boost_max_ms:
            fc.boost_max_ms = boost_ms
    else:
        fc.boost_ms = 0


def _integrate_accel(fc, state, dt_ms, acc_kin, clipped):
    """The accelerometer's own account of the boost, until proof (the caller's test): speed and
    height integrated from the first sample of a push on the pad (reset while the pad is quiet),
    signed."""
    if state == PAD and acc_kin <= _PUSH_MMPS2:
        fc.acc_dv_mmps = fc.acc_dv_max_mmps = fc.acc_h_mm = 0
        fc.acc_clipped = False
        return
    if clipped:
        fc.acc_clipped = True
    if dt_ms > 1000:
        dt_ms = 1000
    if acc_kin > _INT_LIMIT:
        acc_kin = _INT_LIMIT
    elif acc_kin < -_INT_LIMIT:
        acc_kin = -_INT_LIMIT
    dv = fc.acc_dv_mmps + acc_kin * dt_ms // 1000
    if dv > _INT_LIMIT:
        dv = _INT_LIMIT
    elif dv < -_INT_LIMIT:
        dv = -_INT_LIMIT
    fc.acc_dv_mmps = dv
    if dv > fc.acc_dv_max_mmps:
        fc.acc_dv_max_mmps = dv
    h = fc.acc_h_mm + dv * dt_ms // 1000
    if -_INT_LIMIT << 8 < h < _INT_LIMIT << 8:
        fc.acc_h_mm = h


def _climbs_agree(baro_mm, acc_mm, clipped):
    """The barometer's climb and the accelerometer's integrated one agree within _AGREE_MM and a
    quarter of the climb (``clipped``: the accelerometer's is a lower bound)."""
    diff = baro_mm - acc_mm
    return -_AGREE_MM - (baro_mm >> 2) <= diff and (clipped or diff <= _AGREE_MM + (baro_mm >> 2))


def _check_proof(fc, cfg, dt_ms):
    """flight_proven, once true, stays true (every firing path requires it); launched and not
    yet proven (the caller's test).

    Both sensors: the barometer's own reading holds proof_climb_m for a second, and the
    accelerometer's account of the boost agrees: its integrated speed reached proof_speed_mps
    and its integrated height proof_climb_m (a shove or a knock on the rail gives a few m/s; a
    pressure offset, a gust or a hand on the port moves no accelerometer); or each climbed
    proof_baro_climb_m without agreeing by how much. Barometer only (by
    configuration, the accelerometer lost before proof, or clipped short of proof_speed_mps):
    proof_baro_climb_m held, above any pad pressure disturbance, at proof_speed_mps.
    Accelerometer only (or the barometer lost):
    the filter's climb held, at proof_speed_mps, after a boost of 0.3 s."""
    baro_ok = fc.health.baro_ok
    now_ms = fc.now_ms
    if (baro_ok and fc.arb.baro_rate_mmps > _HELD_FAST_MMPS and fc.health.accel_ok
            and fc.health.accel_held_near_zero_ms(now_ms, _HELD_NEAR_ZERO_MMPS2) >= cfg.accel_stuck_ms
            and now_ms - fc.health.baro_spike_ms >= _BARO_CLEAN_MS):
        # D16 rule 14 before the proof, the barometer in use or not: one value near zero held
        # accel_stuck_s while the barometer climbs faster than _HELD_FAST_MMPS reads no drag (a
        # failed bus: zero bytes). Retired; the barometer proves the flight alone
        _retire_accel(fc, now_ms, False)
    # (a clipped account short of proof_speed_mps gives no account: it only under-reads, and the
    # barometer alone proves the flight, as on a barometer-only board)
    accel_ok = fc.health.accel_ok and fc.acc_account and not (
        fc.acc_clipped and fc.acc_dv_max_mmps < cfg.proof_speed_mmps)
    if baro_ok:
        # the barometer's own reading, not the filter (a stuck accelerometer drags it up)
        climb_mm = fc.baro_agl_mm
        line_mm = cfg.proof_climb_mm if accel_ok else cfg.proof_baro_climb_mm
    else:
        # the filter's climb, or the accelerometer's own account when higher: a barometer
        # judged bad (frozen, lost) may have pulled the filter down before it was judged, and a
        # clipped account only under-reads
        climb_mm = fc.agl_mm
        if accel_ok and fc.acc_h_mm > climb_mm:
            climb_mm = fc.acc_h_mm
        line_mm = cfg.proof_climb_mm
    held = climb_mm >= line_mm
    if baro_ok and accel_ok:
        clipped = fc.acc_clipped
        held = held and _climbs_agree(climb_mm, fc.acc_h_mm, clipped)
        if not held:
            # or both climbs from where the barometer last came back into use: the offset it came
            # back with (a transient held from burnout: airbrakes open) is no climb, and left a
            # real flight unproven, with nothing fired (from the pad, a transient still decaying
            # when it came back is no climb either: either account proves)
            climb_mm -= fc.proof_ref_baro_mm
            held = climb_mm >= line_mm and _climbs_agree(
                climb_mm, fc.acc_h_mm - fc.proof_ref_acc_mm, clipped)
        if not held:
            # or each sensor climbed proof_baro_climb_m, the barometer-only board's line (above
            # any pad pressure disturbance; a knock or a shove that the board survives at rest
            # integrates to metres), at proof_speed_mps, without agreeing by how much: an
            # accelerometer that missed part of the boost (a bus that read zeros for a second,
            # then recovered) integrates a height that never again agrees, and left a flight the
            # barometer saw climb a kilometre unproven, with nothing fired
            held = (fc.baro_agl_mm >= cfg.proof_baro_climb_mm
                    and fc.acc_h_mm >= cfg.proof_baro_climb_mm
                    and fc.max_vel_mmps >= cfg.proof_speed_mmps)
    if held:
        fc.climb_ms += dt_ms
    elif fc.climb_ms > dt_ms:
        fc.climb_ms -= dt_ms  # a noisy reading below the line costs only its own time
    else:
        fc.climb_ms = 0
    # a climb that lasts: a pressure transient (ejection, venting, a knock) decays in tenths
    # of a second, a rocket stays above a few tens of metres for seconds
    proven = fc.climb_ms >= _PROOF_HOLD_MS
    if baro_ok and accel_ok:
        proven = proven and fc.acc_dv_max_mmps >= cfg.proof_speed_mmps
    elif baro_ok:
        proven = proven and fc.max_vel_mmps >= cfg.proof_speed_mmps
    elif accel_ok:
        proven = (proven and fc.max_vel_mmps >= cfg.proof_speed_mmps
                  and fc.boost_max_ms >= _ACCEL_ONLY_BOOST_MS)
    else:
        proven = False
    fc.flight_proven = proven


def _transition(fc, cfg, state, apogee):
    """One branch per state, each opening with its rule (the table in the module docstring)."""
    if state == PAD:
        # launch: the boost sustained (barometer-only: the proof climb at the proof speed);
        # refused while the board is not upright; an erratic barometer refuses only its own
        # account (the height), not a boost the accelerometer measures
        if fc.errors & ERR_ORIENTATION:
            return
        boost = cfg.has_accel and fc.boost_ms >= cfg.launch_accel_ms
        # or the height and speed (low thrust-to-weight, barometer-only boards)
        # (with an accelerometer, while it pushes: its integral reached launch_speed_mps)
        height = (not fc.errors & ERR_BARO_ERRATIC
                  and fc.agl_mm >= cfg.launch_height_mm and fc.vel_mmps >= cfg.launch_speed_mmps
                  and (not fc.health.accel_ok or fc.acc_dv_mmps >= cfg.launch_speed_mmps))
        if boost or height:
            fc._launch(not boost)
    elif state <= COAST:
        # ascent: back to the pad without proof (_false_launch); burnout; the Mach lockout;
        # then apogee and the drogue
        now_ms = fc.now_ms
        if not fc.flight_proven and now_ms - fc.launch_ms >= _FALSE_LAUNCH_MS and _false_launch(fc, cfg):
            return
        kf = fc.kf
        fast = (kf.vel_q4 >> 4 > cfg.mach_lockout_mmps
                or now_ms - fc.launch_ms < cfg.mach_lockout_ms)
        if state == BOOST:
            # burnout: the filtered acceleration turns negative, or the boost timeout
            if kf.acc_q4 < -2500 * 16 or now_ms - fc.ignition_ms > cfg.max_boost_ms:
                fc.burnout_ms = now_ms
                fc.events |= EV_BURNOUT
                fc.arb.note_burnout()
                fc.state = FAST if fast else COAST
                fc.boost_ms = 0  # an ignition in coast needs boost readings of its own
        elif (fc.boost_ms >= cfg.launch_accel_ms and fc.apogee_ms < 0
              and (fc.arb.baro_agrees() if fc.mode & MODE_BARO else not fc.baro_excluded)):
            # ignition in coast, before apogee: the launch's boost rule again (a motor lit:
            # staging, an air-start), while a barometer in use agrees with the accelerometer's
            # bounds on its newest window (a tumbling rocket reads thrust-like forces while the
            # barometer tops out, and a violent event spikes the barometer: 319-005); an excluded
            # barometer refuses it, none (lost, frozen, absent) leaves it to the accelerometer.
            # The filter's acceleration, held at or below the coast's ceiling until now, starts
            # from the least the boost readings showed (from the ceiling, burnout would be
            # declared at once)
            fc.ignition_ms = now_ms
            fc.state = BOOST
            fc.events |= EV_IGNITION
            fc.arb.change_below_mmps = cfg.baro_change_below_mmps
            kf.acc_q4 = cfg.launch_accel_mmps2 << 4
        elif state == FAST:
            if not fast:
                fc.state = COAST
                bal = fc.arb.ballistic
                if not fc.health.accel_ok and kf.vel_q4 > 0 and bal.tol_mmps:
                    # the coast's ballistic test begins (D16 rule 10), but nothing tested the
                    # barometer through the lockout: a fall there (frozen under its noise) went
                    # unjudged. Held as after a run without a floor, until a window of the coast
                    # clean for 1.5 s falls as a coast; only while the filter still climbs (no
                    # window of a descent falls as a coast) and the test is on. (Written out
                    # here: a function of shared/ballistic.py re-laid its names, +800
                    # instructions a sample on the Cortex-M0)
                    bal.holds = True
                    bal.fail_ms = now_ms
        elif fast:
            fc.state = FAST
        _drogue_rule(fc, cfg, now_ms, apogee)
    elif state == DROGUE:
        # main: proven, after the guard time; at or below the main altitude descending when the
        # flight rose main_margin_m above it; without a usable barometer _main_due_without_baro
        now_ms = fc.now_ms
        since_ms = now_ms - fc.drogue_fired_ms
        if fc._good_ms < 0:
            # the barometer's stillness is judged from the first sample under the drogue (or
            # after a reset) until a steady descent shows (D16 rule 24)
            fc._good_ms = now_ms
            fc._good_agl_mm = fc.baro_agl_mm
        still_ms = now_ms - fc._good_ms
        if not cfg.main_deploy_mm:
            main = False  # main_deploy_m 0: no main, a single deployment
        elif not fc.flight_proven or since_ms < cfg.main_guard_ms:
            main = False
        elif not fc.mode & MODE_BARO:
            main = _main_due_without_baro(fc, since_ms)
        elif (still_ms >= (_NO_DESCENT_MS if fc._steady_ms >= 0 else _NO_DESCENT_FIRST_MS)
              and -_DESCENT_MIN_MMPS < fc.arb.baro_rate_mmps < _DESCENT_MIN_MMPS
              and -still_ms // 10 * (_DESCENT_MIN_MMPS // 100)
              < fc.baro_agl_mm - fc._good_agl_mm
              < still_ms // 10 * (_DESCENT_MIN_MMPS // 100)):
            # a barometer that stands still under the parachute: _NO_DESCENT_MS after its last
            # steady descent (_NO_DESCENT_FIRST_MS after the first sample under the drogue while
            # none showed) it has moved by less than the slowest descent there is x that time, and
            # its newest window's rate is within that speed of zero (an ejection's transient,
            # decaying, holds the reading up for seconds while its rate descends; one's return
            # climbs): frozen (under its noise, no reading repeats, so the health's stuck test
            # cannot see it). Retired, and the main fires when the steady descent it showed
            # predicts, else main_delay_s after the drogue (D16 rule 24); in use, it never read
            # the main's altitude, and no main fired
            fc.health.retire_baro()
            main = _main_due_without_baro(fc, since_ms)
        elif fc.vel_mmps >= 0:
            main = False  # still climbing (a drogue on the backup timer): its maximum is to come
        elif fc.max_agl_mm >= cfg.main_deploy_mm + cfg.main_margin_mm:
            main = fc.agl_mm <= cfg.main_deploy_mm
        else:
            main = True  # it never rose clear of the main altitude: do not land on the drogue
        if main:
            fc._fire_main()
        _backup_rule(fc, cfg)
        _landing_rule(fc, cfg)
    elif state == MAIN:
        _backup_rule(fc, cfg)
        _landing_rule(fc, cfg)


def _drogue_rule(fc, cfg, now_ms, apogee):
    """Ascent: record apogee; fire the drogue (proven) when its delay is over, or on the
    backup timer."""
    if apogee:
        fc.apogee_ms = now_ms
        fc.events |= EV_APOGEE
        fc.drogue_due_ms = now_ms + cfg.apogee_delay_ms
    if fc.flight_proven and fc.drogue_fired_ms < 0:
        if fc.drogue_due_ms >= 0 and now_ms >= fc.drogue_due_ms:
            fc._fire_drogue()
        elif cfg.backup_drogue_ms and now_ms - fc.launch_ms >= cfg.backup_drogue_ms:
            fc._fire_drogue()


def _false_launch(fc, cfg):
    """A launch that has not proven a flight within _FALSE_LAUNCH_MS (the caller's test) while
    the rocket is near the pad (a push on the rail, a drop) or at rest (a pressure offset that
    stays: the av-bay sealed) goes back to pad mode, with its calibration. An unproven flight
    fires nothing, so going back to the pad in the air costs nothing."""
    baro_ok = fc.health.baro_ok
    if baro_ok:
        near = -cfg.proof_climb_mm < fc.baro_agl_mm < cfg.proof_climb_mm
    else:
        near = -cfg.proof_speed_mmps < fc.vel_mmps < cfg.proof_speed_mmps
    # at rest: no climb (measured: the barometer's rate, else the accelerometer-only filter's;
    # the coast clamp keeps the filter from resting), and (with an accelerometer) standing at
    # 1 g, not coasting at 0 g
    arb = fc.arb
    if arb.judge_due:
        judge_late(arb)  # (this sample's window: see _arbitrate)
    rate_mmps = arb.baro_rate_mmps if baro_ok else fc.vel_mmps
    at_rest = -cfg.launch_speed_mmps < rate_mmps < cfg.launch_speed_mmps and (
        not fc.health.accel_ok or -_PUSH_MMPS2 < fc.acc_meas_avg < _PUSH_MMPS2)
    if not (near or at_rest):
        return False
    fc.state = PAD
    fc.launched = False
    fc.boost_ms = fc.boost_max_ms = fc.climb_ms = 0
    fc.max_agl_mm = fc.max_vel_mmps = 0
    fc.acc_dv_mmps = fc.acc_dv_max_mmps = fc.acc_h_mm = 0
    fc.proof_ref_baro_mm = fc.proof_ref_acc_mm = 0
    fc.acc_clipped = False
    fc.coast_measured = False
    fc.errors |= ERR_FALSE_LAUNCH
    fc.kf.reset(fc.ground_alt_mm + fc.baro_agl_mm if baro_ok else fc.kf.alt_q4 >> 4)
    return True


def _backup_rule(fc, cfg):
    """The backup channels (drogue and main states: never on the pad, in the ascent or landed),
    each proven, at most once, after its primary fired: the backup drogue
    ``backup_drogue_delay_s`` after the drogue; the backup main ``backup_main_delay_s`` after
    the main at the earliest, then at or below ``backup_main_m`` (the main fired descending;
    without a usable barometer: at once)."""
    if (cfg.backup_drogue_delay_ms and fc.backup_drogue_fired_ms < 0 and fc.flight_proven
            and fc.drogue_fired_ms >= 0
            and fc.now_ms - fc.drogue_fired_ms >= cfg.backup_drogue_delay_ms):
        fc._fire_backup_drogue()
    if (cfg.backup_main_mm and fc.backup_main_fired_ms < 0 and fc.flight_proven
            and fc.main_fired_ms >= 0
            and fc.now_ms - fc.main_fired_ms >= cfg.backup_main_delay_ms
            and (not fc.mode & MODE_BARO or fc.agl_mm <= cfg.backup_main_mm)):
        fc._fire_backup_main()


def _landing_rule(fc, cfg):
    """Landed: in MAIN (or in DROGUE with no main), the altitude stays within ``landed_alt_m``
    over a window."""
    agl = fc.agl_mm
    if agl < fc._land_min_mm:
        fc._land_min_mm = agl
    if agl > fc._land_max_mm:
        fc._land_max_mm = agl
    if fc.now_ms - fc._land_start_ms >= cfg.landed_window_ms:
        # landed under the main, or under the only parachute when there is no main
        if ((fc.state == MAIN or not cfg.main_deploy_mm)
                and fc._land_max_mm - fc._land_min_mm <= cfg.landed_alt_mm):
            fc.state = LANDED
            fc.events |= EV_LANDED
        fc._land_start_ms = fc.now_ms
        fc._land_min_mm = fc._land_max_mm = agl


def _pyro(fc, now_ms):
    """Each pulse ends pulse_ms after it fired (while any is on: the caller's test)."""
    pulse_ms = fc.cfg.pulse_ms
    if fc.pyro_drogue and now_ms - fc.drogue_fired_ms >= pulse_ms:
        fc.pyro_drogue = False
        fc._pulses -= 1
    if fc.pyro_main and now_ms - fc.main_fired_ms >= pulse_ms:
        fc.pyro_main = False
        fc._pulses -= 1
    if fc.pyro_backup_drogue and now_ms - fc.backup_drogue_fired_ms >= pulse_ms:
        fc.pyro_backup_drogue = False
        fc._pulses -= 1
    if fc.pyro_backup_main and now_ms - fc.backup_main_fired_ms >= pulse_ms:
        fc.pyro_backup_main = False
        fc._pulses -= 1


# Sensor arbitration and degraded modes (docs/DESIGN.md, "Sensor arbitration").


def _arbitrate(fc, now_ms, state, alt_mm, accel_mmps2, acc_kin, have, clipped):
    """The decision mode from each sensor's health; the accelerometer's velocity bounds from
    launch; in coast (and in boost while no reading clipped), the barometer left out while it
    disagrees with them. Returns ``have`` without an excluded barometer."""
    cfg = fc.cfg
    arb = fc.arb
    due = arb.judge_due
    if due:
        judge_late(arb)  # the previous sample's window (see below)
    elif due is None:
        window_drift_test(arb)  # and the sample after, its drift test
    flags = fc.health.flags
    # the track's time: since the accelerometer's previous reading, or since the part of a
    # silence beyond _ACCEL_HOLD_US was accounted as missing (each reading stands for its own
    # interval, so sensors on separate rows integrate as a row with both)
    dt_ms = now_ms - fc._arb_ms
    coasting = FAST <= state <= COAST
    # at rest on the pad: the track starts again at the first boost reading (with a usable
    # reading, ``integrate`` restarts it as it adds the reading)
    restart = (state == PAD and (arb.margin_mmps or not arb.valid) and cfg.has_accel
               and not (acc_kin > cfg.launch_accel_mmps2 or clipped))
    if restart and (flags & _HEALTH_ACCEL_BAD or not have & _HAVE_ACCEL):
        arb.start(0)
        restart = False
    if flags & _HEALTH_ACCEL_BAD and arb.valid:
        arb.stop()  # its integral no longer bounds anything, for the rest of the flight
        if fc.launched:
            # nor do its proof integrals, which skipped the readings judged bad: a proof still
            # owed comes from the barometer alone (D13)
            fc.acc_account = False
    valid = arb.valid or restart
    if not (valid and state < DROGUE):  # the track serves the ascent's decisions
        fc._arb_ms = now_ms
    elif have & _HAVE_ACCEL or clipped:
        fc._arb_ms = now_ms
        left_out = False
        if coasting and not clipped:
            # not drag (a shock, an ejection, a tumble, or thrust: see step), or outside the
            # filter's gate (D16 rule 16): the track holds, its margin covers the reading
            # (the detector's gate is on, GATE_ACC_MMPS2, when its phase is the state: no flags)
            left_out = acc_kin > _NOT_DRAG_MMPS2 or fc._det_phase == state and not (
                -GATE_ACC_MMPS2 <= acc_kin - (fc.kf.acc_q4 >> 4) <= GATE_ACC_MMPS2)
        if left_out:
            arb.integrate_missing(dt_ms, acc_kin)
        else:
            integrate(arb, dt_ms, acc_kin, accel_mmps2, clipped, restart)
    elif dt_ms * 1000 > _ACCEL_HOLD_US:
        fc._arb_ms = now_ms
        arb.integrate_missing(dt_ms, G_MMPS2)  # no usable reading for that long: unknown by 1 g x dt
    mode = 0
    if cfg.has_baro:
        if add_baro(arb, now_ms, alt_mm, have & _HAVE_BARO):
            kf = fc.kf
            # the judgement is left to the next sample (before the track changes, or to a false
            # launch's test), and the window's close costs 9k fewer instructions (the slowest
            # samples of the pad, the boost and the coast closed a window); in coast the
            # barometer is then left out one sample (10 ms at 100 Hz) after its window closed,
            # of windows half a second long. Under the parachutes the steady descent reads the
            # rate on this sample.
            close_slot(arb, now_ms, kf.vel_q4 >> 4, kf.bias_q4 >> 4, state <= COAST)
            if state == PAD and not cfg.has_accel or FAST <= state <= COAST and not fc.health.accel_ok:
                # the ballistic test of a coast without the accelerometer (shared/ballistic.py;
                # its noise learnt on a barometer-only board's pad)
                ballistic.check(arb.ballistic, arb, state == PAD, state == COAST, now_ms)
            elif state == COAST and not arb.upper_valid:
                # after a clipped boost (the track bounds the velocity from below only) the
                # stillness count alone: a barometer frozen under its noise that came back above
                # the filter the clip carried holds the apogee (D16 rule 20)
                ballistic.check(arb.ballistic, arb, False, False, now_ms)
            if fc.baro_excluded and now_ms - fc.health.baro_spike_ms >= _BARO_CLEAN_MS and (
                    arb.parted_beyond_lie(kf.alt_q4 >> 4, now_ms, arb.lie_max_mm, True)
                    or arb.baro_rate_mmps > _HELD_FAST_MMPS
                    and fc.health.accel_held_near_zero_ms(now_ms, _HELD_NEAR_ZERO_MMPS2)
                    >= cfg.accel_stuck_ms):
                # left out, alive (no impossible reading for _BARO_CLEAN_MS, a reading in every
                # slot), and farther above the accelerometer-carried filter than any barometric
                # error, or climbing faster than _HELD_FAST_MMPS while the accelerometer has read
                # one value near zero for accel_stuck_s: the accelerometer lies (zeros from a
                # failed bus, a part reset to another range). The board flies on without it; the
                # filter, whose velocity it carried, takes the barometer's rate (and at the next
                # reading its altitude), and waits baro_settle_s as one that was far off the
                # barometer (D16 rule 14)
                _retire_accel(fc, now_ms, False)
                valid = False
                have &= _HAVE_BARO
        if not flags & _HEALTH_BARO_BAD:
            mode = MODE_BARO
    if cfg.has_accel and not flags & _HEALTH_ACCEL_BAD and (valid or not fc.launched):
        mode |= MODE_ACCEL
    # (in boost too while the track bounds the velocity from both sides: a clipped part's
    # track under-reads, and the barometer must be able to end a boost that a part stuck at full
    # scale fakes)
    excluded = (BOOST <= state <= COAST and not arb.baro_consistent and mode == MODE_BOTH
                and (state != BOOST or arb.upper_valid))
    fc.baro_excluded = excluded
    if excluded:
        mode = MODE_ACCEL
    if mode & MODE_BARO and state == COAST and fc._baro_coast_ms < _ANCHORED_MS:
        coast_ms = fc._baro_coast_ms
        if coast_ms < _DR_REF_MS <= coast_ms + dt_ms:
            # the reference of the dead reckoning's calibration against the barometer, a second
            # into this run: its newest window lies in the run (D16 rule 7)
            note_reference(arb)
        fc._baro_coast_ms = coast_ms + dt_ms
    old = fc.mode
    if mode != old and mode == MODE_BOTH and not old & MODE_BARO and FAST <= state <= COAST:
        rest = arb.reads_no_climb()
        if rest and arb.parted_beyond_lie(fc.kf.alt_q4 >> 4, now_ms, arb.transient_max_mm if state == COAST
                                          else arb.lie_max_mm, False, True):
            # a barometer that would come back below the accelerometer-carried filter farther
            # than a transient can lie (above the Mach lockout, than a static-port error), reading
            # no climb, lies low (frozen under its noise): retired for the flight, and the
            # accelerometer-only apogee decides (D16 rule 20). After a clipped boost too: the clip
            # under-reads, so the filter it carried lies below the rocket (and the backup timer
            # decides: a clipped track bounds nothing from above)
            fc.health.retire_baro()
            fc.baro_excluded = True
            mode = MODE_ACCEL
        elif rest > 1:
            # nor does one that reads no climb and stands still come back: a coasting rocket's
            # rate falls with the track's and passes zero only at apogee (D16 rule 23). Held out,
            # not retired: a window that falls with the coast takes it back. A barometer frozen
            # under its noise 11.7 s before apogee, left out within 0.3 s, came back 5 s before
            # apogee inside the tolerance the track's margin had grown to (its rate 0, the
            # velocity carried 45 to 52 m/s), and the filter, in the late coast's model, followed
            # it through zero 0.6 to 1.2 s early
            fc.baro_excluded = True
            mode = MODE_ACCEL
    if mode != old:
        if old & MODE_BARO and not mode & MODE_BARO:
            fc._filter_anchored = fc._baro_coast_ms >= _ANCHORED_MS
            arb.set_anchor(fc._filter_anchored, fc._dead_reckoning)
            if state == COAST and fc._filter_anchored and fc.health.accel_ok:
                # the ballistic floor from the anchor, with the accelerometer's drag (D16 rule 10)
                ballistic.set_from_track(arb.ballistic, arb, now_ms)
            # the guard of _apogee_enabled: only an anchor whose bias the filter had learnt
            fc._dead_reckoning = fc._dead_reckoning or fc._filter_anchored
            fc._baro_coast_ms = 0
        elif mode & MODE_BARO and not old & MODE_BARO:
            fc._reanchor = True
            if mode & MODE_ACCEL and reads_slow(arb, cfg.baro_back_slow_mmps):
                fc.baro_back_ms = now_ms
            if state == COAST and (not arb.upper_valid or arb.parted_beyond_lie(
                    fc.kf.alt_q4 >> 4, arb.anchor_ms, arb.transient_max_mm, False)):
                # taken back climbing faster than the filter's velocity by more than
                # baro_readmit_mps while that velocity is below it (apogee near, or past): the
                # filter's velocity is not the motion, and it takes the barometer's rate, erring
                # late if the barometer lies fast (D16 rule 13). After a clipped boost (the clip
                # left the filter wrong, and the anchor with it: taken back after 10 s, it crossed
                # zero at once, 4.4 s before apogee at 44 m/s); with an unclipped track, when the
                # barometer comes back farther above the accelerometer-carried filter than a
                # transient can lie (no budget for the filter's own drift: counted as at the
                # anchor; a false call only errs late). Zeros read for half a second of the boost
                # left filter and anchor 100 to 200 m/s slow; the barometer, taken back 2 to 4 km
                # above the filter, climbing at 90 to 150 m/s against a descending filter, fired
                # the drogue at once, 4.7 to 14.6 s early. A transient's decay comes back within
                # 50 m, reading fast: its rate held the drogue up to 3 s late
                kf = fc.kf
                vel_mmps = kf.vel_q4 >> 4
                fast = cfg.baro_readmit_mmps
                if vel_mmps < fast and arb.baro_rate_mmps - vel_mmps > fast:
                    kf.vel_q4 = arb.baro_rate_mmps << 4
        fc.mode = mode
        fc.events |= EV_MODE
    if not mode & MODE_BARO:
        have &= _HAVE_ACCEL
    return have


def _retire_accel(fc, now_ms, noisy):
    """D16 rules 14 and 15 (see _arbitrate and step): the accelerometer retired (``noisy``: by
    rule 15, see SensorHealth.retire_accel); the filter takes the barometer's window rate, and
    waits as one that was far off the barometer."""
    arb = fc.arb
    if arb.judge_due:
        judge_late(arb)  # the newest window's rate
    fc.health.retire_accel(noisy)
    arb.stop()
    fc.kf.vel_q4 = arb.baro_rate_mmps << 4
    fc.off_baro_ms = now_ms


def _accel_only_apogee(fc):
    """Accelerometer only (no barometer, or it is lost, frozen or excluded): apogee when the
    highest vertical velocity its error budget allows is at or below zero: the track's upper
    bound from launch, or, if the barometer had corrected the filter in coast for
    _ANCHORED_MS before it was lost, the filter's velocity before the fault was detected plus
    the track's change and margin since (``Arbitration.set_anchor``). Never early; late by the
    margin / g. A clipped track bounds nothing from above: then the backup timer. Not while a
    barometer left out but alive lies farther above the filter than a pressure transient can
    (the rocket slow, no static-port error), nor while it climbs fast away from the filter:
    the accelerometer does not decide alone against it (D16 rules 14 and 18)."""
    arb = fc.arb
    if not arb.upper_valid:
        return False
    # (the barometer's test last: the bounds hold the apogee off through most of the mode)
    return ((arb.upper_mmps() <= 0 or fc._filter_anchored and arb.anchored_upper_mmps() <= 0)
            and fc.kf.vel_q4 <= 0
            and not (fc.baro_excluded and (arb.parted_beyond_lie(
                fc.kf.alt_q4 >> 4, fc.now_ms, arb.transient_max_mm, False)
                or arb.climbs_away(fc.kf.alt_q4 >> 4, _BARO_AWAY_MMPS))))


def _main_due_without_baro(fc, since_drogue_ms):
    """Barometer lost or frozen under the drogue (proven, after the guard time): the main fires
    when the last barometric reading that moved and the steady descent rate then predict the
    main altitude; without such a descent (no barometer on the board, or none seen)
    ``main_delay_s`` after the drogue; at ``main_backup_s`` after the drogue at the latest."""
    cfg = fc.cfg
    if cfg.main_backup_ms and since_drogue_ms >= cfg.main_backup_ms:
        return True
    # the mean rate of the steady descent seen (decimetres and tenths of a second: the
    # product below stays within 31 bits for 5 km and 600 s)
    fell_dm = (fc._steady_agl_mm - fc._good_agl_mm) // 100
    took_ds = (fc._good_ms - fc._steady_ms) // 100
    if (fc._steady_ms < 0 or took_ds < _STEADY_MIN_DS
            or fell_dm * 10 < took_ds * _DESCENT_MIN_MMPS // 1000):
        return since_drogue_ms >= cfg.main_delay_ms  # no steady descent seen: no prediction
    drop_dm = (fc._good_agl_mm - cfg.main_deploy_mm) // 100
    return drop_dm <= 0 or fc.now_ms - fc._good_ms >= drop_dm * took_ds // fell_dm * 100


def _field(value, top):
    """``value`` clamped to 0..top (a record field)."""
    if value < 0:
        return 0
    if value > top:
        return top
    return value


def _check(head, w1, w2, w3):
    """15-bit check of a resume record (a blank or torn record fails it)."""
    return (head ^ w1 ^ (w1 >> 15) ^ w2 ^ (w2 >> 15) ^ w3 ^ (w3 >> 15) ^ 0x5A5A) & 0x7FFF
