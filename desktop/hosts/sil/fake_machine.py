"""A fake ``machine`` module for software-in-the-loop runs (MicroPython unix port and CPython).

- ``Pin``: output levels in ``LEVELS``; every level change of an output is recorded with the
  simulated time (``EV_T``/``EV_PIN``/``EV_LEVEL``, ``EV_N`` entries; preallocated, so recording
  allocates nothing inside a heap-locked sample). Inputs read ``INPUTS`` (pulls give the idle
  level); ``schedule_input(pin, level, at_us)`` changes an input at a simulated time.
- ``I2C``/``SoftI2C``: wrap the ``desktop.sim.fakes.FakeI2CBus`` registered in ``BUSES[id]``; each
  transaction advances the clock by its bus time (9 bits per byte at ``freq``) and lets ``WORLD``
  (``desktop/hosts/sil/world.py``) publish the sensor data of the current simulated time first.
- ``Timer``: one-shot and periodic timers on the simulated clock (callbacks run from the clock).
- ``WDT``: a watchdog on the simulated clock; starving it raises ``WatchdogReset`` (a simulated
  reset: the harness "reboots" with ``reset_cause() == WDT_RESET`` and the RTC memory kept).
- ``RTC().memory()``: kept across simulated resets. ``ADC``, ``PWM``, ``reset_cause``,
  ``reset``, ``unique_id``, ``freq``, ``idle``, ``disable_irq``/``enable_irq``.

``install()`` puts this module, ``fake_time`` and ``fake_micropython`` into ``sys.modules`` as
``machine``, ``time`` and ``micropython``: call it before importing any firmware module.
"""

import sys
from array import array

from desktop.hosts.sil import fake_micropython, fake_time
from desktop.sim.fakes.i2c_bus import AllocatingReads

PWRON_RESET = 1
HARD_RESET = 2
WDT_RESET = 3
DEEPSLEEP_RESET = 4
SOFT_RESET = 5

NPINS = 64
LEVELS = bytearray(NPINS)  # output levels
INPUTS = bytearray(NPINS)  # input levels (set by pulls, tests and schedules)
MODES = bytearray(NPINS)  # 0 unused/input, 1 output
DRIVEN = bytearray(NPINS)  # 1: the test drives this input (a pull does not change its level)
ADC_VALUES = array("H", bytearray(2 * NPINS))
_CAP = 4096
EV_T = array("q", bytearray(8 * _CAP))
EV_PIN = bytearray(_CAP)
EV_LEVEL = bytearray(_CAP)
EV_N = [0]
BUSES = {}
WORLD = [None]
_state = {"reset_cause": PWRON_RESET, "rtc": b"", "wdt_timeout": 0, "wdt_fed": 0, "resets": 0}
_timers = []
_inputs = []  # (at_us, pin, level), sorted by time
_next_input = [0]


class WatchdogReset(BaseException):
    """The simulated watchdog bit."""


class HardReset(BaseException):
    """machine.reset() was called."""


WDT_BITE = WatchdogReset("watchdog reset")
try:  # warm up (a first raise allocates)
    raise WDT_BITE
except WatchdogReset:
    pass


def _record(pin, level):
    n = EV_N[0]
    if n < _CAP:
        EV_T[n] = fake_time.elapsed
        EV_PIN[n] = pin
        EV_LEVEL[n] = level
        EV_N[0] = n + 1


def pin_events(pin=None):
    """[(time_us, pin, level)] of every output change (allocates; after the run)."""
    out = []
    for i in range(EV_N[0]):
        if pin is None or EV_PIN[i] == pin:
            out.append((EV_T[i], EV_PIN[i], EV_LEVEL[i]))
    return out


def schedule_input(pin, level, at_us):
    _inputs.append((at_us, pin, level))
    _inputs.sort()


def set_input(pin, level):
    INPUTS[pin] = level
    DRIVEN[pin] = 1


