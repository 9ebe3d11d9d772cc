"""I2C sensor drivers for the flight computer (MicroPython first, CPython for desktop tests).

One module per part, in the style of micropython-lib's drivers:

- ``bmp3xx``: Bosch BMP388 / BMP390 barometer.
- ``ms5611``: TE MS5611-01BA03 barometer (two-phase start/collect API).
- ``bmp280``: Bosch BMP280 barometer.
- ``adxl375``: ADI ADXL375 (+-200 g) and ADXL345 (+-16 g) accelerometers.
- ``mpu6050``: InvenSense MPU-6050 accelerometer (+-16 g; the gyro is not read).
- ``lsm6dso``: ST LSM6DSO / LSM6DSO32 accelerometer (+-16 g / +-32 g; the gyro is not read).

Every driver takes a bus with the ``machine.I2C`` methods ``readfrom_mem_into``, ``writeto_mem``,
``writeto`` and ``readfrom_into`` (a ``machine.I2C``/``SoftI2C`` on a board,
``desktop.sim.fakes.FakeI2CBus`` in tests, ``desktop.hosts.smbus_i2c.SMBusI2C`` on a Raspberry Pi), checks the
part's identity in ``__init__`` and configures it for flight, and has a ``read()`` that stores the
result in attributes that already exist (no tuples, no floats, no new attributes):

- barometers: ``pressure_q4_pa`` (Pa x 16) and ``temp_cdeg`` (0.01 degC);
- accelerometers: ``accel_mmps2`` (``array('i')`` of specific force in mm/s^2), ``clipped``
  (bool, last read) and ``clip_count``.

Bus errors are not caught: an address NACK or a dead device raises the port's ``OSError``
(``ENODEV`` 19, ``EIO`` 5, ``ETIMEDOUT`` 110) out of ``read()``; the flight loop decides.

This module holds what the drivers share: the exceptions, the ``const`` and time shims for
CPython, ``mul_shr`` (the split multiplication that keeps integer compensation inside the 31-bit
small ints of a 32-bit board, see docs/SENSORS.md), ``I2CDevice`` (bus, address, one-byte register
access, identity check) and ``Accelerometer`` (the burst-to-mm/s^2 conversion of the three
accelerometer drivers). Copy the whole package to the board (``mpremote cp -r device/drivers :``):
the drivers import it relatively.
"""

from array import array

try:
    from micropython import const
except ImportError:  # CPython

    def const(x):
        return x


try:
    from time import sleep_ms, sleep_us, ticks_diff, ticks_us
