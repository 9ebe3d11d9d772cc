"""Guest side of tools/armboard.py: per-sample SysTick counts of the flight code on the emulated
board, heap-locked or not, and the integer states to compare with CPython.

Runs on MicroPython (the qemu port built by tools/armboard.py; ``time.ticks_cpu()`` returns
SysTick cycles there) and imports on CPython (``ticks_cpu`` is then a nanosecond clock), so the
same functions give the CPython reference states. Each ``count_*`` function returns
``(ticks, phases, states)``: array('i') of SysTick cycles per sample (the measuring overhead
included; ``overhead()`` gives it), array('b') of the flight phase per sample (PAD, BOOST,
COAST, DESCENT below) and array('i') of the integer states the tests compare.
"""

import gc
import time
from array import array

try:
    import micropython
except ImportError:
    micropython = None

from shared import gains_table
from shared.apogee import VelocityRule
from shared.config import load_config
from shared.detector import HAVE_BOTH, Detector
from shared.flight import BOOST as _FC_BOOST
from shared.flight import DROGUE as _FC_DROGUE
from shared.flight import PAD as _FC_PAD
from shared.flight import FlightComputer

if hasattr(time, "ticks_cpu"):
    _ticks = time.ticks_cpu
    _diff = time.ticks_diff
else:  # CPython: states only; the counts are nanoseconds
    _ticks = time.perf_counter_ns

    def _diff(a, b):
        return a - b

PAD = 0
BOOST = 1
COAST = 2
DESCENT = 3
PHASE_NAMES = ("pad", "boost", "coast", "descent")
_ONE_G_MMPS2 = 9807
_OVERHEAD_SAMPLES = 200
_DUMP_CHUNK = 256
FAKE_BUS_TICKS = None  # firmware_path(replay=True): the counts of its run on the fake I2C bus


def _phase(state):
    """The benchmark's phase (PAD, BOOST, COAST, DESCENT) of a flight-computer state."""
    return PAD if state == _FC_PAD else (BOOST if state == _FC_BOOST else (
        COAST if state < _FC_DROGUE else DESCENT))


def _lock():
    if micropython is not None:
        micropython.heap_lock()


def _unlock():
    if micropython is not None:
        micropython.heap_unlock()


def overhead():
    """Minimum SysTick cycles between two consecutive readings in the measuring loop's shape."""
    tc = _ticks
    td = _diff
    out = array("i", bytearray(4 * _OVERHEAD_SAMPLES))
    _lock()
    try:
        for i in range(_OVERHEAD_SAMPLES):
            t0 = tc()
            t1 = tc()
            out[i] = td(t1, t0)
    finally:
        _unlock()
    return min(out)


def flight_phases(flight, rate_hz, pad_s, burn_ms):
    """Phase of every sample of a ``tools.synthetic_flight.make_flight`` flight, from its profile."""
    n = len(flight[0])
    n_pad = pad_s * rate_hz
    n_boost = n_pad + burn_ms * rate_hz // 1000
    apogee = flight[4]
    out = array("b", bytearray(n))
    for i in range(n):
        out[i] = PAD if i < n_pad else (BOOST if i < n_boost else (COAST if i <= apogee else DESCENT))
    return out


def _fc_loop(fc, dts, alts, accs, ticks, phases, states):
    tc = _ticks
    td = _diff
    for i in range(len(dts)):
        t0 = tc()
        fc.step(dts[i], alts[i], accs[i] + _ONE_G_MMPS2, HAVE_BOTH)
        t1 = tc()
        ticks[i] = td(t1, t0)
        s = fc.state
        phases[i] = _phase(s)
        j = 4 * i
        kf = fc.kf
        states[j] = kf.alt_q4
        states[j + 1] = kf.vel_q4
        states[j + 2] = s
        states[j + 3] = fc.events


def count_fc(flight, lock=True, config=None):
    """FlightComputer.step over the flight; states per sample: alt_q4, vel_q4, state, events."""
    dts, alts, accs = flight[0], flight[1], flight[2]
    n = len(dts)
    fc = FlightComputer(load_config(config))
    ticks = array("i", bytearray(4 * n))
    phases = array("b", bytearray(n))
    states = array("i", bytearray(16 * n))
    if lock:
        _lock()
    try:
        _fc_loop(fc, dts, alts, accs, ticks, phases, states)
    finally:
        if lock:
            _unlock()
    return ticks, phases, states


