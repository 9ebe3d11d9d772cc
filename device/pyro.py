"""Pyro outputs (drogue, main, and the optional backup_drogue, backup_main): drive, continuity
sense, and a hardware bound on every pulse.

``Pyro(machine, board)`` drives every output low as it takes it (boot.py already did, in its
first lines). ``drive(drogue, main, backup_drogue, backup_main)`` sets the levels the state machine
asks for; it is called once per sample and allocates nothing; a backup channel the board does not
have is never driven (``has(index)`` is False). ``guard(index, ms)`` arms a one-shot hardware
timer that drives that output low after ``ms`` whatever the code is doing (a flight loop stuck in a driver, a
Ctrl-C over mpremote: a GPIO keeps its level when the code that set it stops). The timer callback
is built once in ``__init__`` (no allocation when it runs, so it is safe as a hard interrupt).

Continuity: ``continuity(index)`` is 1 (igniter connected), 0 (open) or -1 (no sense input on this
channel). A digital sense input reads ``active`` when current flows through the igniter; an ADC
sense input reads above ``threshold_u16``. See docs/WIRING.md for the circuits.
"""

DROGUE = 0
MAIN = 1
BACKUP_DROGUE = 2
BACKUP_MAIN = 3
NAMES = ("drogue", "main", "backup_drogue", "backup_main")  # the channels, by index


def _cutter(pin):
    def cut(_timer):
        pin.value(0)

    return cut


class Pyro:
    def __init__(self, machine, board):
        Pin = machine.Pin
        self.machine = machine
        pins = []
        present = []  # the board's channels, in NAMES order (the order of its timer ids)
        for name in NAMES:
            if name in board["pyro"]:
                pins.append(Pin(board["pyro"][name]["pin"], Pin.OUT, value=0))
                present.append(name)
            else:
                pins.append(None)
        self.pins = tuple(pins)
        self.drogue_pin = pins[0]
        self.main_pin = pins[1]
        self.backup_drogue_pin = pins[2]
        self.backup_main_pin = pins[3]
        self.all_low()
        self.level = [0, 0, 0, 0]
        self._cut = tuple([None if p is None else _cutter(p) for p in pins])
        ids = board.get("timers", [-1] * len(present))
        self._timer_ids = [ids[present.index(name)] if name in present else -1 for name in NAMES]
        self._timers = [None, None, None, None]
        self.guard_failures = 0
        senses = []
        for name in NAMES:
            s = board["pyro"][name]["sense"] if name in present else None
            if s is None:
                senses.append(None)
            elif s["kind"] == "adc":
                senses.append((machine.ADC(Pin(s["pin"])), 1, s["threshold_u16"]))
            else:
                senses.append((Pin(s["pin"], Pin.IN), 0, s["active"]))
        self._sense = tuple(senses)

    def all_low(self):
        for p in self.pins:
            if p is not None:
                p.value(0)

    def drive(self, drogue, main, backup_drogue=False, backup_main=False):
        """Set every output (called every sample; allocation-free). A backup level for a channel
        the board does not have is ignored (device/board.py check_with_config refuses a
        configuration that enables it)."""
        d = 1 if drogue else 0
        m = 1 if main else 0
        self.drogue_pin.value(d)
        self.main_pin.value(m)
        self.level[0] = d
        self.level[1] = m
        p = self.backup_drogue_pin
        if p is not None:
            d = 1 if backup_drogue else 0
            p.value(d)
            self.level[2] = d
        p = self.backup_main_pin
        if p is not None:
            m = 1 if backup_main else 0
            p.value(m)
            self.level[3] = m

    def has(self, index):
        """True when the board has pyro channel ``index`` (NAMES)."""
        return self.pins[index] is not None

    def has_sense(self, index):
        return self._sense[index] is not None

    def continuity(self, index):
        """1 igniter connected, 0 open, -1 no sense input."""
        s = self._sense[index]
        if s is None:
            return -1
        src, is_adc, ref = s
        if is_adc:
            return 1 if src.read_u16() >= ref else 0
        return 1 if src.value() == ref else 0

    def continuity_bits(self):
        """Bit 0 drogue connected, bit 1 main connected (channels without sense count as 0; the
        status beeps report the primaries, the app's pad check and ``info`` every channel)."""
        bits = 0
        for i in range(2):
            if self.continuity(i) == 1:
                bits |= 1 << i
        return bits

    def guard(self, index, ms):
        """Arm the hardware bound on output ``index``: it goes low ``ms`` from now. Returns True
        when a timer is running (False: no timer on this port; the watchdog is the bound)."""
        if self._cut[index] is None:
            return False  # no such channel on this board
        machine = self.machine
        t = self._timers[index]
        try:
            if t is None:
                t = machine.Timer(self._timer_ids[index])
                self._timers[index] = t
            else:
                t.deinit()
            try:
                t.init(mode=machine.Timer.ONE_SHOT, period=ms, callback=self._cut[index], hard=True)
            except (TypeError, ValueError):  # ports without hard timer callbacks
                t.init(mode=machine.Timer.ONE_SHOT, period=ms, callback=self._cut[index])
            return True
        except Exception:  # noqa: BLE001 - a missing timer must not stop a flight
            self.guard_failures += 1
            return False

    def release_guards(self):
        for t in self._timers:
            if t is not None:
                try:
                    t.deinit()
                except Exception:  # noqa: BLE001
                    pass
