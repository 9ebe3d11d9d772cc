"""Bosch BMP280 (and BME280 pressure/temperature) barometer over I2C, integer-only, no allocation.

Usage::

    from device.drivers.bmp280 import BMP280
    baro = BMP280(i2c)              # address 0x76 (SDO low) or 0x77 (SDO high)
    baro.read()                     # baro.pressure_q4_pa (Pa x 16), baro.temp_cdeg (0.01 degC)

Settings (``__init__`` keywords; defaults are the flight configuration):

=============  ========  ======================================================================
keyword        default   register value
=============  ========  ======================================================================
``osrs_p``     4         ctrl_meas (0xF4) osrs_p[4:2] = 011 (x4, 18 bit, 0.66 Pa resolution)
``osrs_t``     1         ctrl_meas (0xF4) osrs_t[7:5] = 001 (x1)
``iir``        0         config (0xF5) filter[4:2] = 000 (off; 2, 4, 8, 16 allowed)
``t_sb_us``    500       config (0xF5) t_sb[7:5] = 000 (0.5 ms standby)
(fixed)                  ctrl_meas mode[1:0] = 11 (normal mode)
=============  ========  ======================================================================

So config = 0x00 (written in sleep mode, after a soft reset) and ctrl_meas = 0x2F. One
measurement takes 1 + 2 x 1 + 2 x 4 + 0.5 = 11.5 ms typical (13.3 ms max), so with 0.5 ms standby
the part delivers a new result every 12.0 ms (83 Hz; ~72 Hz worst case): Bosch's "handheld
dynamic" oversampling with the IIR off (the flight Kalman filter smooths; the IIR would add a lag
of several samples). ``osrs_p=2`` gives Bosch's "drop detection" profile (125 Hz, 20.8 cm RMS).

``read()`` burst-reads press_msb..temp_xlsb (0xF7..0xFC; the part shadows the data registers
during a burst) and compensates.

Compensation. The datasheet's temperature formula (``t_fine``) fits 31-bit ints as it is. Its
pressure formulas do not: the int64 one (Q24.8 result) needs 64-bit products and a 62-bit by
30-bit division, the "32-bit" one still has 2**31 intermediates and is 3 Pa off. This driver
evaluates the double-precision formula ``P = (2**20 - adc_P - var2 / 2**12) * 6250 / var1 +
(P9 P**2 / 2**31 + P8 P / 2**15 + P7) / 16`` in fixed point: the numerator in Pa x 2**8 via a
precomputed ``6250 * 2**30 / dig_P1`` and ``mul_shr``, the division by the temperature term
``var1 / dig_P1`` (kept in Q24) as a 24-bit long division in 5-bit steps. Every intermediate stays
below 2**30 for -40..+85 degC, 0.5..130 kPa and calibration words inside Bosch's plausibility
ranges; the result is within 0.04 Pa of the datasheet's int64 result (resolution 0.16 Pa at x16).
The datasheet example (``dig_T1 = 27504 ...``, adc_T 519888, adc_P 415148) gives t_fine 128422,
25.08 degC and 100653.26 Pa (int64: 25767233 / 256 = 100653.25 Pa).
"""

from . import CalibrationError, I2CDevice, ReadingError, const, mul_shr, sleep_ms

_REG_CALIB = const(0x88)
_REG_ID = const(0xD0)
_REG_RESET = const(0xE0)
_REG_STATUS = const(0xF3)
_REG_CTRL_MEAS = const(0xF4)
_REG_CONFIG = const(0xF5)
_REG_DATA = const(0xF7)

_CHIP_ID_BMP280 = const(0x58)
_CHIP_ID_BME280 = const(0x60)
_RESET_CMD = const(0xB6)
_STATUS_IM_UPDATE = const(0x01)

_OSRS_VALUES = (0, 1, 2, 4, 8, 16)  # code 0 = skipped
_IIR_VALUES = (0, 2, 4, 8, 16)
# a list made a tuple: frozen firmware would store these ints as long-int objects in a constant tuple
_T_SB_US = tuple([500, 62500, 125000, 250000, 500000, 1000000, 2000000, 4000000])


# raised from read() (pre-built: the per-sample path allocates nothing)
_NO_PRESSURE = ReadingError("BMP280: pressure compensation undefined (var1 <= 0)")


def _s16(b, i):
    v = b[i] | (b[i + 1] << 8)
    return v - 65536 if v & 0x8000 else v


def measurement_time_us(osrs_p, osrs_t):
    """Typical measurement time in normal mode (datasheet appendix formula)."""
    return 1000 + 2000 * osrs_t + 2000 * osrs_p + 500