def _det_loop(det, dts, alts, accs, enable_from, ticks, states):
    tc = _ticks
    td = _diff
    for i in range(1, len(dts)):
        t0 = tc()
        det.step(dts[i], alts[i], accs[i], HAVE_BOTH, i >= enable_from)
        t1 = tc()
        ticks[i] = td(t1, t0)
        kf = det.kf
        j = 3 * i
        states[j] = kf.alt_q4
        states[j + 1] = kf.vel_q4
        states[j + 2] = kf.acc_q4


def count_detector(flight, phases, enable_from, lock=True):
    """Detector.step (filter + velocity rule, project gains) over samples 1..n-1."""
    dts, alts, accs = flight[0], flight[1], flight[2]
    n = len(dts)
    det = Detector(gains_table.PROJECT, VelocityRule())
    det.start(alts[0], accs[0])
    ticks = array("i", bytearray(4 * n))
    states = array("i", bytearray(12 * n))
    if lock:
        _lock()
    try:
        _det_loop(det, dts, alts, accs, enable_from, ticks, states)
    finally:
        if lock:
            _unlock()
    return ticks, phases, states


def _kf_loop(kf, row, alts, accs, ticks, states):
    tc = _ticks
    td = _diff
    for i in range(1, len(alts)):
        t0 = tc()
        kf.predict(row)
        kf.correct(row, row, alts[i], accs[i])  # both sensors read at the same rate
        t1 = tc()
        ticks[i] = td(t1, t0)
        j = 3 * i
        states[j] = kf.alt_q4
        states[j + 1] = kf.vel_q4
        states[j + 2] = kf.acc_q4


def count_filter(flight, phases, rate_hz, lock=True):
    """Kalman predict + correct (both sensors, plain model) at the flight's rate."""
    alts, accs = flight[1], flight[2]
    n = len(alts)
    det = Detector(gains_table.PROJECT, VelocityRule())
    det.start(alts[0], accs[0])
    row = gains_table.PROJECT[0]
    for r in gains_table.PROJECT:
        if r[0] == rate_hz:
            row = r
    ticks = array("i", bytearray(4 * n))
    states = array("i", bytearray(12 * n))
    if lock:
        _lock()
    try:
        _kf_loop(det.kf, row, alts, accs, ticks, states)
    finally:
        if lock:
            _unlock()
    return ticks, phases, states


# -- per-function breakdown of the full step ------------------------------------------------------
#
# ``profile_fc`` replaces the methods named in PROFILE (and module-level functions) by wrappers
# that read SysTick around the real call: an instance attribute shadows the class's method, so
# ``self.x(...)`` and ``obj.x(...)`` both reach the wrapper; a module global does the same for a
# module-level function. Each wrapper is a plain function whose bindings are default arguments (a
# closure over more than a few values, or a bound method called with more than 4 arguments, would
# allocate on MicroPython and fail under the heap lock) and calls the class's function with the
# instance. Self time = inclusive time less the children's (their inclusive time and the wrapper's
# own cost, calibrated on a no-op), so the self times of all functions add up to the unprofiled step
# within the map-cache effects of the extra instance attributes.

