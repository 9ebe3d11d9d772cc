"""A coast checked against ballistics: the velocity floor (docs/DESIGN.md D16 rule 10).

Portable and allocation-free per sample.

Without an accelerometer in use nothing but the barometer measures the motion, and nothing else
tells a pressure transient's decay from a descent. Physics still bounds a coasting rocket: going
up, its vertical acceleration is -g - drag, drag >= 0, and drag falls as the rocket slows and
climbs (in coast, below the Mach lockout: subsonic, in thinning air). On the barometric climb
rates over the arbitration's history of 50 ms slot means (``shared/arbitration.py``, read here):
r0 over the newest 0.5 s, r1 and r2 over the windows 0.5 s and 1 s before it, dt apart:

- *the change test*: nothing lifts a coasting rocket, r0 - r1 <= -g dt + tol, and its
  deceleration does not grow, r0 - r1 >= min(r1 - r2, -g dt) - tol; tol is
  ``baro_ballistic_mps`` plus three times the learnt noise, the mean |r0 - 2 r1 + r2| (on a
  barometer-only board's pad and over the coast's passing windows; a board whose accelerometer
  failed starts from the arbitration's change test). A fault fails _RUN windows in a row;
- *the drag law*: over the coast's passing windows, the drag between r2 and r1,
  (r2 - r1) / dt - g, and the square of their mean speed are averaged: for drag = k v^2 the
  ratio of the averages is k, and the noise of one window pair's drag (a few m/s^2) averages out;
- *the floor*: at the first failure of a run (once the law has _LAW_WINDOWS windows, and if no
  window failed in the _CLEAN_MS before), the vertical velocity is at least r1 less three
  standard deviations of its noise (at r1's middle time), and it falls from there at most at
  g + k' v^2, k' the law's k plus a noise margin: a vertical coast in air of constant density,
  where the real rocket climbs into thinner air. Once the run is _RUN windows long, no apogee
  while the floor is above zero (``holds``), for the rest of the coast. A run that set no floor
  (no law yet, or a failure in the _CLEAN_MS before) holds the apogee until a window that holds
  no failure falls by g dt.

With both sensors the window test does not run (its cost on a Cortex-M0); the barometer's
exclusion by the arbitration sets the floor instead (``set_from_track``), from the filter's
velocity before the fault and the drag the accelerometer measured then. After a clipped boost
(the accelerometer's track bounds the velocity from below only) the stillness count runs in coast
(docs/DESIGN.md D16 rule 20).

Units: rates and the floor in mm/s, drag in mm/s^2, times in ms, the learnt noise in mm/s.
"""

from array import array

try:
    from micropython import const
except ImportError:
    def const(x):
        return x

from shared.arbitration import _clamp, window_decel_mmps2  # (_clamp: x within +-limit)
from shared.physics import G_MMPS2

