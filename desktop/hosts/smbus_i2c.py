"""``machine.I2C`` methods over Linux ``/dev/i2c-N`` with smbus2, so the board drivers run on a Pi.

::

    from desktop.hosts.smbus_i2c import SMBusI2C
    from device.drivers.bmp3xx import BMP3XX
    with SMBusI2C(1) as i2c:                # /dev/i2c-1 (Raspberry Pi header pins 3/5)
        baro = BMP3XX(i2c)
        baro.read()

Every transfer is one ``SMBus.i2c_rdwr`` (Linux I2C_RDWR ioctl), not the SMBus block calls,
which stop at 32 bytes: a register read is a write of the register address followed, after a
repeated start, by a read of ``len(buf)`` bytes, exactly what ``machine.I2C.readfrom_mem_into``
does on a board. Errors are the kernel's ``OSError``: a NACKed address is usually ``EREMOTEIO``
(121) or ``ENXIO`` (6) rather than the ``ENODEV`` (19) / ``EIO`` (5) of MicroPython ports, so
callers should catch ``OSError`` as a whole. Only 7-bit addresses and 8-bit register addresses
(``addrsize=8``) are supported. Bus speed is set by the kernel (``dtparam=i2c_arm_baudrate``).
"""

import smbus2


def _bytes_view(buf):
    """Writable byte view of any buffer (bytearray, memoryview, array), as machine.I2C sees it."""
    return memoryview(buf).cast("B")


class SMBusI2C:
    """A ``machine.I2C`` look-alike on Linux bus ``bus_number`` (``/dev/i2c-<bus_number>``)."""

    def __init__(self, bus_number=1):
        self.bus_number = bus_number
        self._bus = smbus2.SMBus(bus_number)

    # -- context manager -----------------------------------------------------------------------

    def close(self):
        if self._bus is not None:
            self._bus.close()
            self._bus = None

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()

    # -- machine.I2C API -----------------------------------------------------------------------

    @staticmethod
    def _check_addrsize(addrsize):
        if addrsize != 8:
            raise ValueError("SMBusI2C supports 8-bit register addresses only (addrsize=8)")

    def readfrom_mem_into(self, addr, memaddr, buf, addrsize=8):
        """Write ``memaddr``, repeated start, read ``len(buf)`` bytes into ``buf``."""
        self._check_addrsize(addrsize)
        view = _bytes_view(buf)
        wr = smbus2.i2c_msg.write(addr, [memaddr & 0xFF])
        rd = smbus2.i2c_msg.read(addr, view.nbytes)
        self._bus.i2c_rdwr(wr, rd)
        view[:] = bytes(rd)

    def readfrom_mem(self, addr, memaddr, nbytes, addrsize=8):
        buf = bytearray(nbytes)
        self.readfrom_mem_into(addr, memaddr, buf, addrsize)
        return bytes(buf)

    def writeto_mem(self, addr, memaddr, buf, addrsize=8):
        """Write ``memaddr`` followed by ``buf`` in one message."""
        self._check_addrsize(addrsize)
        self._bus.i2c_rdwr(smbus2.i2c_msg.write(addr, bytes([memaddr & 0xFF]) + bytes(buf)))

    def writeto(self, addr, buf, stop=True):
        """Write ``buf``; returns the number of bytes acknowledged (all, or an OSError)."""
        data = bytes(buf)
        self._bus.i2c_rdwr(smbus2.i2c_msg.write(addr, data))
        return len(data)

    def readfrom_into(self, addr, buf, stop=True):
        view = _bytes_view(buf)
        rd = smbus2.i2c_msg.read(addr, view.nbytes)
        self._bus.i2c_rdwr(rd)
        view[:] = bytes(rd)

    def readfrom(self, addr, nbytes, stop=True):
        buf = bytearray(nbytes)
        self.readfrom_into(addr, buf)
        return bytes(buf)

    def scan(self):
        """Addresses 0x08..0x77 that acknowledge a one-byte read (like ``machine.I2C.scan``)."""
        found = []
        for addr in range(0x08, 0x78):
            try:
                self._bus.i2c_rdwr(smbus2.i2c_msg.read(addr, 1))
            except OSError:
                continue
            found.append(addr)
        return found