# (label, object path from the flight computer or "module:" + module name, attribute, arity)
PROFILE = (
    ("flight._arbitrate", "module:shared.flight", "_arbitrate", 8),
    ("flight._set_baro_weight", "module:shared.flight", "_set_baro_weight", 5),
    ("flight._configure_detector", "module:shared.flight", "_configure_detector", 5),
    ("flight._apogee_enabled", "module:shared.flight", "_apogee_enabled", 3),
    ("flight._accel_only_apogee", "module:shared.flight", "_accel_only_apogee", 1),
    ("flight._update_averages", "module:shared.flight", "_update_averages", 9),
    ("flight._update_boost", "module:shared.flight", "_update_boost", 7),
    ("flight._integrate_accel", "module:shared.flight", "_integrate_accel", 5),
    ("flight._transition", "module:shared.flight", "_transition", 4),
    ("flight._false_launch", "module:shared.flight", "_false_launch", 2),
    ("flight._drogue_rule", "module:shared.flight", "_drogue_rule", 4),
    ("flight._backup_rule", "module:shared.flight", "_backup_rule", 2),
    ("flight._landing_rule", "module:shared.flight", "_landing_rule", 2),
    ("flight._check_proof", "module:shared.flight", "_check_proof", 3),
    ("flight._pyro", "module:shared.flight", "_pyro", 2),
    ("health.check_health", "module:shared.flight", "check_health", 7),
    ("padcal.update_pad", "module:shared.flight", "update_pad", 6),
    ("padcal._add_alt", "module:shared.padcal", "_add_alt", 3),
    ("padcal._apply", "module:shared.padcal", "_apply", 5),
    ("padcal._check_orientation", "module:shared.padcal", "_check_orientation", 2),
    ("arbitration.integrate", "module:shared.flight", "integrate", 6),
    ("Arbitration.integrate_missing", "arb", "integrate_missing", 2),
    ("arbitration.add_baro", "module:shared.flight", "add_baro", 4),
    ("arbitration.close_slot", "module:shared.flight", "close_slot", 5),
    ("arbitration.judge_late", "module:shared.flight", "judge_late", 1),
    ("arbitration._judge", "module:shared.arbitration", "_judge", 5),
    ("Arbitration.start", "arb", "start", 1),
    ("Detector.step", "det", "step", 5),
    ("Detector._predict_irregular", "det", "_predict_irregular", 1),
    ("Detector._interval_row", "det", "_interval_row", 1),
    ("Detector._outlier", "det", "_outlier", 4),
    ("Detector._set_period", "det", "_set_period", 1),
    ("VelocityRule.update", "rule", "update", 3),
    ("Kalman.predict", "kf", "predict", 1),
    ("Kalman.correct", "kf", "correct", 4),
    ("Kalman.correct_baro", "kf", "correct_baro", 2),
    ("Kalman.correct_accel", "kf", "correct_accel", 2),
    ("Kalman.correct_coast", "kf", "correct_coast", 4),
    ("Kalman.correct_baro_part", "kf", "correct_baro_part", 3),
    ("Kalman.correct_accel_part", "kf", "correct_accel_part", 3),
    ("Kalman.correct_gravity", "kf", "correct_gravity", 2),
    ("kalman._baro_innovation", "module:shared.kalman", "_baro_innovation", 2),
    ("kalman._accel_innovation", "module:shared.kalman", "_accel_innovation", 2),
    ("kalman._add2", "module:shared.kalman", "_add2", 6),
    ("kalman._add", "module:shared.kalman", "_add", 5),
    ("kalman._mul_gain", "module:shared.kalman", "_mul_gain", 3),
)
_P_MAX_DEPTH = 16
_p_depth = array("i", [0])
# per depth: the children's ticks as the caller saw them (wrapper cost included), and the count of
# wrapped calls below (to take the wrappers' cost out of the inclusive times)
_p_child = array("i", [0] * _P_MAX_DEPTH)
_p_desc = array("i", [0] * _P_MAX_DEPTH)
_p_incl = None  # per function, this sample: inclusive ticks, self ticks, calls
_p_self = None
_p_calls = None
_p_cost = array("i", [0])  # a wrapped call's extra ticks seen by its caller (calibrated)
_p_ovh = array("i", [0])  # the readings' own ticks inside a wrapper, beyond the call's (calibrated)


def _p_enter():
    d = _p_depth[0] + 1
    _p_depth[0] = d
    _p_child[d] = 0
    _p_desc[d] = 0
    return d


def _p_leave(d, slot, dt):
    dt -= _p_ovh[0]
    desc = _p_desc[d]
    _p_depth[0] = d - 1
    _p_incl[slot] += dt - desc * _p_cost[0]
    _p_self[slot] += dt - _p_child[d]
    _p_calls[slot] += 1
    _p_child[d - 1] += dt + _p_cost[0]
    _p_desc[d - 1] += 1 + desc