class BMP280(I2CDevice):
    """BMP280 (chip id 0x58) or BME280 (0x60, humidity not read); ``part`` says which."""

    def __init__(self, i2c, addr=0x76, osrs_p=4, osrs_t=1, iir=0, t_sb_us=500):
        if osrs_p not in _OSRS_VALUES[1:] or osrs_t not in _OSRS_VALUES[1:]:
            raise ValueError("BMP280: oversampling must be one of 1, 2, 4, 8, 16")
        if iir not in _IIR_VALUES:
            raise ValueError("BMP280: iir must be one of 0, 2, 4, 8, 16")
        if t_sb_us not in _T_SB_US:
            raise ValueError("BMP280: t_sb_us must be one of %s" % (_T_SB_US,))
        super().__init__(i2c, addr)
        self._buf = bytearray(6)
        self.pressure_q4_pa = 0
        self.temp_cdeg = 0
        self.t_fine = 0
        self.raw_pressure = 0
        self.raw_temp = 0
        self.period_us = measurement_time_us(osrs_p, osrs_t) + t_sb_us

        chip = self._check_id(
            _REG_ID, (_CHIP_ID_BMP280, _CHIP_ID_BME280), "BMP280", "0x58 (BMP280) or 0x60 (BME280)"
        )
        self.part = "BMP280" if chip == _CHIP_ID_BMP280 else "BME280"
        self._write8(_REG_RESET, _RESET_CMD)
        sleep_ms(3)
        for _ in range(20):
            if not self._read8(_REG_STATUS) & _STATUS_IM_UPDATE:
                break
            sleep_ms(1)
        self._load_calibration()
        self._write8(_REG_CONFIG, (_T_SB_US.index(t_sb_us) << 5) | (_IIR_VALUES.index(iir) << 2))
        self.ctrl_meas = (_OSRS_VALUES.index(osrs_t) << 5) | (_OSRS_VALUES.index(osrs_p) << 2) | 0x03
        self._write8(_REG_CTRL_MEAS, self.ctrl_meas)

    def _load_calibration(self):
        b = bytearray(24)
        self.i2c.readfrom_mem_into(self.addr, _REG_CALIB, b)
        t1 = b[0] | (b[1] << 8)
        p1 = b[6] | (b[7] << 8)
        if t1 == 0 or p1 == 0 or b == bytearray(b"\xff" * 24):
            raise CalibrationError("%s at 0x%02x: calibration words are blank" % (self.part, self.addr))
        self._t1 = t1
        self._t2 = _s16(b, 2)
        self._t3 = _s16(b, 4)
        self._p1 = p1
        self._p2x8 = _s16(b, 8) << 3
        self._p3 = _s16(b, 10)
        self._p4x1024 = _s16(b, 12) << 10
        self._p5x64 = _s16(b, 14) << 6
        self._p6x8 = _s16(b, 16) << 3
        self._p7x16 = _s16(b, 18) << 4
        self._p8 = _s16(b, 20)
        self._p9 = _s16(b, 22)
        self._k30 = (6250 * (1 << 30) + (p1 >> 1)) // p1  # 6250 / dig_P1 in Q30 (< 2**28)

    def read(self):
        """One burst read of the data registers and compensation."""
        b = self._buf
        self.i2c.readfrom_mem_into(self.addr, _REG_DATA, b)
        self.raw_pressure = (b[0] << 12) | (b[1] << 4) | (b[2] >> 4)
        self.raw_temp = (b[3] << 12) | (b[4] << 4) | (b[5] >> 4)
        self.compensate(self.raw_pressure, self.raw_temp)

    def compensate(self, adc_p, adc_t):
        """Set ``t_fine``, ``temp_cdeg`` and ``pressure_q4_pa`` from the 20-bit raw words."""
        t1 = self._t1
        var1 = (((adc_t >> 3) - (t1 << 1)) * self._t2) >> 11
        d = (adc_t >> 4) - t1
        t_fine = var1 + ((((d * d) >> 12) * self._t3) >> 14)
        self.t_fine = t_fine
        self.temp_cdeg = (t_fine * 5 + 128) >> 8
        vv = t_fine - 128000  # 2 * var1 of the double formula, |vv| < 2**19
        sq = mul_shr(vv, vv, 14)
        # x = (2**20 - adc_P - var2 / 2**12) * 2**6
        x = ((1048576 - adc_p) << 6) - mul_shr(sq, self._p6x8, 14)
        x -= mul_shr(vv, self._p5x64, 14) + self._p4x1024
        # e = var1 / dig_P1 = 1 + P3 vv**2 / 2**55 + P2 vv / 2**35, in Q24
        e = 16777216 + mul_shr(sq, self._p3, 17) + mul_shr(self._p2x8, vv, 14)
        if e <= 0:
            # the datasheet's code returns pressure 0 here (it would divide by zero): that is not
            # a pressure; raised, never stored, so no one uses it
            raise _NO_PRESSURE
        a = mul_shr(x, self._k30, 28)  # x * 6250 / dig_P1 in Pa * 2**8 (before / e)
        q = a // e  # q = floor(a * 2**24 / e), 24 quotient bits in 5-bit steps
        r = a - q * e
        r <<= 5
        d = r // e
        r -= d * e
        q = (q << 5) + d
        r <<= 5
        d = r // e
        r -= d * e
        q = (q << 5) + d
        r <<= 5
        d = r // e
        r -= d * e
        q = (q << 5) + d
        r <<= 5
        d = r // e
        r -= d * e
        q = (q << 5) + d
        r <<= 4
        q = (q << 4) + r // e  # P in Pa * 2**8
        p = q + mul_shr(self._p9, mul_shr(q, q, 29), 14) + mul_shr(self._p8, q, 19) + self._p7x16
        self.pressure_q4_pa = (p + 8) >> 4
