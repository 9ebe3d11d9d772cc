"""ST LSM6DSO (+-16 g) / LSM6DSO32 (+-32 g) accelerometer over I2C; the gyro is left off.

Usage::

    from device.drivers.lsm6dso import LSM6DSO
    imu = LSM6DSO(i2c)                          # 0x6A (SA0 low) or 0x6B (SA0 high)
    imu32 = LSM6DSO(i2c, part="LSM6DSO32")      # same WHO_AM_I (0x6C): ``part`` decides the scale

The LSM6DSO, LSM6DSOX and LSM6DSO32 all answer WHO_AM_I = 0x6C, so, as with the ADXL345/ADXL375,
the part is the caller's statement and the 1 g pad check catches a wrong one (a DSO32 read as a DSO
shows 0.5 g).

Settings (register values written by ``__init__``):

================  ===========================================================================
register          value
================  ===========================================================================
CTRL3_C 0x12      0x01 (SW_RESET, polled until it clears), then 0x44 (BDU = 1: the high and
                  low bytes of a sample belong together; IF_INC = 1: burst reads auto-increment)
CTRL1_XL 0x10     0x74: ODR_XL = 0111 (833 Hz, high-performance), FS_XL = 01 (+-16 g on the
                  LSM6DSO, +-32 g on the LSM6DSO32: the FS code table is not monotonic)
CTRL2_G 0x11      0x00 (gyro power-down)
================  ===========================================================================

Scale: 0.488 mg/LSB (LSM6DSO +-16 g) or 0.976 mg/LSB (LSM6DSO32 +-32 g), int16 output;
``clipped`` when any axis reads -32768 or 32767.

``read()`` burst-reads OUTX_L_A..OUTZ_H_A (0x28..0x2D, little-endian int16).
"""

from array import array

try:
    from micropython import const
except ImportError:  # CPython

    def const(x):
        return x


from . import accel_scale_q, chip_id_error, sleep_ms

_REG_WHO_AM_I = const(0x0F)
_REG_CTRL1_XL = const(0x10)
_REG_CTRL2_G = const(0x11)
_REG_CTRL3_C = const(0x12)
_REG_OUTX_L_A = const(0x28)

_WHO_AM_I = const(0x6C)
_CTRL3_SW_RESET = const(0x01)
_CTRL3_BDU_IF_INC = const(0x44)
_CTRL1_833HZ_FS01 = const(0x74)

_SCALE_NG = {"LSM6DSO": 488000, "LSM6DSO32": 976000}
_RANGE_G = {"LSM6DSO": 16, "LSM6DSO32": 32}


class LSM6DSO:
    """LSM6DSO (default) or LSM6DSO32 (``part="LSM6DSO32"``), accelerometer only."""

    def __init__(self, i2c, addr=0x6A, part="LSM6DSO", scale_ng=None):
        if part not in _SCALE_NG:
            raise ValueError("LSM6DSO: part must be 'LSM6DSO' or 'LSM6DSO32'")
        self.i2c = i2c
        self.addr = addr
        self.part = part
        self.range_g = _RANGE_G[part]
        self.rate_hz = 833
        self.scale_ng = scale_ng if scale_ng is not None else _SCALE_NG[part]
        self._ki, self._kf, self._shift = accel_scale_q(self.scale_ng, 32768)
        self._half = 1 << (self._shift - 1)
        self._b1 = bytearray(1)
        self._buf = bytearray(6)
        self.raw = array("h", [0, 0, 0])
        self.accel_mmps2 = array("i", [0, 0, 0])
        self.clipped = False
        self.clip_count = 0

        who = self._read8(_REG_WHO_AM_I)
        if who != _WHO_AM_I:
            raise chip_id_error(part, addr, who, "0x6c (LSM6DSO/LSM6DSOX/LSM6DSO32)")
        self._write8(_REG_CTRL3_C, _CTRL3_SW_RESET)
        for _ in range(50):
            sleep_ms(1)
            if not self._read8(_REG_CTRL3_C) & _CTRL3_SW_RESET:
                break
        self._write8(_REG_CTRL3_C, _CTRL3_BDU_IF_INC)
        self._write8(_REG_CTRL2_G, 0x00)
        self._write8(_REG_CTRL1_XL, _CTRL1_833HZ_FS01)

    def _read8(self, reg):
        self.i2c.readfrom_mem_into(self.addr, reg, self._b1)
        return self._b1[0]

    def _write8(self, reg, value):
        self._b1[0] = value
        self.i2c.writeto_mem(self.addr, reg, self._b1)

    def read(self):
        """One burst read of the three axes; updates ``raw``, ``accel_mmps2``, ``clipped``."""
        b = self._buf
        self.i2c.readfrom_mem_into(self.addr, _REG_OUTX_L_A, b)
        raw = self.raw
        out = self.accel_mmps2
        ki = self._ki
        kf = self._kf
        shift = self._shift
        half = self._half
        clipped = False
        for i in range(3):
            v = b[2 * i] | (b[2 * i + 1] << 8)
            if v & 0x8000:
                v -= 65536
            if v >= 32767 or v <= -32768:
                clipped = True
            raw[i] = v
            out[i] = v * ki + ((v * kf + half) >> shift)
        self.clipped = clipped
        if clipped:
            self.clip_count += 1