def _wrapper(fn, obj, slot, arity):
    """A wrapper of ``fn`` (called with ``obj`` first unless it is None) with ``arity`` arguments."""
    tc = _ticks
    td = _diff
    if obj is None:
        if arity == 1:
            def w(a, _f=fn, _s=slot, _tc=tc, _td=td):
                d = _p_enter()
                t0 = _tc()
                r = _f(a)
                _p_leave(d, _s, _td(_tc(), t0))
                return r
        elif arity == 2:
            def w(a, b, _f=fn, _s=slot, _tc=tc, _td=td):
                d = _p_enter()
                t0 = _tc()
                r = _f(a, b)
                _p_leave(d, _s, _td(_tc(), t0))
                return r
        elif arity == 3:
            def w(a, b, c, _f=fn, _s=slot, _tc=tc, _td=td):
                d = _p_enter()
                t0 = _tc()
                r = _f(a, b, c)
                _p_leave(d, _s, _td(_tc(), t0))
                return r
        elif arity == 4:
            def w(a, b, c, e, _f=fn, _s=slot, _tc=tc, _td=td):
                d = _p_enter()
                t0 = _tc()
                r = _f(a, b, c, e)
                _p_leave(d, _s, _td(_tc(), t0))
                return r
        elif arity == 5:
            def w(a, b, c, e, f, _f=fn, _s=slot, _tc=tc, _td=td):
                d = _p_enter()
                t0 = _tc()
                r = _f(a, b, c, e, f)
                _p_leave(d, _s, _td(_tc(), t0))
                return r
        elif arity == 6:
            def w(a, b, c, e, f, h, _f=fn, _s=slot, _tc=tc, _td=td):
                d = _p_enter()
                t0 = _tc()
                r = _f(a, b, c, e, f, h)
                _p_leave(d, _s, _td(_tc(), t0))
                return r
        elif arity == 7:
            def w(a, b, c, e, f, h, i, _f=fn, _s=slot, _tc=tc, _td=td):
                d = _p_enter()
                t0 = _tc()
                r = _f(a, b, c, e, f, h, i)
                _p_leave(d, _s, _td(_tc(), t0))
                return r
        elif arity == 8:
            def w(a, b, c, e, f, h, i, j, _f=fn, _s=slot, _tc=tc, _td=td):
                d = _p_enter()
                t0 = _tc()
                r = _f(a, b, c, e, f, h, i, j)
                _p_leave(d, _s, _td(_tc(), t0))
                return r
        elif arity == 9:
            def w(a, b, c, e, f, h, i, j, k, _f=fn, _s=slot, _tc=tc, _td=td):
                d = _p_enter()
                t0 = _tc()
                r = _f(a, b, c, e, f, h, i, j, k)
                _p_leave(d, _s, _td(_tc(), t0))
                return r
        else:
            raise ValueError("module function arity %d" % arity)
        return w
    if arity == 0:
        def w(_f=fn, _o=obj, _s=slot, _tc=tc, _td=td):
            d = _p_enter()
            t0 = _tc()
            r = _f(_o)
            _p_leave(d, _s, _td(_tc(), t0))
            return r
    elif arity == 1:
        def w(a, _f=fn, _o=obj, _s=slot, _tc=tc, _td=td):
            d = _p_enter()
            t0 = _tc()
            r = _f(_o, a)
            _p_leave(d, _s, _td(_tc(), t0))
            return r
    elif arity == 2:
        def w(a, b, _f=fn, _o=obj, _s=slot, _tc=tc, _td=td):
            d = _p_enter()
            t0 = _tc()
            r = _f(_o, a, b)
            _p_leave(d, _s, _td(_tc(), t0))
            return r
    elif arity == 3:
        def w(a, b, c, _f=fn, _o=obj, _s=slot, _tc=tc, _td=td):
            d = _p_enter()
            t0 = _tc()
            r = _f(_o, a, b, c)
            _p_leave(d, _s, _td(_tc(), t0))
            return r
    elif arity == 4:
        def w(a, b, c, e, _f=fn, _o=obj, _s=slot, _tc=tc, _td=td):
            d = _p_enter()
            t0 = _tc()
            r = _f(_o, a, b, c, e)
            _p_leave(d, _s, _td(_tc(), t0))
            return r
    elif arity == 5:
        def w(a, b, c, e, f, _f=fn, _o=obj, _s=slot, _tc=tc, _td=td):
            d = _p_enter()
            t0 = _tc()
            r = _f(_o, a, b, c, e, f)
            _p_leave(d, _s, _td(_tc(), t0))
            return r
    elif arity == 6:
        def w(a, b, c, e, f, h, _f=fn, _o=obj, _s=slot, _tc=tc, _td=td):
            d = _p_enter()
            t0 = _tc()
            r = _f(_o, a, b, c, e, f, h)
            _p_leave(d, _s, _td(_tc(), t0))
            return r
    else:
        raise ValueError("method arity %d" % arity)
    return w