def _tick(now):
    """Called by the fake clock on every advance: inputs, timers, watchdog."""
    i = _next_input[0]
    while i < len(_inputs) and _inputs[i][0] <= now:
        INPUTS[_inputs[i][1]] = _inputs[i][2]
        DRIVEN[_inputs[i][1]] = 1
        i += 1
    _next_input[0] = i
    for t in _timers:
        while t._due >= 0 and now >= t._due:
            due = t._due
            if t._period > 0 and t._mode == Timer.PERIODIC:
                t._due += t._period
            else:
                t._due = -1
            t.fired += 1
            if t._cb is not None:
                fake_time.elapsed = due  # the callback runs at its due time (within a long advance)
                t._cb(t)
                fake_time.elapsed = now
    timeout = _state["wdt_timeout"]
    if timeout and now - _state["wdt_fed"] > timeout * 1000:
        _state["wdt_timeout"] = 0
        raise WDT_BITE


def reset_state(reset_cause=PWRON_RESET, keep_rtc=True):
    """Power-on (or reset) state: outputs released (low: the pull-downs), timers and watchdog off."""
    for i in range(NPINS):
        if MODES[i] and LEVELS[i]:
            LEVELS[i] = 0
            _record(i, 0)
        MODES[i] = 0
    del _timers[:]
    _state["reset_cause"] = reset_cause
    _state["wdt_timeout"] = 0
    if not keep_rtc:
        _state["rtc"] = b""
        _MEM32.clear()


_MEM32 = {}  # address -> 32-bit word; kept across simulated resets like the RP2040's watchdog scratch


class _Mem:
    """``machine.mem32``: a word store (the scratch registers the resume record uses)."""

    def __getitem__(self, addr):
        return _MEM32.get(addr, 0)

    def __setitem__(self, addr, value):
        _MEM32[addr] = value & 0xFFFFFFFF


mem32 = _Mem()


def install(origin_us=0):
    fake_time.reset(origin_us)
    fake_time.hook = _tick
    fake_micropython._clock[0] = lambda: fake_time.elapsed
    sys.modules["machine"] = sys.modules[__name__]
    sys.modules["time"] = fake_time
    sys.modules["utime"] = fake_time
    sys.modules["micropython"] = fake_micropython


def install_world(frames_path):
    """Bus 0 with a BMP390 at 0x77 and an ADXL375 at 0x53, fed by the frames file; returns the
    World (desktop/hosts/sil/world.py). Call after ``install()``."""
    from desktop.hosts.sil.world import World
    from desktop.sim.fakes import FakeADXL375, FakeBMP390, FakeI2CBus

    bus = FakeI2CBus()
    world = World(frames_path, bus.add(0x77, FakeBMP390()), bus.add(0x53, FakeADXL375()))
    BUSES[0] = bus
    WORLD[0] = world
    return world


class Pin:
    IN = 0
    OUT = 1
    OPEN_DRAIN = 2
    ALT = 3
    PULL_UP = 1
    PULL_DOWN = 2
    IRQ_RISING = 1
    IRQ_FALLING = 2

    def __init__(self, id, mode=-1, pull=-1, value=None, **kw):
        self.id = id
        self.init(mode, pull, value)

    def init(self, mode=-1, pull=-1, value=None, **kw):
        i = self.id
        if pull == Pin.PULL_UP and not DRIVEN[i]:
            INPUTS[i] = 1
        elif pull == Pin.PULL_DOWN and not DRIVEN[i]:
            INPUTS[i] = 0
        if mode == Pin.OUT or mode == Pin.OPEN_DRAIN:
            if value is not None:
                self.value(value)
            MODES[i] = 1
        elif mode == Pin.IN:
            MODES[i] = 0

    def value(self, v=None):
        i = self.id
        if v is None:
            return LEVELS[i] if MODES[i] else INPUTS[i]
        v = 1 if v else 0
        if LEVELS[i] != v:
            LEVELS[i] = v
            _record(i, v)
        return None

    def __call__(self, v=None):
        return self.value(v)

    def on(self):
        self.value(1)

    def off(self):
        self.value(0)

    def high(self):
        self.value(1)

    def low(self):
        self.value(0)

    def irq(self, *args, **kw):
        return None


class Signal:
    def __init__(self, pin, invert=False):
        self.pin = pin
        self.invert = invert

    def value(self, v=None):
        if v is None:
            return self.pin.value() ^ self.invert
        self.pin.value((1 if v else 0) ^ self.invert)


