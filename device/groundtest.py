"""Ground test: pulse one pyro channel on the ground, disarmed, with two confirmations.

Over mpremote (the board is idle: mpremote interrupts main.py and soft-resets first)::

    mpremote exec "from device.groundtest import info; info()"
    mpremote exec "from device.groundtest import fire; fire('drogue', 50, confirm='drogue')"
    # a backup channel the board has (pyro.backup_drogue / pyro.backup_main in board.json):
    mpremote exec "from device.groundtest import fire; fire('backup_main', 50, confirm='backup_main')"
    # with an igniter connected (continuity input shows it) a second confirmation is required:
    mpremote exec "from device.groundtest import fire; fire('drogue', 50, confirm='drogue',
                   igniter='live igniter')"          # (one line)

Safety (DESIGN.md D2): refused unless the board is disarmed (arming input off) and idle (no
``armed.flag`` from an interrupted flight); the channel name must be typed again; a connected
igniter needs ``igniter='live igniter'``; the pulse is bounded by a hardware timer that drives the
output low (``Pyro.guard``; where the port has none, by the watchdog, and the board resets after
the test), not only by this code (Ctrl-C over mpremote stops code, a GPIO keeps its level); every
pyro output is driven low in a ``finally``.
"""

from time import sleep_ms, ticks_diff, ticks_ms

MAX_PULSE_MS = 2000
LIVE = "live igniter"


class Refused(Exception):
    """The ground test or bench flight was refused; the message says why (one line)."""


def bench_hardware(board_path="board.json"):
    """(board, Pyro, arming Pin or None) without starting the sensors."""
    import machine

    from device import board as boardmod
    from device.pyro import Pyro

    b = boardmod.load(board_path)
    pyro = Pyro(machine, b)
    arm = None
    if b["arm"] is not None:
        a = b["arm"]
        Pin = machine.Pin
        pull = Pin.PULL_UP if a["pull"] == "up" else (Pin.PULL_DOWN if a["pull"] == "down" else None)
        arm = Pin(a["pin"], Pin.IN, pull) if pull is not None else Pin(a["pin"], Pin.IN)
    return b, pyro, arm


def refuse_unless_idle(b, arm):
    """Raise Refused unless the board is disarmed and idle."""
    from device.resume import ResumeStore

    if arm is not None and arm.value() == b["arm"]["active"]:
        raise Refused("the arming input is on: disarm the board first")
    try:
        from device import app

        cur = app.CURRENT
        if cur is not None and cur.last_loop is not None and not cur.last_loop.done:
            raise Refused("the flight loop is running")
    except ImportError:
        pass
    import machine

    if ResumeStore(machine).armed_flag() is not None:
        raise Refused("armed.flag is present (the board was reset while armed): cycle the arming input, "
                      "or delete armed.flag if you know it is on the ground")


def info(board_path="board.json"):
    """Print the board, the arming input, continuity and one sensor reading."""
    from device import board as boardmod

    b, pyro, arm = bench_hardware(board_path)
    pyro.all_low()
    print("board %s (%s), sample rate %d Hz" % (b["board"], b["mcu"], b["sample_hz"]))
    print("arming input: %s" % ("none (command arming)" if arm is None else (
        "ON" if arm.value() == b["arm"]["active"] else "off")))
    for name in boardmod.channels(b):
        c = pyro.continuity(boardmod.CHANNELS.index(name))
        print("%s: pin %d, continuity %s" % (name, b["pyro"][name]["pin"],
                                             {1: "connected", 0: "open", -1: "not sensed"}[c]))
    try:
        hw = boardmod.Hardware(b)
        for code, text in hw.errors:
            print("error %d: %s" % (code, text))
        s = hw.sensors
        for _ in range(3):
            s.read()
            sleep_ms(30)
        if hw.baro is not None:
            print("baro %s: %.2f Pa, %.2f C" % (b["baro"]["part"], s.pressure_q4_pa / 16, s.temp_cdeg / 100))
        if hw.accel is not None:
            v = hw.accel.accel_mmps2
            print("accel %s: axis %s %.2f m/s^2 (x %d, y %d, z %d mm/s^2)" % (
                b["accel"]["part"], b["accel"]["axis"], s.accel_mmps2 / 1000, v[0], v[1], v[2]))
        hw.pyro.all_low()
    finally:
        pyro.all_low()


def fire(channel, ms=50, confirm=None, igniter=None, board_path="board.json"):
    """Pulse ``channel`` ('drogue', 'main', or a backup channel the board has: 'backup_drogue',
    'backup_main') for ``ms`` milliseconds. Returns the measured ms."""
    import machine

    from device.board import CHANNELS, channels

    if channel not in CHANNELS:
        raise Refused("channel must be one of %s" % ", ".join(["'%s'" % c for c in CHANNELS]))
    if confirm != channel:
        raise Refused("confirm: type the channel name again, confirm=%r" % channel)
    if not isinstance(ms, int) or not 1 <= ms <= MAX_PULSE_MS:
        raise Refused("ms must be an integer from 1 to %d" % MAX_PULSE_MS)
    b, pyro, arm = bench_hardware(board_path)
    if channel not in channels(b):
        raise Refused("the board has no %s channel (board.json pyro.%s)" % (channel, channel))
    index = CHANNELS.index(channel)
    wdt = None
    try:
        refuse_unless_idle(b, arm)
        if pyro.continuity(index) == 1 and igniter != LIVE:
            raise Refused("continuity shows an igniter connected on %s: if you mean to fire it, add "
                          "igniter=%r" % (channel, LIVE))
        if not pyro.guard(index, ms):
            # no timer on this port: the watchdog bounds the pulse, and resets the board afterwards
            wdt = machine.WDT(timeout=max(ms + 200, 500))
        print("ground test: %s (pin %d) on for %d ms" % (channel, b["pyro"][channel]["pin"], ms))
        pin = pyro.pins[index]
        t0 = ticks_ms()
        pin.value(1)
        while ticks_diff(ticks_ms(), t0) < ms:
            sleep_ms(1)
        pin.value(0)
        took = ticks_diff(ticks_ms(), t0)
    finally:
        pyro.all_low()
        pyro.release_guards()
    print("ground test: %s off after %d ms" % (channel, took))
    if wdt is not None:
        print("ground test: the watchdog bounded the pulse; resetting the board")
        machine.reset()
    return took