# The learnt noise is the mean |r0 - 2 r1 + r2|: about 2 standard deviations of one window's rate
# (independent windows: 0.8 x sqrt(6) sigma). The tolerance is baro_ballistic_mps + _NOISE_K x
# it; the floor starts _NOISE_K x sigma below r1, and its drag is half a noise per dt above the
# law's: 0.7 sigma of one window pair's drag, about 1.8 sigma of the law's average (an average
# over 3.2 s holds about 6 independent pairs). A whole noise per dt held fewer transients' decays
# off apogee (docs/BENCHMARKS.md, "A coast checked against ballistics").
_NOISE_K = const(3)
_NOISE_AVG_N = const(40)  # the noise's average: 1/40 per window (2 s of windows at 20 per second)
# A fault fails _RUN windows in a row (0.15 s): a single slot off (a reading stalled at speed) moves
# only the two windows it ends, 0.5 s apart
_RUN = const(3)
# The floor is set only from windows that held no earlier failure: the last one at least three
# windows (1.5 s) before (a rise at the coast's start, before its windows lay in the coast, sits
# in r1 half a second later)
_CLEAN_MS = const(1500)
_DRAG_AVG_N = const(64)  # the drag law's averages: 1/64 per window (3.2 s)
# With both sensors the floor starts from the filter's velocity at the arbitration's anchor, which
# the barometer and the accelerometer together know to about a metre per second: twice that below
_ANCHOR_MARGIN_MMPS = const(2000)
# No floor before the law has averaged this many windows (0.25 s of the coast): without a drag
# law the floor would fall at g alone, above a real coast (after a reset in coast, or a fault in
# the coast's first windows). Ten lost a C6 whose transient came 0.4 s into its windows' coast
_LAW_WINDOWS = const(5)
# A coasting rocket's rate falls by g x dt from one window to the next (drag only adds): a
# barometer whose rate stayed within half of that of none in _STILL_WINDOWS windows (2.5 s at 20
# per second) since one that fell or rose by the whole of it stands still, frozen under its noise
# (or a transient's decay cancels the coast's deceleration), and holds the apogee (docs/DESIGN.md
# D16 rule 20). A frozen part reads no climb: standing at zero, _STILL_MIN_WINDOWS windows (0.5 s,
# one independent window pair) plus one per _STILL_NOISE_MMPS of learnt noise complete the count.
# A quiet part (noise below about 0.85 m/s: a window pair's change known to a quarter of g x dt)
# stands still at a coast's apogee less than once in 10^4 window pairs; a noisier one needs up to
# the five pairs; with no noise learnt (none yet, or a quantised part at rest) the longest count.
_STILL_MIN_WINDOWS = const(10)
_STILL_NOISE_MMPS = const(50)
_STILL_WINDOWS = const(50)
# On a barometer-only board's pad, a window whose rate rose over the second by more than
# _NOISE_K x the learnt noise (about four standard deviations of that rise) plus _REST_MMPS is the
# climb beginning, not noise: the launch by height comes about 0.8 s later, and its accelerating
# windows taught the pad's noise ten to twenty times its value (so every tolerance of the flight)
_REST_MMPS = const(1000)
# Bounds that keep every product inside 31 bits: a rate's change (1 km/s) times 100, a speed
# (m/s) squared times 256, the drag (53 g) times the ratio of squared speeds in 1/256 (at most
# 4), the deceleration (107 g) times a step of at most 1 s.
_CHANGE_LIMIT_MMPS = const(0xFFFFF)
_SPEED_LIMIT_MPS = const(1000)
_DRAG_LIMIT_MMPS2 = const(0x7FFFF)
_RATIO_LIMIT_256 = const(1024)
_DECEL_LIMIT_MMPS2 = const(0xFFFFF)
_DT_LIMIT_MS = const(1000)
# The windows: _WINDOW_SLOTS of the arbitration's 50 ms slots (0.5 s); a rise between two slots is
# clamped to 1 km (the rate then stays within 31 bits)
_WINDOW_SLOTS = const(10)
_RISE_LIMIT_MM = const(0xFFFFF)
# ``_window_rates`` output: the three rates, then the middle times of r1's and r2's windows, and
# the start of r2's window; then, for ``_stands_still``, the windows that moved by g x dt since the
# last that stood still (kept here: an attribute of its own re-laid MicroPython's interned names
# and took the Cortex-M0's worst sample, which never runs this code, to 140.3 to 140.6k
# instructions in two of the four forms)
_R0 = const(0)
_R1 = const(1)
_R2 = const(2)
_T1 = const(3)
_T2 = const(4)
_START = const(5)
_MOVED = const(6)


class Ballistic:
    """The change test's learnt noise, the coast's drag law and the floor; see the module
    docstring."""

    def __init__(self, config):
        # (from the values: one more attribute of the configuration re-lays its table, and so
        # every lookup of it in the step, on MicroPython: docs/BENCHMARKS.md)
        self.tol_mmps = int(config.values["baro_ballistic_mps"] * 1000)
        # the noise: learnt on the pad of a barometer-only board; a board whose accelerometer
        # failed starts from the arbitration's change test (the mean |r0 - r1| there, about
        # 1/sqrt(3) of the mean |r0 - 2 r1 + r2|), so that its pad costs nothing more
        self.noise_from_arb = config.has_accel
        self.noise_mmps = 0
        self.coast_ms = -1  # the first coast sample the test saw (-1: not coasting)
        # the drag the coast's windows showed before any fault: its average (mm/s^2) and the
        # average square of the speed it was measured at ((m/s)^2), over ``windows`` windows
        # (counted to _LAW_WINDOWS)
        self.drag_mmps2 = 0
        self.speed2 = 0
        self.windows = 0
        self.run = 0  # failing windows in a row
        self.fail_ms = -_CLEAN_MS  # the last failing window
        # the floor, set at the first failure of a run (``floor_set``), in force once the run
        # reaches _RUN windows (``anchored``, for the rest of the coast): its velocity, the fall
        # not yet taken off it (um/s) and its drag at the speed whose square is ``speed2``
        self.floor_set = False
        self.anchored = False
        # no apogee: the floor is in force and above zero, a run set no floor, or the barometer
        # stands still (the step reads it)
        self.holds = False
        # windows whose rate stayed within half of g x dt of none, since one that moved by g x dt
        # (the names quiet and _stands_still: of those tried, the cheapest on the Cortex-M0)
        self.quiet = 0
        self.floor_mmps = 0
        self.fall_um = 0
        self.at_ms = 0  # the time the floor was carried on to
        self.floor_drag_mmps2 = 0
        self.rates = array("i", [0] * 7)  # _window_rates' output, and the windows that moved