class _Noop:
    def m1(self, a):
        return a


def _p_calibrate():
    """The wrapper's costs, from a wrapped no-op against a plain call of it, both timed outside:
    its readings' ticks beyond those of the plain call (taken out of every inclusive time) and the
    extra ticks its caller sees (taken out of the caller's self time)."""
    global _p_incl, _p_self, _p_calls
    tc = _ticks
    td = _diff
    _p_incl = array("i", [0])
    _p_self = array("i", [0])
    _p_calls = array("i", [0])
    _p_ovh[0] = 0
    _p_cost[0] = 0
    o = _Noop()
    empty = plain = wrapped = inner = 0x3FFFFFFF
    w = _wrapper(_Noop.m1, o, 0, 1)
    _lock()
    try:
        for _ in range(50):
            t0 = tc()
            t1 = tc()
            empty = min(empty, td(t1, t0))
            t0 = tc()
            o.m1(1)
            t1 = tc()
            plain = min(plain, td(t1, t0))
            _p_incl[0] = 0
            _p_depth[0] = 0
            t0 = tc()
            w(1)
            t1 = tc()
            wrapped = min(wrapped, td(t1, t0))
            inner = min(inner, _p_incl[0])
    finally:
        _unlock()
    _p_ovh[0] = inner - (plain - empty)  # the no-op's inclusive time is then its plain call's
    _p_cost[0] = wrapped - plain
    return array("i", (_p_ovh[0], _p_cost[0]))


def _p_loop(fc, dts, alts, accs, ticks, phases, k, incl_ph, self_ph, calls_ph, self_worst):
    tc = _ticks
    td = _diff
    top = _p_child
    for i in range(len(dts)):
        _p_depth[0] = 0
        top[0] = 0
        _p_desc[0] = 0
        t0 = tc()
        fc.step(dts[i], alts[i], accs[i] + _ONE_G_MMPS2, HAVE_BOTH)
        t1 = tc()
        ticks[i] = td(t1, t0)
        ph = _phase(fc.state)
        phases[i] = ph
        base = ph * (k + 1)  # each phase: the functions of PROFILE, then the step
        for j in range(k):
            incl_ph[base + j] += _p_incl[j]
            self_ph[base + j] += _p_self[j]
            calls_ph[base + j] += _p_calls[j]
            if _p_self[j] > self_worst[j]:
                self_worst[j] = _p_self[j]
            _p_incl[j] = _p_self[j] = _p_calls[j] = 0
        # the step's own time: its children's (wrapper costs included) taken out
        j = k
        incl_ph[base + j] += ticks[i] - _p_desc[0] * _p_cost[0]
        self_ph[base + j] += ticks[i] - top[0]
        calls_ph[base + j] += 1
        if ticks[i] - top[0] > self_worst[j]:
            self_worst[j] = ticks[i] - top[0]


