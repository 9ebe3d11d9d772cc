"""A fake ``time`` module: a simulated clock with MicroPython's tick arithmetic.

``ticks_us``/``ticks_ms`` wrap at 2**30 as on a 32-bit board (``origin`` sets where the clock
starts, e.g. a few seconds before the wrap). The clock only moves when something advances it:
``sleep_us``/``sleep_ms``/``sleep`` and ``advance(us)`` (the fake I2C bus advances it by each
transaction's bus time). ``elapsed`` is the simulated time since the start in us (never wraps).
Each advance calls ``hook(elapsed)`` (the fake machine: timers, watchdog, scheduled inputs).
``set_end(us)`` makes the next sleep at or after that time raise ``SimulationEnd``.
"""

import time as _real

_PERIOD = 1 << 30
_MASK = _PERIOD - 1
_HALF = 1 << 29

elapsed = 0
origin = 0
end_us = 0
hook = None


class SimulationEnd(BaseException):
    """Raised from a sleep once the simulated time reaches ``end_us``."""


END = SimulationEnd("simulation end")
try:  # warm up: the first raise of an instance allocates; later ones do not (heap-locked paths)
    raise END
except SimulationEnd:
    pass


def reset(origin_us=0):
    global elapsed, origin, end_us
    elapsed = 0
    origin = origin_us & _MASK
    end_us = 0


def set_end(us):
    global end_us
    end_us = us


def advance(us):
    global elapsed
    if us > 0:
        elapsed += us
    if hook is not None:
        hook(elapsed)


def _check_end():
    if end_us and elapsed >= end_us:
        raise END


def ticks_us():
    return (origin + elapsed) & _MASK


def ticks_ms():
    return ((origin + elapsed) // 1000) & _MASK


def ticks_cpu():
    return ticks_us()


def ticks_diff(a, b):
    return ((a - b + _HALF) & _MASK) - _HALF


def ticks_add(a, delta):
    return (a + delta) & _MASK


def sleep_us(us):
    _check_end()
    advance(us)


def sleep_ms(ms):
    _check_end()
    advance(ms * 1000)


def sleep(s):
    _check_end()
    advance(int(s * 1000000))


def time():
    return 1700000000 + elapsed // 1000000


def time_ns():
    return (1700000000 * 1000000 + elapsed) * 1000


def localtime(secs=None):
    return _real.localtime(secs if secs is not None else time())


def real_ticks_us():
    """The real clock (measurements in the tests)."""
    if hasattr(_real, "ticks_us"):
        return _real.ticks_us()
    return _real.perf_counter_ns() // 1000


def real_ticks_diff(a, b):
    if hasattr(_real, "ticks_diff"):
        return _real.ticks_diff(a, b)
    return a - b
