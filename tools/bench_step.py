"""Per-sample cost of the filter + apogee rule, and of the whole state machine step:
microseconds and bytes allocated per step.

Portable: runs on MicroPython (board or unix port) and CPython.

    micropython tools/bench_step.py          # from the repository root (MICROPYPATH=.)
    python tools/bench_step.py
    python tools/bench_step.py --all         # CPython: also run it on both MicroPython interpreters

On MicroPython the allocation figure is measured (gc.mem_alloc() before and after the loop with
the collector disabled) and the loop is then re-run with micropython.heap_lock() held, which
raises MemoryError at the first allocation.
"""

import gc
import sys
import time
from array import array

try:
    import micropython
except ImportError:
    micropython = None

if __name__ == "__main__" and sys.implementation.name != "micropython":
    sys.path.insert(0, __file__.rsplit("/", 2)[0] if "/" in __file__ else "..")

from shared import gains_table  # noqa: E402
from shared.apogee import SeedRule, VelocityRule  # noqa: E402
from shared.config import load_config  # noqa: E402
from shared.detector import HAVE_BOTH, Detector  # noqa: E402
from shared.flight import FlightComputer  # noqa: E402
from tools.synthetic_flight import make_flight  # noqa: E402

# The 32-bit wasm build's collector corrupts the heap when run from nested calls (seen here:
# a wild pointer after gc.collect() inside a function); its 1 MB heap is enough without it.
_CAN_COLLECT = getattr(sys.implementation, "_build", "") != "wasi"


def _collect():
    if _CAN_COLLECT:
        gc.collect()


def _ticks_us():
    if micropython is not None:
        return time.ticks_us()
    return time.perf_counter_ns() // 1000


def _elapsed_us(t0, t1):
    if micropython is not None:
        return time.ticks_diff(t1, t0)
    return t1 - t0


_REPEATS = 20  # best of: this machine's timing noise is large, the minimum is repeatable


def new_detector(table_name, rule_name):
    table = gains_table.SEED if table_name == "seed" else gains_table.PROJECT
    rule = SeedRule() if rule_name == "seed" else VelocityRule()
    return Detector(table, rule)


def run_loop(det, dts, alts, accs, enable_from, states):
    """Step ``det`` over samples 1..n-1; write (alt, vel, acc) per sample into ``states``
    (array('i') of 3n, or None). Returns the index of the first detection, or -1."""
    fired_at = -1
    n = len(dts)
    for i in range(1, n):
        if det.step(dts[i], alts[i], accs[i], HAVE_BOTH, i >= enable_from) and fired_at < 0:
            fired_at = i
        if states is not None:
            kf = det.kf
            j = 3 * i
            states[j] = kf.alt_q4
            states[j + 1] = kf.vel_q4
            states[j + 2] = kf.acc_q4
    return fired_at


def run_flight(table_name, rule_name, flight, enable_from, lock):
    """Run one flight; with ``lock`` the loop runs with the MicroPython heap locked.

    Returns (fired_at, states array)."""
    dts, alts, accs = flight[0], flight[1], flight[2]
    det = new_detector(table_name, rule_name)
    det.start(alts[0], accs[0])
    states = array("i", bytearray(4 * 3 * len(dts)))
    if lock and micropython is not None:
        micropython.heap_lock()
        try:
            fired_at = run_loop(det, dts, alts, accs, enable_from, states)
        finally:
            micropython.heap_unlock()
    else:
        fired_at = run_loop(det, dts, alts, accs, enable_from, states)
    return fired_at, states


def run_fc_loop(fc, dts, alts, accs, out):
    """Step the FlightComputer over every sample (accs are kinematic, as make_flight gives them:
    the specific force is acc + 1 g). ``out`` (array('i') of 6n, or None) receives per sample
    alt_q4, vel_q4, acc_q4, state, events, pyro bits (1 drogue, 2 main, 4 backup drogue, 8 backup
    main)."""
    n = len(dts)
    for i in range(n):
        fc.step(dts[i], alts[i], accs[i] + 9807, HAVE_BOTH)
        if out is not None:
            kf = fc.kf
            j = 6 * i
            out[j] = kf.alt_q4
            out[j + 1] = kf.vel_q4
            out[j + 2] = kf.acc_q4
            out[j + 3] = fc.state
            out[j + 4] = fc.events
            out[j + 5] = (fc.pyro_drogue + 2 * fc.pyro_main + 4 * fc.pyro_backup_drogue
                          + 8 * fc.pyro_backup_main)


