"""A fake ``micropython`` module: the real one's heap functions, and ``kbd_intr`` recorded.

``KBD`` holds the current Ctrl-C character (3 = enabled, -1 = disabled) and ``KBD_HISTORY`` every
call with the simulated time."""

try:
    import micropython as _real
except ImportError:  # CPython
    _real = None

KBD = [3]
KBD_HISTORY = []
_clock = [None]


def const(x):
    return x


def kbd_intr(c):
    KBD[0] = c
    t = _clock[0]() if _clock[0] is not None else 0
    KBD_HISTORY.append((t, c))


def heap_lock():
    if _real is not None and hasattr(_real, "heap_lock"):
        return _real.heap_lock()
    return 0


def heap_unlock():
    if _real is not None and hasattr(_real, "heap_unlock"):
        return _real.heap_unlock()
    return 0


def mem_info(*args):
    if _real is not None:
        return _real.mem_info(*args)


def alloc_emergency_exception_buf(n):
    pass


def schedule(func, arg):
    func(arg)


def opt_level(*args):
    return 0


def native(f):
    return f


def viper(f):
    return f
