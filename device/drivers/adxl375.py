"""Analog Devices ADXL375 (+-200 g) and ADXL345 (+-16 g) accelerometers over I2C.

Usage::

    from device.drivers.adxl375 import ADXL375
    acc = ADXL375(i2c)                      # 0x53 (ALT ADDRESS low) or 0x1D (high)
    acc.read()                              # acc.accel_mmps2[0..2], acc.clipped, acc.clip_count
    acc345 = ADXL375(i2c, part="ADXL345")   # same driver, ADXL345 scale and range

**The two parts cannot be told apart**: the ADXL375 is register-compatible with the ADXL345 down
to the DEVID register (0xE5 on both), so ``part`` is the caller's statement of what is soldered on
the board. A wrong ``part`` gives readings off by 12.5x (3.9 vs 49 mg/LSB). What catches it is the
pad check before arming (DESIGN.md D4): at rest |a| must be close to 1 g (9807 mm/s^2); an
ADXL345 read as an ADXL375 shows ~12.3 g, an ADXL375 read as an ADXL345 shows ~0.08 g.

Settings (register values written by ``__init__``):

===============  =========================================================================
register         value
===============  =========================================================================
POWER_CTL 0x2D   0x00 while configuring, then 0x08 (Measure)
BW_RATE 0x2C     ``rate_hz`` code: 800 Hz -> 0x0D (default; bandwidth 400 Hz). 100..3200 Hz
                 allowed; 1600/3200 Hz are avoided by default because of the reported
                 right-justified data quirk of the ADXL375 at those rates.
DATA_FORMAT 0x31 0x0B: FULL_RES = 1, right-justified, range bits 11 (+-16 g on the ADXL345;
                 the ADXL375 range is fixed at +-200 g and ADI asks for these bits set)
FIFO_CTL 0x38    0x00 (bypass: each read gets the newest sample)
INT_ENABLE 0x2E  0x00
OFSX/Y/Z 0x1E..  0x00 (offsets are calibrated in software on the pad)
===============  =========================================================================

Scale (datasheet typical; ``scale_ng``, nano-g per LSB, overrides it with a per-unit
calibration): ADXL375 49 mg/LSB (20.5 LSB/g, 18.4..22.6 between units: calibrate on the pad),
ADXL345 full resolution 256 LSB/g (3.9 mg/LSB).
Both output 13-bit two's complement (-4096..4095) sign-extended to 16 bits; ``clipped`` is set
when any axis reads -4096 or 4095 (the sensor is saturated, or about to be).

``read()`` burst-reads DATAX0..DATAZ1 (0x32..0x37, little-endian int16) and stores the raw counts
in ``raw`` and the specific force in ``accel_mmps2`` (mm/s^2, +9807 on the axis pointing up at
rest).
"""

from . import LITTLE_ENDIAN, Accelerometer, const

_REG_DEVID = const(0x00)
_REG_OFSX = const(0x1E)
_REG_BW_RATE = const(0x2C)
_REG_POWER_CTL = const(0x2D)
_REG_INT_ENABLE = const(0x2E)
_REG_DATA_FORMAT = const(0x31)
_REG_DATAX0 = const(0x32)
_REG_FIFO_CTL = const(0x38)

_DEVID = const(0xE5)
_POWER_MEASURE = const(0x08)
_DATA_FORMAT_FULL_RES = const(0x0B)
_RAW_MAX = const(4095)
_RAW_MIN = const(-4096)

_RATES_HZ = (3200, 1600, 800, 400, 200, 100)
_RATE_CODES = (0x0F, 0x0E, 0x0D, 0x0C, 0x0B, 0x0A)
_SCALE_NG = {"ADXL375": 49000000, "ADXL345": 3906250}
_RANGE_G = {"ADXL375": 200, "ADXL345": 16}


class ADXL375(Accelerometer):
    """ADXL375 (default) or ADXL345 (``part="ADXL345"``): both answer DEVID 0xE5."""

    def __init__(self, i2c, addr=0x53, part="ADXL375", rate_hz=800, scale_ng=None):
        if part not in _SCALE_NG:
            raise ValueError("ADXL375: part must be 'ADXL375' or 'ADXL345'")
        if rate_hz not in _RATES_HZ:
            raise ValueError("%s: rate_hz must be one of %s" % (part, _RATES_HZ))
        super().__init__(
            i2c, addr, part, _RANGE_G[part], rate_hz, scale_ng, _SCALE_NG[part], _RAW_MIN, _RAW_MAX
        )
        self._check_id(_REG_DEVID, (_DEVID,), part, "0xe5 (ADXL345/ADXL375)")
        self._write8(_REG_POWER_CTL, 0x00)
        self._write8(_REG_BW_RATE, _RATE_CODES[_RATES_HZ.index(rate_hz)])
        self._write8(_REG_DATA_FORMAT, _DATA_FORMAT_FULL_RES)
        self._write8(_REG_FIFO_CTL, 0x00)
        self._write8(_REG_INT_ENABLE, 0x00)
        for i in range(3):
            self._write8(_REG_OFSX + i, 0x00)
        self._write8(_REG_POWER_CTL, _POWER_MEASURE)

    def read(self):
        """One burst read of DATAX0..DATAZ1; updates ``raw``, ``accel_mmps2``, ``clipped``."""
        self._read_accel(_REG_DATAX0, LITTLE_ENDIAN)


class ADXL345(ADXL375):
    """The ADXL345 (+-16 g full resolution): ``ADXL375(i2c, part="ADXL345")``."""

    def __init__(self, i2c, addr=0x53, rate_hz=800, scale_ng=None):
        super().__init__(i2c, addr, part="ADXL345", rate_hz=rate_hz, scale_ng=scale_ng)