def check(bal, arb, on_pad, coasting, now_ms):
    """A window of the arbitration ``arb`` closed: ``judge`` its rates. Returns True when the
    window fails."""
    if coasting and not bal.noise_mmps and bal.noise_from_arb:
        bal.noise_mmps = arb._change_avg_mmps * 7 >> 2
    return judge(bal, _window_rates(arb, bal.rates), on_pad, coasting, now_ms)


def judge(bal, got, on_pad, coasting, now_ms):
    """The rates in ``bal.rates`` (``got``: there are three): on the pad (``on_pad``) learn the
    noise; in coast (``coasting``) test that the barometer does not stand still, learn the drag,
    test the change and, at the first failure of a run, set the floor, in force once the run is
    _RUN windows long; else (above the Mach lockout; with both sensors after a clipped boost)
    only the first. Returns True when the window fails."""
    if not coasting:
        bal.coast_ms = -1
    elif bal.coast_ms < 0:
        bal.coast_ms = now_ms
    if not got:
        return False
    r = bal.rates
    if on_pad:  # (the pad: the rates are noise, until the climb begins)
        if r[_R0] - r[_R2] <= _NOISE_K * bal.noise_mmps + _REST_MMPS:
            _learn_noise(bal, _clamp(r[_R0] - r[_R1], _CHANGE_LIMIT_MMPS)
                         - _clamp(r[_R1] - r[_R2], _CHANGE_LIMIT_MMPS))
        return False
    if not bal.tol_mmps:  # (0: the rule is off)
        return False
    dt_cs = (r[_T1] - r[_T2]) // 10  # centiseconds: the products below stay in 31 bits
    if dt_cs <= 0:
        return False
    change = _clamp(r[_R0] - r[_R1], _CHANGE_LIMIT_MMPS)
    least = G_MMPS2 * dt_cs // 100  # the least a coasting rocket's rate falls over dt
    _stands_still(bal, r[_R0], change, least)
    if not coasting:
        return False
    noise = bal.noise_mmps
    tol = bal.tol_mmps + _NOISE_K * noise
    before = _clamp(r[_R1] - r[_R2], _CHANGE_LIMIT_MMPS)
    most = -before if -before > least else least  # the most, as drag does not grow
    if -most - tol <= change <= -least + tol:
        bal.run = 0
        if not bal.anchored:  # (after a fault its decay would teach the noise and the drag)
            bal.floor_set = False  # (a glitch: a single slot off moves two windows, not _RUN)
            if change < -least and now_ms - bal.fail_ms >= _CLEAN_MS:
                # falling as a coast, its windows clean of the run's fault: a hold without a
                # floor ends (not the stillness count's: one window is no motion)
                bal.holds = bal.quiet >= _STILL_WINDOWS
            if r[_START] >= bal.coast_ms:  # r1 and r2 both in this coast (the boost's end is
                # no noise: a barometer frozen in the boost, whose fall to zero passes as the
                # deceleration at burnout, taught the noise fifty times its value in 0.5 s)
                # (a second difference beyond three noises and g x dt counts as that, so that one
                # window pair moves the noise by a bounded step: a part frozen near apogee, its
                # rate's fall to zero inside the tolerance, taught it six times its value in 0.6 s)
                _learn_noise(bal, _clamp(change - before, _NOISE_K * noise + least))
                _learn_drag(bal, before, dt_cs)
        return False
    bal.run += 1
    if bal.anchored:
        return True
    clean = now_ms - bal.fail_ms >= _CLEAN_MS  # (r1 and r2 held no earlier failure's fault)
    bal.fail_ms = now_ms
    if bal.run == 1 and r[_START] >= bal.coast_ms and clean and bal.windows >= _LAW_WINDOWS:
        # the floor: r1 less its noise at r1's middle time (the drag's margin: see _NOISE_K)
        _set_floor(bal, r[_R1] - _NOISE_K * noise // 2,
                   bal.drag_mmps2 + (noise * 100 // dt_cs >> 1), r[_T1], now_ms)
    elif bal.run >= _RUN and bal.floor_set:
        bal.anchored = True
        bal.holds = bal.floor_mmps > 0
    elif bal.run >= _RUN:
        # no floor (no drag law yet: the coast's first 1.5 s; or a failure shortly before): the
        # apogee held until a clean window falls as a coast (a barometer frozen under its noise
        # then stands still, and the count holds it on)
        bal.holds = True
    return True


def _stands_still(bal, rate, change, least):
    """Count the windows whose ``rate`` changed by less than half of ``least`` (g x dt) while not
    descending faster than that, since one that changed or descended by the whole of it (a
    noise's dip does not end the run; a transient's return, rising, is no standing still, nor a
    steady descent under a parachute, the only flight whose rate holds; _RUN of them since the
    last that stood still, as a slot off moves isolated windows and motion all of them):
    _STILL_WINDOWS of them,
    or, while the rate stands at zero within half of ``least`` (a frozen part reads no climb),
    _STILL_MIN_WINDOWS plus one per _STILL_NOISE_MMPS of learnt noise, hold the apogee
    (``holds``) until a window moves again (docs/DESIGN.md D16 rule 20)."""
    if change < 0:
        change = -change
    if -rate > change:  # (a descent is motion too: under a parachute its rate holds)
        change = -rate
    r = bal.rates
    if change < least >> 1:
        r[_MOVED] = 0
        quiet = bal.quiet + 1
        noise = bal.noise_mmps
        if noise and rate < least >> 1 and quiet >= _STILL_MIN_WINDOWS + noise // _STILL_NOISE_MMPS:
            quiet = _STILL_WINDOWS  # (complete: it stays so until windows move)
        bal.quiet = quiet
        if quiet >= _STILL_WINDOWS:
            bal.holds = True
    elif change > least and bal.quiet:
        r[_MOVED] += 1
        if r[_MOVED] >= _RUN:  # (a single slot off moves isolated windows; motion, them all)
            bal.quiet = 0
            bal.holds = bal.anchored and bal.floor_mmps > 0


def _window_rates(arb, out):
    """The barometric climb rates (mm/s) of the windows ending at the arbitration's newest slot, at
    the slot ``_WINDOW_SLOTS`` before it and at the one ``2 * _WINDOW_SLOTS`` before, then the
    middle times of the second and third windows and the start of the third (ms), into ``out``.
    False, and ``out`` untouched, until the history holds the three windows, or while the newest
    window holds a slot without a barometric reading. (It reads the arbitration's history here:
    one more function there re-lays that module's globals, and so every lookup of them in its
    per-sample code, on MicroPython.)"""
    if arb._slots <= 3 * _WINDOW_SLOTS or arb._unjudged:
        return False
    t = arb._t
    alt = arb._alt
    size = len(t)
    i = arb._head
    k = 0
    while k < 3:  # (no range: it allocates on MicroPython)
        j = i - _WINDOW_SLOTS
        if j < 0:
            j += size
        span_ms = t[i] - t[j]
        if span_ms <= 0:
            return False
        out[k] = _clamp(alt[i] - alt[j], _RISE_LIMIT_MM) * 1000 // span_ms
        if k:
            out[2 + k] = (t[i] + t[j]) >> 1
        i = j
        k += 1
    out[5] = t[i]
    return True


def set_from_track(bal, arb, now_ms):
    """With both sensors, the barometer was left out in coast after correcting the filter long
    enough (``Arbitration.set_anchor`` just ran): the floor from the filter's velocity at the
    anchor less _ANCHOR_MARGIN_MMPS, with the drag the accelerometer's track shows over the 0.5 s
    after the anchor (less the filter's bias estimate then) as the law at the anchor's speed, and
    carried on to now."""
    if bal.floor_set or not bal.tol_mmps:
        return
    t = arb._t
    # the anchor's slot, as ``set_anchor`` takes it: the history is full by now (4 s of coast),
    # so its oldest slot follows the newest (the slot kept as an attribute of the arbitration
    # re-laid its table: +1.3k mean, 140.2k worst instructions on the Cortex-M0)
    i = arb._head + 1
    if i >= len(t):
        i = 0
    v = arb.anchor_filter_mmps
    if v <= 0:
        return
    drag = window_decel_mmps2(arb, i) + arb._fbias[i] - G_MMPS2
    speed = v // 1000
    bal.speed2 = speed * speed if speed > 0 else 1
    _set_floor(bal, v - _ANCHOR_MARGIN_MMPS, drag, arb.anchor_ms, now_ms)
    bal.anchored = True
    bal.holds = bal.floor_mmps > 0


def _set_floor(bal, floor_mmps, drag_mmps2, at_ms, now_ms):
    """Set the floor (pending until ``anchored``) at ``floor_mmps`` at ``at_ms``, its drag
    ``drag_mmps2`` (at the speed whose square is ``speed2``; within 0 to _DRAG_LIMIT_MMPS2, the
    bound ``fall`` needs), and carry it on to ``now_ms``."""
    if drag_mmps2 < 0:
        drag_mmps2 = 0
    elif drag_mmps2 > _DRAG_LIMIT_MMPS2:
        drag_mmps2 = _DRAG_LIMIT_MMPS2
    bal.floor_drag_mmps2 = drag_mmps2
    bal.floor_mmps = floor_mmps
    bal.fall_um = 0
    bal.at_ms = at_ms
    bal.floor_set = True
    fall(bal, now_ms)


def _learn_noise(bal, second_mmps):
    """Average |r0 - 2 r1 + r2| (``second_mmps``, each change clamped) into the noise."""
    if second_mmps < 0:
        second_mmps = -second_mmps
    bal.noise_mmps += (second_mmps - bal.noise_mmps) // _NOISE_AVG_N


def _learn_drag(bal, before_mmps, dt_cs):
    """Average the drag between r2 and r1 (their change ``before_mmps`` over ``dt_cs``, less g)
    and the square of their mean speed (the first window of the coast sets both)."""
    r = bal.rates
    drag = _clamp(-before_mmps * 100 // dt_cs - G_MMPS2, _DRAG_LIMIT_MMPS2)
    speed = ((r[_R1] + r[_R2]) >> 1) // 1000
    if speed < 0:
        speed = 0
    elif speed > _SPEED_LIMIT_MPS:
        speed = _SPEED_LIMIT_MPS
    n = bal.windows
    if n:
        bal.drag_mmps2 += (drag - bal.drag_mmps2) // _DRAG_AVG_N
        bal.speed2 += (speed * speed - bal.speed2) // _DRAG_AVG_N
    else:
        bal.drag_mmps2 = drag
        bal.speed2 = speed * speed
    if n < _LAW_WINDOWS:
        bal.windows = n + 1


def fall(bal, now_ms):
    """Carry the floor on to ``now_ms`` (from ``bal.at_ms``: the samples' own clock, not their
    whole milliseconds, which a board's jitter truncates by up to a tenth): down at
    g + drag v^2 / speed2 while it is above zero, in steps of at most _DT_LIMIT_MS (Euler with the
    deceleration at each step's start: the floor stays below the exact one)."""
    dt_ms = now_ms - bal.at_ms
    bal.at_ms = now_ms
    while dt_ms > 0:
        v = bal.floor_mmps
        if v <= 0:
            bal.holds = bal.quiet >= _STILL_WINDOWS
            return
        step = dt_ms if dt_ms < _DT_LIMIT_MS else _DT_LIMIT_MS
        dt_ms -= step
        speed = (v + 999) // 1000  # (rounded up: more drag, a lower floor)
        if speed > _SPEED_LIMIT_MPS:
            speed = _SPEED_LIMIT_MPS
        speed2 = bal.speed2 if bal.speed2 > 0 else 1
        ratio = speed * speed * 256 // speed2
        if ratio > _RATIO_LIMIT_256:
            ratio = _RATIO_LIMIT_256
        decel = G_MMPS2 + (bal.floor_drag_mmps2 * ratio >> 8)
        if decel > _DECEL_LIMIT_MMPS2:
            decel = _DECEL_LIMIT_MMPS2
        um = bal.fall_um + decel * step  # (the fall's sub-mm/s remainder carried: um/s)
        v -= um // 1000
        bal.floor_mmps = v
        bal.fall_um = um % 1000
        if v <= 0:
            bal.holds = bal.quiet >= _STILL_WINDOWS