except ImportError:  # CPython: same names, same modular tick arithmetic as a 32-bit port
    import time as _time

    _TICKS_PERIOD = 1 << 30
    _TICKS_HALF = 1 << 29

    def sleep_ms(ms):
        _time.sleep(ms / 1000)

    def sleep_us(us):
        _time.sleep(us / 1000000)

    def ticks_us():
        return (_time.perf_counter_ns() // 1000) & (_TICKS_PERIOD - 1)

    def ticks_diff(new, old):
        return ((new - old + _TICKS_HALF) & (_TICKS_PERIOD - 1)) - _TICKS_HALF


__all__ = [
    "SensorError",
    "ChipIdError",
    "CalibrationError",
    "ReadingError",
    "SensorConfigError",
    "chip_id_error",
    "mul_shr",
    "accel_scale_q",
    "I2CDevice",
    "Accelerometer",
    "LITTLE_ENDIAN",
    "BIG_ENDIAN",
    "const",
    "sleep_ms",
    "sleep_us",
    "ticks_us",
    "ticks_diff",
]


class SensorError(RuntimeError):
    """A sensor answered but is not usable (wrong part, bad calibration, rejected settings).

    Bus failures are ``OSError`` and are never wrapped in this class, so a flight loop can tell
    "retry the bus" from "this part is wrong".
    """


class ChipIdError(SensorError):
    """The identity register held a value other than the expected part's id."""


class CalibrationError(SensorError):
    """The factory calibration failed its check (CRC, all-zero or all-ones words)."""


class SensorConfigError(SensorError):
    """The part rejected the requested configuration (e.g. BMP3 ERR.conf_err)."""


class ReadingError(SensorError):
    """A reading the part's own compensation cannot turn into a value (raised from ``read()``;
    the flight loop counts it as a failed read: the reading is never used)."""


def chip_id_error(part, addr, got, expected):
    """Build the ChipIdError for ``part`` at ``addr`` (init path only: it formats a string)."""
    return ChipIdError("%s at 0x%02x: chip id 0x%02x, expected %s" % (part, addr, got, expected))


def mul_shr(a, b, s):
    """Return ``floor(a * b / 2**s)`` exactly, with every intermediate inside +-2**30.

    Requires ``|a| < 2**28``, ``|b| < 2**28`` and ``s >= 14``; for ``s < 28`` the caller also
    guarantees that the result itself fits. Both factors are split into a signed high part and a
    14-bit non-negative low part (``a = ah * 2**14 + al``); the four partial products are below
    2**28 each and are added from the bottom up with floor shifts, which compose exactly:
    ``floor((floor(x) + n) / 2**k) == floor((x + n) / 2**k)`` for integer ``n``.

    On a 32-bit port a plain ``a * b`` with a 24-bit and a 16-bit factor already exceeds the
    31-bit small-int range and allocates a long int; this helper does not allocate.
    """
    ah = a >> 14
    al = a & 0x3FFF
    bh = b >> 14
    bl = b & 0x3FFF
    m = ((al * bl) >> 14) + ah * bl + al * bh
    if s >= 28:
        return (ah * bh + (m >> 14)) >> (s - 28)
    return ((ah * bh) << (28 - s)) + (m >> (s - 14))


def accel_scale_q(scale_ng, full_scale):
    """Fixed-point scale ``(ki, kf, shift)`` for raw counts to mm/s^2 (g = 9.80665 m/s^2):

        mm/s^2 = raw * ki + ((raw * kf + (1 << (shift - 1))) >> shift)

    ``ki`` is the integer part of the mm/s^2 per LSB, ``kf / 2**shift`` its fraction, with
    ``shift`` as large as possible (at most 24) such that ``full_scale * kf < 2**29``: the per-read
    products stay small ints, and the scale error is below ``2**-shift`` mm/s^2 per LSB (0.4 mm/s^2
    at 32768 counts, i.e. < 0.1 LSB). ``scale_ng`` is the part's scale factor in nano-g per LSB
    (integer), ``full_scale`` the largest raw magnitude. Init-time only (returns a tuple).
    """
    num = scale_ng * 980665  # mm/s^2 per LSB = num / 10**11
    den = 100000000000
    ki = num // den
    shift = 24
    while True:
        kf = ((num - ki * den) * (1 << shift) + den // 2) // den
        if full_scale * kf < (1 << 29) or shift == 1:
            return ki, kf, shift
        shift -= 1


class I2CDevice:
    """What every register-based driver has: the bus, the address, one-byte register access.

    ``_read8``/``_write8`` go through the one-byte scratch buffer ``_b1``, so they allocate
    nothing. The subclass holds its own register map (``_REG_... = const(0x..)``).
    """

    def __init__(self, i2c, addr):
        self.i2c = i2c
        self.addr = addr
        self._b1 = bytearray(1)

    def _read8(self, reg):
        self.i2c.readfrom_mem_into(self.addr, reg, self._b1)
        return self._b1[0]

    def _write8(self, reg, value):
        self._b1[0] = value
        self.i2c.writeto_mem(self.addr, reg, self._b1)

    def _check_id(self, reg, ids, part, expected):
        """Read the identity register ``reg`` and return it if it is one of ``ids``; otherwise
        raise ``ChipIdError`` naming ``part`` and the ``expected`` id(s) (init path only)."""
        got = self._read8(reg)
        if got not in ids:
            raise chip_id_error(part, self.addr, got, expected)
        return got


LITTLE_ENDIAN = const(0)  # low byte first in each int16 (ADXL375, LSM6DSO)
BIG_ENDIAN = const(1)  # high byte first (MPU6050)


class Accelerometer(I2CDevice):
    """Three-axis int16 accelerometer: the state of docs/SENSORS.md's accelerometer API and the
    conversion of one burst of six bytes.

    ``raw_min``/``raw_max`` are the part's extreme codes (a read at either sets ``clipped``);
    ``-raw_min`` is the full scale used for ``accel_scale_q``. ``scale_ng`` (nano-g per LSB)
    overrides ``nominal_ng``.
    """

    def __init__(self, i2c, addr, part, range_g, rate_hz, scale_ng, nominal_ng, raw_min, raw_max):
        super().__init__(i2c, addr)
        self.part = part
        self.range_g = range_g
        self.rate_hz = rate_hz
        self.scale_ng = scale_ng if scale_ng is not None else nominal_ng
        self._ki, self._kf, self._shift = accel_scale_q(self.scale_ng, -raw_min)
        self._half = 1 << (self._shift - 1)
        self._raw_min = raw_min
        self._raw_max = raw_max
        self._buf = bytearray(6)
        self.raw = array("h", [0, 0, 0])
        self.accel_mmps2 = array("i", [0, 0, 0])
        self.clipped = False
        self.clip_count = 0

    def _read_accel(self, reg, byte_order):
        """Burst-read X, Y, Z (int16 each, ``LITTLE_ENDIAN`` or ``BIG_ENDIAN``) from ``reg`` and
        update ``raw``, ``accel_mmps2``, ``clipped`` and ``clip_count``.

        Allocation-free and integer-only: |v| <= 2**15 and |v * kf| < 2**29 (``accel_scale_q``).
        """
        b = self._buf
        self.i2c.readfrom_mem_into(self.addr, reg, b)
        lo = byte_order  # offset of the low byte within each pair
        hi = 1 - byte_order
        raw = self.raw
        out = self.accel_mmps2
        ki = self._ki
        kf = self._kf
        shift = self._shift
        half = self._half
        raw_min = self._raw_min
        raw_max = self._raw_max
        clipped = False
        for i in range(3):
            j = 2 * i
            v = b[j + lo] | (b[j + hi] << 8)
            if v & 0x8000:
                v -= 65536
            if v >= raw_max or v <= raw_min:
                clipped = True
            raw[i] = v
            out[i] = v * ki + ((v * kf + half) >> shift)
        self.clipped = clipped
        if clipped:
            self.clip_count += 1