def profile_fc(flight_data, config=None):
    """FlightComputer.step over the flight with the functions of PROFILE timed (heap locked).
    Returns (labels, per-phase ticks: inclusive, self and calls summed over the phase's samples as
    arrays of 4 x (len(labels)) laid out phase by phase, the worst sample's self ticks per label,
    the step's ticks per sample, the phases, (wrapper readings' ticks, wrapper cost))."""
    global _p_incl, _p_self, _p_calls
    calib = _p_calibrate()
    dts, alts, accs = flight_data[0], flight_data[1], flight_data[2]
    n = len(dts)
    fc = FlightComputer(load_config(config))
    objs = {"fc": fc, "health": fc.health, "pad": fc.pad, "arb": fc.arb, "det": fc.det, "kf": fc.kf,
            "rule": fc.det.rule}
    from shared import arbitration, detector, flight, kalman, padcal

    modules = {"shared.flight": flight, "shared.kalman": kalman, "shared.detector": detector,
               "shared.padcal": padcal, "shared.arbitration": arbitration}
    k = len(PROFILE)
    _p_incl = array("i", bytearray(4 * k))
    _p_self = array("i", bytearray(4 * k))
    _p_calls = array("i", bytearray(4 * k))
    restore = []
    for slot, (_label, where, name, arity) in enumerate(PROFILE):
        # a name the code no longer has is left out (its row then shows no calls)
        if where.startswith("module:"):
            mod = modules[where[7:]]
            fn = getattr(mod, name, None)
            if fn is not None:
                restore.append((mod, name, fn))
                setattr(mod, name, _wrapper(fn, None, slot, arity))
        else:
            obj = objs[where]
            fn = getattr(type(obj), name, None)
            if fn is not None:
                setattr(obj, name, _wrapper(fn, obj, slot, arity))
    labels = [p[0] for p in PROFILE] + ["FlightComputer.step"]
    incl_ph = array("i", bytearray(16 * (k + 1)))
    self_ph = array("i", bytearray(16 * (k + 1)))
    calls_ph = array("i", bytearray(16 * (k + 1)))
    self_worst = array("i", bytearray(4 * (k + 1)))
    ticks = array("i", bytearray(4 * n))
    phases = array("b", bytearray(n))
    _lock()
    try:
        _p_loop(fc, dts, alts, accs, ticks, phases, k, incl_ph, self_ph, calls_ph, self_worst)
    finally:
        _unlock()
        for mod, name, fn in restore:
            setattr(mod, name, fn)
    return labels, incl_ph, self_ph, calls_ph, self_worst, ticks, phases, calib


def dump_profile(result):
    """Print a profile_fc result as lines the host parses."""
    labels, incl_ph, self_ph, calls_ph, self_worst, ticks, phases, calib = result
    print("profile labels: " + " ".join(labels))
    print_ints("profile calib", calib)
    print_ints("profile incl", incl_ph)
    print_ints("profile self", self_ph)
    print_ints("profile calls", calls_ph)
    print_ints("profile worst", self_worst)
    print_ints("profile ticks", ticks)
    print_ints("profile phases", phases)


# -- what one bytecode operation costs -------------------------------------------------------------

_G_ONE = 1


def _cost_f0():
    pass


def _cost_f3(a, b, c):
    return a


class _CostProbe:
    def noop(self):
        pass


