"""Bosch BMP388 / BMP390 barometer over I2C, integer-only and allocation-free per read.

Usage::

    from device.drivers.bmp3xx import BMP3XX
    baro = BMP3XX(i2c)              # address 0x77 (SDO high); 0x76 with SDO low
    baro.read()                     # baro.pressure_q4_pa (Pa x 16), baro.temp_cdeg (0.01 degC)

Settings (``__init__`` keywords; defaults are the flight configuration):

============  =========  =======================================================================
keyword       default    register value
============  =========  =======================================================================
``osr_p``     8          OSR (0x1C) osr_p[2:0] = 3 (x8 pressure oversampling)
``osr_t``     1          OSR (0x1C) osr_t[5:3] = 0 (x1 temperature)
``iir``       0          CONFIG (0x1F) iir_filter[3:1] = 0 (bypass; 1, 3, 7 ... 127 allowed)
``odr_hz``    50         ODR (0x1D) odr_sel = 2 (200 Hz / 2**2 = 50 Hz, 20 ms period)
(fixed)                  PWR_CTRL (0x1B) = 0x33: normal mode, pressure and temperature enabled
============  =========  =======================================================================

So OSR = 0x03, ODR = 0x02, CONFIG = 0x00, PWR_CTRL = 0x33: the part converts continuously at
50 Hz; one conversion takes 234 + (392 + 8 * 2000) + (313 + 1 * 2000) = 18 939 us (Bosch API
formula), which must fit in the 20 000 us ODR period (the part sets ERR.conf_err and stays asleep
otherwise; ``__init__`` checks both before and after). This is Bosch's "drone" profile (BMP388
datasheet table 10: x8/x1, 50 Hz, 11 cm RMS with IIR coefficient 3) with the IIR filter off: the
flight Kalman filter does the smoothing, and the sensor's IIR adds a lag of about ``iir`` samples
that the filter does not model. For 100 Hz use ``osr_p=2, odr_hz=100`` (6 939 us).

``read()`` burst-reads STATUS..DATA_5 (0x03..0x09, 7 bytes; the part shadows the data registers
during a burst, so pressure and temperature belong to one conversion), stores the raw words, sets
``fresh`` from STATUS.drdy_press (False: no new conversion since the last read, the values are
repeated) and compensates.

Compensation. Bosch's integer compensation (BMP3 Sensor API) uses 64-bit intermediates that a
32-bit MicroPython board would hold as heap long ints. This driver evaluates the same polynomial
(datasheet section 9.3 / API double-precision form)::

    P = P5 + P6 T + P7 T^2 + P8 T^3 + UP (P1 + P2 T + P3 T^2 + P4 T^3)
        + UP^2 (P9 + P10 T) + UP^3 P11

in fixed point with rescaled coefficients and ``mul_shr`` split products, every intermediate below
2**29 in magnitude for -45..+90 degC and 0.5..130 kPa (checked in tests with an int wrapper that
fails past 2**30, and on the 32-bit wasm MicroPython under ``heap_lock``). ``t_lin`` (degC x 2**16)
is Bosch's, floored instead of truncated; the pressure is accumulated in Pa x 2**8 and rounded to
Pa x 16. Against Bosch's 64-bit integer result the error is below 0.03 Pa (the BMP390's resolution
is 0.016 Pa, its RMS noise at x8 about 0.2 Pa). The temperature is rounded to the nearest
0.01 degC (Bosch truncates). Outside that envelope the arithmetic is still exact but MicroPython
promotes to long ints, i.e. ``read()`` allocates.
"""

from . import CalibrationError, I2CDevice, SensorConfigError, const, mul_shr, sleep_ms

_REG_CHIP_ID = const(0x00)
_REG_ERR = const(0x02)
_REG_STATUS = const(0x03)
_REG_PWR_CTRL = const(0x1B)
_REG_OSR = const(0x1C)
_REG_ODR = const(0x1D)
_REG_CONFIG = const(0x1F)
_REG_NVM_PAR = const(0x31)
_REG_CMD = const(0x7E)

_CHIP_ID_BMP388 = const(0x50)
_CHIP_ID_BMP390 = const(0x60)
_CMD_SOFT_RESET = const(0xB6)
_PWR_NORMAL_PT = const(0x33)
_ERR_CONF = const(0x04)
_STATUS_DRDY_PRESS = const(0x20)

_OSR_VALUES = (1, 2, 4, 8, 16, 32)
_IIR_VALUES = (0, 1, 3, 7, 15, 31, 63, 127)


def _s8(v):
    return v - 256 if v & 0x80 else v


def _u16(b, i):
    return b[i] | (b[i + 1] << 8)


def _s16(b, i):
    v = b[i] | (b[i + 1] << 8)
    return v - 65536 if v & 0x8000 else v


def measurement_time_us(osr_p, osr_t):
    """Conversion time of one pressure+temperature measurement (Bosch BMP3 API formula)."""
    return 234 + 392 + osr_p * 2000 + 313 + osr_t * 2000


