"""Bench flight: a stored flight through the real FlightComputer on the board, toggling the real
outputs at the detection times.

    python tools/deploy.py bench FLIGHT.csv      # converts, copies :bench.bin, runs it, compares
    mpremote run device/benchflight.py           # replays the :bench.bin already on the board

``bench.bin`` (written by ``tools/deploy.py bench`` from a flight CSV): BENCH_MAGIC, u32 record
count, u32 header length, header JSON (``config``: the flight configuration the desktop replay
used, ``source``), then BENCH_REC records: ``dt_us``, ``alt_mm``, ``accel_mmps2``, ``have``:
exactly what ``desktop.review.replay`` gives ``FlightComputer.step()``, so the board must print the
same events at the same samples.

The sensors are replaced by the file; everything downstream is the flight code: the state machine,
``Pyro.drive`` on the real pyro pins (put LEDs or test lamps on the outputs, not igniters), the
hardware pulse guard, the status LED. Same refusals as the ground test (disarmed, idle; an
igniter shown connected needs ``igniter='live igniter'``), every output low in a ``finally``.
Records are streamed from the file (the flight need not fit in RAM); ``speed`` 1.0 replays in
real time, 0 as fast as possible.
"""

import struct

BENCH_MAGIC = b"AFCBNCH1"
BENCH_REC = "<IiiI"
BENCH_REC_SIZE = 16
_CHUNK = 64


def write_bench(path, dt_us, alt_mm, accel_mmps2, have, config_values, source=""):
    """Write a bench file (CPython, tools/deploy.py)."""
    import json

    head = json.dumps({"config": config_values, "source": source}).encode()
    with open(path, "wb") as f:
        f.write(BENCH_MAGIC + struct.pack("<II", len(dt_us), len(head)) + head)
        buf = bytearray(BENCH_REC_SIZE)
        for i in range(len(dt_us)):
            struct.pack_into(BENCH_REC, buf, 0, int(dt_us[i]), int(alt_mm[i]), int(accel_mmps2[i]),
                             int(have[i]))
            f.write(buf)


def main(path="bench.bin", speed=1.0, igniter=None, board_path="board.json", verbose=True):
    """Replay ``path`` through the flight code. Returns a list of (sample, event name, time_s, agl_m)."""
    import json
    from time import sleep_us, ticks_add, ticks_diff, ticks_us

    from device.board import CHANNELS, channels
    from device.groundtest import LIVE, Refused, bench_hardware, refuse_unless_idle
    from shared.config import load_config
    from shared.flight import (
        EV_BACKUP_DROGUE,
        EV_BACKUP_MAIN,
        EV_DROGUE,
        EV_MAIN,
        EVENT_NAMES,
        STATE_NAMES,
        FlightComputer,
    )

    b, pyro, arm = bench_hardware(board_path)
    events = []
    f = None
    try:
        refuse_unless_idle(b, arm)
        for name in channels(b):
            if pyro.continuity(CHANNELS.index(name)) == 1 and igniter != LIVE:
                raise Refused("continuity shows an igniter connected on %s: use LEDs for a bench flight, "
                              "or add igniter=%r" % (name, LIVE))
        f = open(path, "rb")
        head = f.read(16)
        if head[:8] != BENCH_MAGIC:
            raise Refused("%s is not a bench file (make one with tools/deploy.py bench FLIGHT.csv)" % path)
        n, hlen = struct.unpack("<II", head[8:16])
        meta = json.loads(f.read(hlen))
        config = load_config(meta.get("config", {}))
        fc = FlightComputer(config)
        buf = bytearray(_CHUNK * BENCH_REC_SIZE)
        if verbose:
            print("bench flight: %d samples from %s" % (n, meta.get("source", path)))
        t_us = 0
        deadline = ticks_us()
        i = 0
        fires = ((EV_DROGUE, 0), (EV_MAIN, 1), (EV_BACKUP_DROGUE, 2), (EV_BACKUP_MAIN, 3))  # Pyro indices
        while i < n:
            got = f.readinto(buf)
            k = got // BENCH_REC_SIZE
            if k == 0:
                break
            for j in range(k):
                dt, alt, acc, have = struct.unpack_from(BENCH_REC, buf, j * BENCH_REC_SIZE)
                if i:
                    t_us += dt
                    if speed:
                        deadline = ticks_add(deadline, int(dt / speed))
                        while True:
                            d = ticks_diff(deadline, ticks_us())
                            if d <= 0:
                                break
                            sleep_us(d)
                fc.step(dt, alt, acc, have)
                pyro.drive(fc.pyro_drogue, fc.pyro_main, fc.pyro_backup_drogue, fc.pyro_backup_main)
                if fc.events:
                    for event, index in fires:
                        if fc.events & event:
                            pyro.guard(index, config.pulse_ms + 100)
                    for bit in range(len(EVENT_NAMES)):
                        if fc.events & (1 << bit):
                            events.append((i, EVENT_NAMES[bit], t_us / 1e6, fc.agl_mm / 1000))
                            if verbose:
                                print("EVENT %s sample %d t %.3f s agl %.1f m" % (
                                    EVENT_NAMES[bit], i, t_us / 1e6, fc.agl_mm / 1000))
                i += 1
        if verbose:
            print("bench flight: done, %d samples, final state %s, max altitude %.1f m" % (
                i, STATE_NAMES[fc.state], fc.max_agl_mm / 1000))
    finally:
        pyro.all_low()
        pyro.release_guards()
        if f is not None:
            f.close()
    return events


if __name__ == "__main__":
    main()