class ADC:
    def __init__(self, pin, **kw):
        self.id = pin.id if isinstance(pin, Pin) else pin

    def read_u16(self):
        return ADC_VALUES[self.id]


class PWM:
    def __init__(self, pin, freq=1000, duty_u16=0, **kw):
        self.pin = pin
        self._freq = freq
        self._duty = duty_u16
        pin.init(Pin.OUT, value=0)

    def duty_u16(self, v=None):
        if v is None:
            return self._duty
        self._duty = v
        self.pin.value(1 if v else 0)

    def freq(self, f=None):
        if f is None:
            return self._freq
        self._freq = f

    def deinit(self):
        self.pin.value(0)


class I2C(AllocatingReads):
    def __init__(self, id=0, scl=None, sda=None, freq=400000, timeout=50000):
        if id not in BUSES:
            raise OSError(19)
        self.bus = BUSES[id]
        self.freq = freq
        self.bit_us_x1000 = 1000000000 // freq  # ns per bit

    def _cost(self, nbytes):
        world = WORLD[0]
        fake_time.advance((nbytes * 9 * self.bit_us_x1000) // 1000)
        if world is not None:
            world.sync(fake_time.elapsed)

    def readfrom_mem_into(self, addr, memaddr, buf, addrsize=8):
        self._cost(3 + len(buf))
        self.bus.readfrom_mem_into(addr, memaddr, buf)

    def writeto_mem(self, addr, memaddr, buf, addrsize=8):
        self._cost(2 + len(buf))
        self.bus.writeto_mem(addr, memaddr, buf)

    def writeto(self, addr, buf, stop=True):
        self._cost(1 + len(buf))
        return self.bus.writeto(addr, buf)

    def readfrom_into(self, addr, buf, stop=True):
        self._cost(1 + len(buf))
        self.bus.readfrom_into(addr, buf)

    def scan(self):
        return self.bus.scan()


class SoftI2C(I2C):
    def __init__(self, scl=None, sda=None, freq=400000, timeout=50000):
        I2C.__init__(self, -1 if -1 in BUSES else 0, scl, sda, freq)


class Timer:
    ONE_SHOT = 0
    PERIODIC = 1

    def __init__(self, id=-1, **kw):
        self.id = id
        self._due = -1
        self._period = 0
        self._mode = 0
        self._cb = None
        self.fired = 0
        _timers.append(self)
        if kw:
            self.init(**kw)

    def init(self, mode=PERIODIC, period=-1, freq=-1, callback=None, hard=True):
        if freq > 0:
            period = 1000 // freq
        self._mode = mode
        self._period = period * 1000
        self._cb = callback
        self._due = fake_time.elapsed + self._period

    def deinit(self):
        self._due = -1


class WDT:
    def __init__(self, id=0, timeout=5000):
        _state["wdt_timeout"] = timeout
        _state["wdt_fed"] = fake_time.elapsed

    def feed(self):
        _state["wdt_fed"] = fake_time.elapsed


RTC_MEMORY = [True]  # False: a port without RTC memory (the RP2040): RTC().memory is missing


class RTC:
    def __init__(self, id=0):
        pass

    def __getattr__(self, name):
        if name == "memory" and RTC_MEMORY[0]:
            return self._memory
        raise AttributeError(name)

    def _memory(self, data=None):
        if data is None:
            return _state["rtc"]
        _state["rtc"] = bytes(data)

    def datetime(self, dt=None):
        return (2026, 1, 1, 3, 0, 0, 0, 0)


def reset_cause():
    return _state["reset_cause"]


_HARD = HardReset("machine.reset()")


def reset():
    raise _HARD


def soft_reset():
    raise _HARD


def unique_id():
    return b"\x00SIL\x00\x01"


def freq(f=None):
    return 125000000


def idle():
    pass


def disable_irq():
    return 0


def enable_irq(state=0):
    pass


def lightsleep(ms=0):
    fake_time.sleep_ms(ms)


def deepsleep(ms=0):
    raise _HARD