def op_costs():
    """Instructions (in SysTick cycles, ten operations per reading) of single operations and of
    calls, heap locked: [(label, ticks for ten)]. The method call is a no-op method put on each of
    the flight computer's classes, called on its real instance: its lookup misses the instance's
    attribute table as a real method's does (the cost depends on how full the table is and where
    the name's hash falls)."""
    tc = _ticks
    td = _diff
    fc = FlightComputer(load_config())
    x = 1
    y = 7
    arr = array("i", (0, 0))
    out = []

    def best(run):
        b = 0x3FFFFFFF
        for _ in range(5):
            _lock()
            try:
                b = min(b, run())
            finally:
                _unlock()
        return b

    def empty():
        t0 = tc()
        return td(tc(), t0)

    e = best(empty)

    def local():
        t0 = tc()
        x; x; x; x; x; x; x; x; x; x  # noqa: B018, E702
        return td(tc(), t0)

    def glob():
        t0 = tc()
        _G_ONE; _G_ONE; _G_ONE; _G_ONE; _G_ONE; _G_ONE; _G_ONE; _G_ONE; _G_ONE; _G_ONE  # noqa: B018, E702
        return td(tc(), t0)

    kf = fc.kf

    def attr():
        t0 = tc()
        kf.alt_q4; kf.alt_q4; kf.alt_q4; kf.alt_q4; kf.alt_q4; kf.alt_q4; kf.alt_q4; kf.alt_q4; kf.alt_q4; kf.alt_q4  # noqa: B018, E501, E702
        return td(tc(), t0)

    def store():
        t0 = tc()
        kf.bias_q4 = x; kf.bias_q4 = x; kf.bias_q4 = x; kf.bias_q4 = x; kf.bias_q4 = x; kf.bias_q4 = x; kf.bias_q4 = x; kf.bias_q4 = x; kf.bias_q4 = x; kf.bias_q4 = x  # noqa: E501, E702
        return td(tc(), t0)

    def subscr():
        t0 = tc()
        arr[1]; arr[1]; arr[1]; arr[1]; arr[1]; arr[1]; arr[1]; arr[1]; arr[1]; arr[1]  # noqa: B018, E702
        return td(tc(), t0)

    def add():
        t0 = tc()
        x + y; x + y; x + y; x + y; x + y; x + y; x + y; x + y; x + y; x + y  # noqa: B018, E702
        return td(tc(), t0)

    def mul():
        t0 = tc()
        x * y; x * y; x * y; x * y; x * y; x * y; x * y; x * y; x * y; x * y  # noqa: B018, E702
        return td(tc(), t0)

    def call0():
        t0 = tc()
        _cost_f0(); _cost_f0(); _cost_f0(); _cost_f0(); _cost_f0(); _cost_f0(); _cost_f0(); _cost_f0(); _cost_f0(); _cost_f0()  # noqa: E501, E702
        return td(tc(), t0)

    def call3():
        t0 = tc()
        _cost_f3(x, x, x); _cost_f3(x, x, x); _cost_f3(x, x, x); _cost_f3(x, x, x); _cost_f3(x, x, x); _cost_f3(x, x, x); _cost_f3(x, x, x); _cost_f3(x, x, x); _cost_f3(x, x, x); _cost_f3(x, x, x)  # noqa: E501, E702
        return td(tc(), t0)

    for label, run in (("local variable", local), ("global variable", glob), ("attribute (cached)", attr),
                       ("attribute store", store), ("array item", subscr), ("add", add), ("multiply", mul),
                       ("function call, no argument", call0), ("function call, 3 arguments", call3)):
        out.append((label, best(run) - e))
    for name, o in (("FlightComputer", fc), ("Detector", fc.det), ("Kalman", fc.kf),
                    ("SensorHealth", fc.health), ("PadCalibration", fc.pad), ("Arbitration", fc.arb),
                    ("VelocityRule", fc.det.rule)):
        cls = type(o)
        cls.zz_cost_noop = _CostProbe.noop

        def meth(o=o):
            t0 = tc()
            o.zz_cost_noop(); o.zz_cost_noop(); o.zz_cost_noop(); o.zz_cost_noop(); o.zz_cost_noop(); o.zz_cost_noop(); o.zz_cost_noop(); o.zz_cost_noop(); o.zz_cost_noop(); o.zz_cost_noop()  # noqa: E501, E702
            return td(tc(), t0)

        out.append(("method call on %s (%d attributes)" % (name, len(o.__dict__)), best(meth) - e))
        del cls.zz_cost_noop
    return out


def dump_op_costs():
    """Print op_costs() as lines the host parses (``opcost TICKS LABEL``)."""
    for label, ticks in op_costs():
        print("opcost %d %s" % (ticks, label))


def _alt_loop(to_alt_mm, n, p_lo, p_span, ticks, states):
    tc = _ticks
    td = _diff
    for i in range(n):
        p = p_lo + p_span // n * i
        t0 = tc()
        h = to_alt_mm(p)
        t1 = tc()
        ticks[i] = td(t1, t0)
        states[i] = h


def count_altitude(n, lock=True):
    """shared.altitude.pressure_to_alt_mm over ``n`` pressures spread over its whole range."""
    from shared.altitude import P_MAX_Q4, P_MIN_Q4, pressure_to_alt_mm

    ticks = array("i", bytearray(4 * n))
    states = array("i", bytearray(4 * n))
    if lock:
        _lock()
    try:
        _alt_loop(pressure_to_alt_mm, n, P_MIN_Q4, P_MAX_Q4 - P_MIN_Q4, ticks, states)
    finally:
        if lock:
            _unlock()
    return ticks, array("b", bytearray(n)), states


