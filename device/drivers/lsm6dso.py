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

from . import LITTLE_ENDIAN, Accelerometer, const, sleep_ms

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


class LSM6DSO(Accelerometer):
    """LSM6DSO (default) or LSM6DSO32 (``part="LSM6DSO32"``), accelerometer only."""

    def __init__(self, i2c, addr=0x6A, part="LSM6DSO", scale_ng=None):
        if part not in _SCALE_NG:
            raise ValueError("LSM6DSO: part must be 'LSM6DSO' or 'LSM6DSO32'")
        super().__init__(i2c, addr, part, _RANGE_G[part], 833, scale_ng, _SCALE_NG[part], -32768, 32767)
        self._check_id(_REG_WHO_AM_I, (_WHO_AM_I,), part, "0x6c (LSM6DSO/LSM6DSOX/LSM6DSO32)")
        self._write8(_REG_CTRL3_C, _CTRL3_SW_RESET)
        for _ in range(50):
            sleep_ms(1)
            if not self._read8(_REG_CTRL3_C) & _CTRL3_SW_RESET:
                break
        self._write8(_REG_CTRL3_C, _CTRL3_BDU_IF_INC)
        self._write8(_REG_CTRL2_G, 0x00)
        self._write8(_REG_CTRL1_XL, _CTRL1_833HZ_FS01)

    def read(self):
        """One burst read of OUTX_L_A..OUTZ_H_A; updates ``raw``, ``accel_mmps2``, ``clipped``."""
        self._read_accel(_REG_OUTX_L_A, LITTLE_ENDIAN)
