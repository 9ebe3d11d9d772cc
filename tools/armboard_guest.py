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