def run_fc_flight(flight, lock, config_values=None):
    """The whole state machine over a synthetic flight; returns the array of run_fc_loop."""
    dts, alts, accs = flight[0], flight[1], flight[2]
    fc = FlightComputer(load_config(config_values))
    out = array("i", bytearray(4 * 6 * len(dts)))
    if lock and micropython is not None:
        micropython.heap_lock()
        try:
            run_fc_loop(fc, dts, alts, accs, out)
        finally:
            micropython.heap_unlock()
    else:
        run_fc_loop(fc, dts, alts, accs, out)
    return out


def measure_fc(rate_hz):
    """(us per sample, bytes per sample or None) of FlightComputer.step over a whole flight."""
    flight = make_flight(rate_hz=rate_hz)
    fc = FlightComputer(load_config())
    dts, alts, accs = flight[0], flight[1], flight[2]
    _collect()
    gc.disable()
    mem0 = gc.mem_alloc() if micropython is not None else 0
    t0 = _ticks_us()
    run_fc_loop(fc, dts, alts, accs, None)
    t1 = _ticks_us()
    mem1 = gc.mem_alloc() if micropython is not None else 0
    gc.enable()
    if micropython is not None:
        run_fc_flight(flight, True)
    per_bytes = (mem1 - mem0) / len(dts) if micropython is not None else None
    return _elapsed_us(t0, t1) / len(dts), per_bytes, len(dts)


def measure(table_name, rule_name, rate_hz):
    """(us per step, bytes allocated per step or None on CPython, steps, fired_at)."""
    flight = make_flight(rate_hz=rate_hz)
    dts, alts, accs = flight[0], flight[1], flight[2]
    enable_from = len(dts) // 4
    det = new_detector(table_name, rule_name)
    det.start(alts[0], accs[0])
    steps = len(dts) - 1
    _collect()
    gc.disable()
    mem0 = gc.mem_alloc() if micropython is not None else 0
    t0 = _ticks_us()
    fired_at = run_loop(det, dts, alts, accs, enable_from, None)
    t1 = _ticks_us()
    mem1 = gc.mem_alloc() if micropython is not None else 0
    gc.enable()
    per_step_bytes = (mem1 - mem0) / steps if micropython is not None else None
    if micropython is not None:  # prove it: any allocation raises MemoryError
        run_flight(table_name, rule_name, flight, enable_from, True)
    return _elapsed_us(t0, t1) / steps, per_step_bytes, steps, fired_at


def main():
    impl = sys.implementation.name
    print("implementation: %s, sys.maxsize %d" % (impl, sys.maxsize))
    for table_name, rule_name, rate in (("project", "velocity", 100), ("project", "seed", 100),
                                        ("seed", "seed", 20)):
        best = None
        for _ in range(_REPEATS):
            us, per_bytes, steps, fired = measure(table_name, rule_name, rate)
            best = us if best is None or us < best else best
        alloc = "n/a (CPython)" if per_bytes is None else "%.1f B/step (heap-locked run passed)" % per_bytes
        print("gains=%-7s rule=%-8s %3d Hz: %6.2f us/step (best of %d, %d steps), alloc %s"
              % (table_name, rule_name, rate, best, _REPEATS, steps, alloc))
    best = None
    for _ in range(_REPEATS):
        us, per_bytes, steps = measure_fc(100)
        best = us if best is None or us < best else best
    alloc = "n/a (CPython)" if per_bytes is None else "%.1f B/step (heap-locked run passed)" % per_bytes
    print("full FlightComputer.step (filter + rule + state machine) 100 Hz: %6.2f us/step (best of %d, "
          "%d steps), alloc %s" % (best, _REPEATS, steps, alloc))


if __name__ == "__main__":
    if "--all" in sys.argv and sys.implementation.name != "micropython":
        from desktop.hosts.micropython import INTERPRETERS, run_micropython

        main()
        for interp in INTERPRETERS:
            print(run_micropython("from tools.bench_step import main\nmain()", interp), end="")
    else:
        main()