def firmware_path(frames_path, workdir, samples, lock=True, replay=False):
    """``FlightLoop.sample()`` (sensor reads through the fake I2C bus and the drivers, pressure to
    altitude, the state machine, pyro, log record, status) and ``after_sample()`` on the fake
    machine (desktop/hosts/sil), as the board runs them. States per sample: pressure_q4_pa, accel_mmps2,
    alt_q4, vel_q4, state, baro_errors + accel_errors. With ``replay`` the sensor readings of
    that run are then replayed as integers (desktop/hosts/sil/replay_sensors.py: no bus, no
    driver) through a new loop, whose counts are returned: the firmware's own cost. Call once
    per interpreter: it installs the fake ``machine``, ``time`` and ``micropython`` modules."""
    from desktop.hosts.sil import fake_machine, fake_time

    fake_machine.install()
    fake_machine.install_world(frames_path)
    import os

    os.chdir(workdir)
    import device.flightloop as fl_mod
    from device import board as boardmod
    from device import flightlog
    from device.flightloop import FlightLoop

    fl_mod.collect = lambda: None  # no collection in the safe points: it would need the heap
    b = boardmod.load("board.json")
    hw = boardmod.Hardware(b)
    loop = FlightLoop(hw, load_config({}), flightlog.LogBuffer(b["log_ram_kb"] * 1024))
    period = 1000000 // b["sample_hz"]
    ticks = array("i", bytearray(4 * samples))
    phases = array("b", bytearray(samples))
    states = array("i", bytearray(24 * samples))
    pressures = array("i", bytearray(4 * samples))  # the readings, for the replay
    accels = array("i", bytearray(4 * samples))
    haves = array("i", bytearray(4 * samples))
    s = loop.sensors
    for i in range(samples):
        fake_time.advance(period)
        ticks[i] = _timed_sample(loop, period, lock)
        fc = loop.fc
        st = fc.state
        phases[i] = _phase(st)
        j = 6 * i
        states[j] = s.pressure_q4_pa
        states[j + 1] = s.accel_mmps2
        states[j + 2] = fc.kf.alt_q4
        states[j + 3] = fc.kf.vel_q4
        states[j + 4] = st
        states[j + 5] = s.baro_errors + s.accel_errors
        pressures[i] = s.pressure_q4_pa
        accels[i] = s.accel_mmps2
        haves[i] = s.have
    if replay:
        global FAKE_BUS_TICKS
        FAKE_BUS_TICKS = array("i", ticks)
        from desktop.hosts.sil.replay_sensors import ReplaySensors

        hw.sensors = ReplaySensors(pressures, accels, haves)
        loop = None  # its log buffer's block is the one the new loop's can take
        gc.collect()
        loop = FlightLoop(hw, load_config({}), flightlog.LogBuffer(b["log_ram_kb"] * 1024))
        for i in range(samples):
            ticks[i] = _timed_sample(loop, period, lock)
    return ticks, phases, states


def _timed_sample(loop, period, lock):
    """Ticks of one ``loop.sample(period)`` (heap locked with ``lock``); then its safe point."""
    tc = _ticks
    if lock:
        _lock()
    try:
        t0 = tc()
        loop.sample(period)
        t1 = tc()
    finally:
        if lock:
            _unlock()
    loop.after_sample()
    return _diff(t1, t0)


def dump(name, result):
    """Print one result as three lines the host parses (``name ticks|phases|states: ints``)."""
    ticks, phases, states = result
    for part, values in (("ticks", ticks), ("phases", phases), ("states", states)):
        print_ints("%s %s" % (name, part), values)


def print_ints(label, values):
    """Print ``label: v0 v1 ...`` on one line, in small pieces (the heap may be fragmented)."""
    print(label + ":", end="")
    for k in range(0, len(values), _DUMP_CHUNK):
        print(" " + " ".join([str(v) for v in values[k:k + _DUMP_CHUNK]]), end="")
    print()
