"""Per-sample time and allocation of the flight loop on MicroPython (guest side).

``measure(opts)`` builds the board's hardware on the fake machine and the sensor fakes fed by a
simulated flight, then runs the loop body sample by sample (the fake clock advanced by one period
before each, so the world publishes new data) and measures with the real clock and
``gc.mem_alloc()`` (collector disabled):

- ``sample()``, the step: sensor reads through the fake I2C bus and the drivers, pressure to
  altitude, ``FlightComputer.step`` (two on the pad: the shadow), pyro outputs, log record, status;
- ``sample()`` again with the sensors replaced by replayed integers (no bus, no driver): the
  firmware's own cost;
- ``after_sample()``, the safe point (pad epochs, GC calls excluded by a stub, log flushes).

It then re-runs ``sample()`` with the heap locked (any allocation raises MemoryError).
"""

import gc
import sys

from desktop.hosts.sil import fake_machine, fake_time
from desktop.hosts.sil.replay_sensors import ReplaySensors

_WASI = getattr(sys.implementation, "_build", "") == "wasi"


def measure(opts):
    fake_machine.install()
    from array import array

    import micropython

    fake_machine.install_world(opts["frames"])
    import os

    os.chdir(opts["workdir"])
    import device.flightloop as fl_mod
    from device import board as boardmod
    from device import flightlog
    from device.flightloop import FlightLoop
    from shared.config import load_config

    fl_mod.collect = lambda: None  # no GC inside the measured safe points (and none on wasm32)
    b = boardmod.load("board.json")
    cfg = load_config({})
    hw = boardmod.Hardware(b)
    n = opts["samples"]
    period = 1000000 // b["sample_hz"]
    # pass 1: real sensors through the fake bus
    log = flightlog.LogBuffer(b["log_ram_kb"] * 1024)
    loop = FlightLoop(hw, cfg, log)
    pressures = array("i", bytearray(4 * n))
    accels = array("i", bytearray(4 * n))
    haves = array("i", bytearray(4 * n))
    t_sample = t_after = 0
    worst_sample = worst_after = 0
    a_sample = a_after = 0
    gc.collect() if not _WASI else None
    gc.disable()
    rt = fake_time.real_ticks_us
    rd = fake_time.real_ticks_diff
    # gc.mem_alloc() walks the whole heap (slow on the wasm build's 32 MB): per-sample figures on
    # request, otherwise the heap-locked pass below is the proof
    mem = gc.mem_alloc if opts.get("alloc", True) else (lambda: 0)
    for i in range(n):
        fake_time.advance(period)
        m0 = mem()
        t0 = rt()
        loop.sample(period)
        t1 = rt()
        m1 = mem()  # kept out of both timed windows
        t1b = rt()
        loop.after_sample()
        t2 = rt()
        m2 = mem()
        s = loop.sensors
        pressures[i] = s.pressure_q4_pa
        accels[i] = s.accel_mmps2
        haves[i] = s.have
        d1 = rd(t1, t0)
        d2 = rd(t2, t1b)
        t_sample += d1
        t_after += d2
        if d1 > worst_sample:
            worst_sample = d1
        if d2 > worst_after:
            worst_after = d2
        a_sample += m1 - m0
        a_after += m2 - m1
        if i % 200 == 199 and not _WASI:
            gc.enable()
            gc.collect()
            gc.disable()
    gc.enable()
    states = loop.fc.state
    # pass 2: the firmware's own cost, sensors replayed from pass 1
    hw.sensors = ReplaySensors(pressures, accels, haves)
    log2 = flightlog.LogBuffer(b["log_ram_kb"] * 1024)
    loop2 = FlightLoop(hw, cfg, log2)
    t_own = worst_own = a_own = 0
    if not _WASI:
        gc.collect()
    gc.disable()
    for _i in range(n):
        m0 = mem()
        t0 = rt()
        loop2.sample(period)
        t1 = rt()
        a_own += mem() - m0
        loop2.after_sample()
        d = rd(t1, t0)
        t_own += d
        if d > worst_own:
            worst_own = d
    gc.enable()
    # pass 3: heap locked
    hw.sensors = ReplaySensors(pressures, accels, haves)
    loop3 = FlightLoop(hw, cfg, flightlog.LogBuffer(b["log_ram_kb"] * 1024))
    locked_ok = True
    for _i in range(n):
        micropython.heap_lock()
        try:
            loop3.sample(period)
        except MemoryError:
            locked_ok = False
        finally:
            micropython.heap_unlock()
        loop3.after_sample()
        if not locked_ok:
            break
    return {
        "interpreter": sys.implementation.name + ("/wasm32" if _WASI else "/unix"),
        "samples": n,
        "final_state": states,
        "same_decisions": loop2.fc.state == states and loop3.fc.state == states,
        "sample_us_mean": t_sample / n,
        "sample_us_worst": worst_sample,
        "alloc_measured": opts.get("alloc", True),
        "sample_alloc_bytes": a_sample,
        "own_us_mean": t_own / n,
        "own_us_worst": worst_own,
        "own_alloc_bytes": a_own,
        "safe_point_us_mean": t_after / n,
        "safe_point_us_worst": worst_after,
        "safe_point_alloc_bytes_per_sample": a_after / n,
        "heap_locked_ok": locked_ok,
    }


def main(opts):
    import json

    print("MEASURE " + json.dumps(measure(opts)))