class BMP3XX(I2CDevice):
    """BMP388 (chip id 0x50) or BMP390 (chip id 0x60) on I2C; ``part`` says which answered."""

    def __init__(self, i2c, addr=0x77, osr_p=8, osr_t=1, iir=0, odr_hz=50):
        super().__init__(i2c, addr)
        self._buf = bytearray(7)
        self.pressure_q4_pa = 0
        self.temp_cdeg = 0
        self.raw_pressure = 0
        self.raw_temp = 0
        self.fresh = False

        if osr_p not in _OSR_VALUES or osr_t not in _OSR_VALUES:
            raise ValueError("BMP3xx: oversampling must be one of 1, 2, 4, 8, 16, 32")
        if iir not in _IIR_VALUES:
            raise ValueError("BMP3xx: iir must be one of 0, 1, 3, 7, 15, 31, 63, 127")
        odr_sel = -1
        for sel in range(18):
            if 200 / (1 << sel) == odr_hz:
                odr_sel = sel
                break
        if odr_sel < 0:
            raise ValueError("BMP3xx: odr_hz must be 200 / 2**n (200, 100, 50, 25, 12.5 ...)")
        self.measurement_us = measurement_time_us(osr_p, osr_t)
        self.period_us = 5000 << odr_sel
        if self.measurement_us >= self.period_us:
            raise SensorConfigError(
                "BMP3xx: x%d/x%d takes %d us, longer than the %d us ODR period"
                % (osr_p, osr_t, self.measurement_us, self.period_us)
            )

        chip = self._check_id(
            _REG_CHIP_ID,
            (_CHIP_ID_BMP388, _CHIP_ID_BMP390),
            "BMP388/BMP390",
            "0x50 (BMP388) or 0x60 (BMP390)",
        )
        self.part = "BMP388" if chip == _CHIP_ID_BMP388 else "BMP390"

        self._write8(_REG_CMD, _CMD_SOFT_RESET)
        sleep_ms(3)
        self._load_calibration()
        self._write8(_REG_OSR, (_OSR_VALUES.index(osr_t) << 3) | _OSR_VALUES.index(osr_p))
        self._write8(_REG_ODR, odr_sel)
        self._write8(_REG_CONFIG, _IIR_VALUES.index(iir) << 1)
        self._write8(_REG_PWR_CTRL, _PWR_NORMAL_PT)
        err = self._read8(_REG_ERR)
        if err & _ERR_CONF:
            raise SensorConfigError("%s at 0x%02x: ERR=0x%02x, configuration rejected"
                                    % (self.part, addr, err))

    def _load_calibration(self):
        b = bytearray(21)
        self.i2c.readfrom_mem_into(self.addr, _REG_NVM_PAR, b)
        if b == bytearray(21) or b == bytearray(b"\xff" * 21):
            raise CalibrationError(
                "%s at 0x%02x: calibration NVM reads all 0x%02x" % (self.part, self.addr, b[0])
            )
        par_t1 = _u16(b, 0)
        par_t2 = _u16(b, 2)
        par_t3 = _s8(b[4])
        par_p1 = _s16(b, 5)
        par_p2 = _s16(b, 7)
        par_p3 = _s8(b[9])
        par_p4 = _s8(b[10])
        par_p5 = _u16(b, 11)
        par_p6 = _u16(b, 13)
        par_p7 = _s8(b[15])
        par_p8 = _s8(b[16])
        par_p9 = _s16(b, 17)
        par_p10 = _s8(b[19])
        par_p11 = _s8(b[20])
        # Rescaled coefficients (see the module docstring for the units):
        self._t1x256 = par_t1 << 8  # UT offset
        self._t2 = par_t2
        self._t3 = par_t3
        self._o5 = par_p5 << 11  # P5 * 2**3 Pa, in Pa * 2**8
        self._o6 = par_p6
        self._o7 = par_p7
        self._o8 = par_p8
        self._s1 = (par_p1 - 16384) << 12  # P1 in S * 2**32
        self._s2 = (par_p2 - 16384) << 1
        self._s3 = par_p3
        self._s4 = par_p4
        self._q9 = par_p9 << 12  # (P9 + P10 T) in Q12 (Pa per unit (UP/2**24)**2)
        self._q10 = par_p10
        self._p11 = par_p11

    def read(self):
        """One burst read and compensation; updates ``pressure_q4_pa``, ``temp_cdeg``, ``fresh``."""
        b = self._buf
        self.i2c.readfrom_mem_into(self.addr, _REG_STATUS, b)
        self.fresh = bool(b[0] & _STATUS_DRDY_PRESS)
        self.raw_pressure = b[1] | (b[2] << 8) | (b[3] << 16)
        self.raw_temp = b[4] | (b[5] << 8) | (b[6] << 16)
        self.compensate(self.raw_pressure, self.raw_temp)

    def compensate(self, up, ut):
        """Set ``temp_cdeg`` and ``pressure_q4_pa`` from the raw 24-bit words ``up`` and ``ut``."""
        # t_lin = pd1 * par_t2 / 2**14 + pd1**2 * par_t3 / 2**32, degC * 2**16 (|t| < 2**23).
        pd1 = ut - self._t1x256
        t2 = self._t2
        t = ((pd1 >> 12) * t2 + (((pd1 & 0xFFF) * t2) >> 12)) >> 2
        t += (mul_shr(pd1, pd1, 24) * self._t3) >> 8
        self.temp_cdeg = (t * 25 + 8192) >> 14
        tt = mul_shr(t, t, 24)  # T**2, degC**2 * 2**8
        ttt = mul_shr(tt, t, 22)  # T**3, degC**3 * 2**2
        # Offset in Pa * 2**8, sensitivity in (Pa per UP LSB) * 2**32.
        off = self._o5 + mul_shr(self._o6, t, 14) + ((self._o7 * tt) >> 8) + ((self._o8 * ttt) >> 9)
        sens = self._s1 + mul_shr(self._s2, t, 14) + ((self._s3 * tt) >> 8) + ((self._s4 * ttt) >> 7)
        x2 = mul_shr(up, up, 24)  # UP**2 / 2**24
        x3 = mul_shr(x2, up, 26)  # UP**3 / 2**50
        q = self._q9 + ((self._q10 * t) >> 4)
        p = off + mul_shr(sens, up, 24) + mul_shr(q, x2, 28) + ((self._p11 * x3) >> 7)
        self.pressure_q4_pa = (p + 8) >> 4


BMP388 = BMP3XX
BMP390 = BMP3XX
