"""A fake ``machine.I2C`` bus holding register-level fake devices, with fault injection.

``FakeI2CBus`` implements the four ``machine.I2C`` methods the drivers use
(``readfrom_mem_into``, ``writeto_mem``, ``writeto``, ``readfrom_into``) plus the allocating
conveniences (``readfrom_mem``, ``readfrom``, ``scan``). Devices are found by 7-bit address:

- unknown address -> ``OSError(19, "ENODEV")`` (ENODEV: what SoftI2C and the esp32 port raise for an address
  NACK; the literal 19 is used, not ``errno.ENODEV``, whose value differs on WASI builds);
- ``bus.nack(addr, True)`` makes a present device NACK (``OSError(19)``, or another errno such as
  5 = EIO of the rp2 hardware I2C, or 110 = ETIMEDOUT);
- per device (``FakeI2CDevice``): ``stuck = True`` freezes the register file (every read returns
  what it returned when it stuck; command devices repeat their last ADC word), ``fail_after(n)``
  lets ``n`` more reads through and then the device is dead (``OSError(5)`` on every transaction),
  and a wrong chip id is a constructor argument of each part's fake (``chip_id=``).

This module, like the rest of ``desktop/fakes``, only uses what MicroPython also has, so the same
fakes run on the unix and wasm32 MicroPython interpreters; the bus read/write paths allocate
nothing, so a driver's ``read()`` can be measured under ``micropython.heap_lock()`` against them.
"""

ENODEV = 19
EIO = 5
_ERRNO_NAMES = {5: "EIO", 19: "ENODEV", 110: "ETIMEDOUT", 116: "ETIMEDOUT"}


def bus_error(errno):
    """``OSError(errno, name)``: ``.errno`` and ``.args[0]`` are the errno on CPython and MicroPython."""
    return OSError(errno, _ERRNO_NAMES.get(errno, "I2C error"))


class FakeI2CDevice:
    """Base of the register-level fakes: a 256-byte register file with auto-increment.

    Subclasses override ``_after_read(reg, n)`` / ``_write_reg(reg, value)`` for side effects,
    or ``read_into`` / ``command`` entirely for command-based parts (MS5611).
    """

    part = "device"

    def __init__(self):
        self.regs = bytearray(256)
        self._frozen = None
        self._stuck = False
        self._dead = False
        self._fail_left = -1
        self._ptr = 0
        self.reads = 0
        self.writes = 0

    # -- fault injection -----------------------------------------------------------------------

    @property
    def stuck(self):
        return self._stuck

    @stuck.setter
    def stuck(self, value):
        if value and not self._stuck:
            self._frozen = bytearray(self.regs)
            self._freeze()
        self._stuck = bool(value)

    def _freeze(self):
        """Hook: a command-based device saves its last output here."""

    def fail_after(self, n_reads):
        """Let ``n_reads`` more reads succeed; afterwards every transaction raises OSError(5)."""
        self._fail_left = n_reads

    @property
    def dead(self):
        return self._dead

    def revive(self):
        self._dead = False
        self._fail_left = -1

    def _check_alive(self, counts_as_read):
        if self._dead:
            raise bus_error(EIO)
        if counts_as_read and self._fail_left >= 0:
            if self._fail_left == 0:
                self._dead = True
                raise bus_error(EIO)
            self._fail_left -= 1

    # -- bus-facing API ------------------------------------------------------------------------

    def read_into(self, reg, buf):
        """A register read: set the pointer to ``reg`` and read ``len(buf)`` bytes."""
        self._check_alive(True)
        self.reads += 1
        src = self._frozen if self._stuck else self.regs
        n = len(buf)
        for i in range(n):
            buf[i] = src[(reg + i) & 0xFF]
        self._ptr = (reg + n) & 0xFF
        if not self._stuck:
            self._after_read(reg, n)

    def write(self, reg, data):
        """A register write of ``data`` starting at ``reg`` (auto-increment)."""
        self._check_alive(False)
        self.writes += 1
        for i in range(len(data)):
            self._write_reg((reg + i) & 0xFF, data[i])
        self._ptr = (reg + len(data)) & 0xFF

    def command(self, data):
        """``writeto``: the first byte sets the register pointer, the rest are written."""
        self._check_alive(False)
        if len(data) == 0:
            return
        if len(data) == 1:
            self._ptr = data[0]
            return
        self.write(data[0], bytes(data)[1:])

    def read_current(self, buf):
        """``readfrom_into``: read from the current register pointer."""
        self.read_into(self._ptr, buf)

    # -- hooks ---------------------------------------------------------------------------------

    def _after_read(self, reg, n):
        pass

    def _write_reg(self, reg, value):
        if not self._stuck:
            self.regs[reg] = value


class AllocatingReads:
    """machine.I2C's convenience reads that return new bytes, built on the ``*_into`` methods."""

    def readfrom_mem(self, addr, memaddr, nbytes, addrsize=8):
        buf = bytearray(nbytes)
        self.readfrom_mem_into(addr, memaddr, buf)
        return bytes(buf)

    def readfrom(self, addr, nbytes, stop=True):
        buf = bytearray(nbytes)
        self.readfrom_into(addr, buf)
        return bytes(buf)


class FakeI2CBus(AllocatingReads):
    """A ``machine.I2C`` stand-in: ``bus.add(addr, device)``, then hand ``bus`` to a driver."""

    def __init__(self):
        self.devices = {}
        self._nack = {}
        self.transactions = 0

    def add(self, addr, device):
        """Attach ``device`` at 7-bit ``addr``; returns the device."""
        if not 0x08 <= addr <= 0x77:
            raise ValueError("I2C address 0x%02x outside 0x08..0x77" % addr)
        self.devices[addr] = device
        return device

    def remove(self, addr):
        self.devices.pop(addr, None)

    def nack(self, addr, on=True, errno=ENODEV):
        """Make ``addr`` NACK (raise ``OSError(errno)``) until ``nack(addr, False)``."""
        if on:
            self._nack[addr] = errno
        else:
            self._nack.pop(addr, None)

    def _device(self, addr):
        self.transactions += 1
        err = self._nack.get(addr, 0)
        if err:
            raise bus_error(err)
        dev = self.devices.get(addr)
        if dev is None:
            raise bus_error(ENODEV)
        return dev

    # -- machine.I2C API -----------------------------------------------------------------------

    def readfrom_mem_into(self, addr, memaddr, buf, addrsize=8):
        self._device(addr).read_into(memaddr, buf)

    def writeto_mem(self, addr, memaddr, buf, addrsize=8):
        self._device(addr).write(memaddr, buf)

    def writeto(self, addr, buf, stop=True):
        self._device(addr).command(buf)
        return len(buf)

    def readfrom_into(self, addr, buf, stop=True):
        self._device(addr).read_current(buf)

    def scan(self):
        return sorted(a for a in self.devices if not self._nack.get(a, 0))


def gauss(rng, sigma):
    """One N(0, sigma) draw from a numpy Generator or a ``random.Random`` (0.0 if sigma is 0)."""
    if not sigma:
        return 0.0
    if hasattr(rng, "normal"):
        return float(rng.normal(0.0, sigma))
    return rng.gauss(0.0, sigma)


def default_rng(seed):
    """A seeded generator: numpy's on CPython, ``random.Random`` if numpy is missing."""
    try:
        import numpy

        return numpy.random.default_rng(seed)
    except ImportError:
        import random

        return random.Random(seed)
