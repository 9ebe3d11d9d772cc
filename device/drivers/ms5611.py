"""TE Connectivity (MEAS) MS5611-01BA03 barometer over I2C, integer-only and allocation-free.

The MS5611 has no registers: one-byte commands start a conversion (D1 = pressure, D2 =
temperature), and the 24-bit result is read with the ADC-read command once the conversion time
has passed (reading early returns 0). So the driver has two APIs:

- **two-phase, for the flight loop** (never blocks)::

      baro.start()                  # issue the next conversion (pressure, or temperature every
                                    # ``temp_every`` pressures), note the ticks
      ...                           # one loop period later (>= baro.conversion_us)
      if baro.collect():            # reads the ADC; True when a new pressure was computed
          use(baro.pressure_q4_pa)

  ``ready()`` tells whether the conversion time has elapsed. ``collect()`` called too early
  returns False without touching the bus (the conversion keeps running); an ADC result of 0 (the
  part lost the conversion, e.g. after a brown-out) is counted in ``dropped`` and returns False.
  With the defaults (OSR 4096, 9.04 ms max) and a 100 Hz loop that calls ``start()`` right after
  ``collect()``, pressure is new at 80 Hz and temperature at 20 Hz (ArduPilot's schedule).

- **blocking** ``read()``: temperature conversion, ``sleep_us``, pressure conversion,
  ``sleep_us``, compensate: 2 x 9.04 ms = 18.1 ms at OSR 4096. For bench use and tests.

Settings: ``osr`` in 256, 512, 1024, 2048, 4096 (default 4096) for both conversions; commands
0x40 + 2k (D1) and 0x50 + 2k (D2), k = log2(osr / 256); conversion time (datasheet maximum)
0.60 / 1.17 / 2.28 / 4.54 / 9.04 ms, RMS resolution 6.5 / 4.2 / 2.7 / 1.8 / 1.2 Pa.

``__init__`` sends RESET (0x1E), waits 3 ms, reads the 8 PROM words (0xA0..0xAE) and checks the
CRC-4 of AN520 (the part has no chip id: a wrong or absent part fails the CRC, or NACKs).

Compensation is the datasheet's first- and second-order integer algorithm, bit-exact (``TEMP`` in
0.01 degC; the datasheet's P in Pa equals ``pressure_q4_pa >> 4``): OFF and SENS (> 2**31) are
held as two 16-bit halves, D1 * SENS - OFF * 2**21 is accumulated bottom-up in 12/16-bit limbs
with floor shifts, so every intermediate stays below 2**28 for -40..+85 degC with any PROM. The
pressure keeps 4 fractional bits: ``floor((D1 * SENS - OFF * 2**21) / 2**32)``.
"""

from . import CalibrationError, const, mul_shr, sleep_ms, sleep_us, ticks_diff, ticks_us

_CMD_RESET = const(0x1E)
_CMD_CONVERT_D1 = const(0x40)
_CMD_CONVERT_D2 = const(0x50)
_CMD_ADC_READ = const(0x00)
_CMD_PROM_READ = const(0xA0)

_OSR_VALUES = (256, 512, 1024, 2048, 4096)
# datasheet maximum per OSR; a list made a tuple: frozen firmware would store 9040 as a long int
_CONVERSION_US = tuple([600, 1170, 2280, 4540, 9040])

_IDLE = const(0)
_CONVERTING_P = const(1)
_CONVERTING_T = const(2)


def crc4(words):
    """CRC-4 of the 8 PROM words (AN520); the CRC itself sits in the low nibble of word 7."""
    n_rem = 0
    for cnt in range(16):
        w = words[cnt >> 1]
        if cnt == 15:
            w &= 0xFF00  # the CRC nibble is not part of the checked data
        n_rem ^= (w & 0xFF) if cnt & 1 else (w >> 8)
        for _ in range(8):
            if n_rem & 0x8000:
                n_rem = ((n_rem << 1) ^ 0x3000) & 0xFFFF
            else:
                n_rem = (n_rem << 1) & 0xFFFF
    return (n_rem >> 12) & 0xF


class MS5611:
    """MS5611-01BA03 at ``addr`` 0x77 (CSB low) or 0x76 (CSB high)."""

    def __init__(self, i2c, addr=0x77, osr=4096, temp_every=4):
        if osr not in _OSR_VALUES:
            raise ValueError("MS5611: osr must be one of 256, 512, 1024, 2048, 4096")
        if temp_every < 1:
            raise ValueError("MS5611: temp_every must be >= 1")
        self.i2c = i2c
        self.addr = addr
        k = _OSR_VALUES.index(osr)
        self.conversion_us = _CONVERSION_US[k]
        self._cmd_p = bytearray((_CMD_CONVERT_D1 + 2 * k,))
        self._cmd_t = bytearray((_CMD_CONVERT_D2 + 2 * k,))
        self._b2 = bytearray(2)
        self._b3 = bytearray(3)
        self.temp_every = temp_every
        self.pressure_q4_pa = 0
        self.temp_cdeg = 0
        self.raw_pressure = 0  # D1
        self.raw_temp = 0  # D2
        self.dropped = 0
        self._state = _IDLE
        self._t_start = 0
        self._since_temp = temp_every  # forces a temperature conversion first
        self._have_temp = False

        self.i2c.writeto(addr, bytearray((_CMD_RESET,)))
        sleep_ms(3)
        words = [0] * 8
        for i in range(8):
            self.i2c.readfrom_mem_into(addr, _CMD_PROM_READ + 2 * i, self._b2)
            words[i] = (self._b2[0] << 8) | self._b2[1]
        self.prom = words
        if words[1:7] == [0] * 6 or words[1:7] == [0xFFFF] * 6:
            raise CalibrationError("MS5611 at 0x%02x: PROM reads all 0x%04x" % (addr, words[1]))
        crc = crc4(words)
        if crc != words[7] & 0xF:
            raise CalibrationError(
                "MS5611 at 0x%02x: PROM CRC 0x%x, computed 0x%x" % (addr, words[7] & 0xF, crc)
            )
        self._c1 = words[1]
        self._c2 = words[2]
        self._c3 = words[3]
        self._c4 = words[4]
        self._c5x256 = words[5] << 8
        self._c6 = words[6]

    # -- two-phase API -----------------------------------------------------------------------

    def start(self):
        """Start the next conversion (temperature first, then every ``temp_every`` pressures)."""
        if self._since_temp >= self.temp_every or not self._have_temp:
            self.i2c.writeto(self.addr, self._cmd_t)
            self._state = _CONVERTING_T
        else:
            self.i2c.writeto(self.addr, self._cmd_p)
            self._state = _CONVERTING_P
        self._t_start = ticks_us()

    def ready(self):
        """True once the running conversion has had its maximum conversion time."""
        return self._state != _IDLE and ticks_diff(ticks_us(), self._t_start) >= self.conversion_us

    def collect(self):
        """Read the finished conversion; True when ``pressure_q4_pa``/``temp_cdeg`` were updated."""
        if not self.ready():
            return False
        state = self._state
        self._state = _IDLE
        v = self._read_adc()
        if v == 0:
            self.dropped += 1
            return False
        if state == _CONVERTING_T:
            self.raw_temp = v
            self._since_temp = 0
            self._have_temp = True
            return False
        self.raw_pressure = v
        self._since_temp += 1
        self.compensate(v, self.raw_temp)
        return True

    # -- blocking API ------------------------------------------------------------------------

    def read(self):
        """Blocking: convert temperature and pressure (2 x ``conversion_us``) and compensate."""
        self.i2c.writeto(self.addr, self._cmd_t)
        sleep_us(self.conversion_us)
        t = self._read_adc()
        self.i2c.writeto(self.addr, self._cmd_p)
        sleep_us(self.conversion_us)
        p = self._read_adc()
        if t == 0 or p == 0:
            self.dropped += 1
            return
        self.raw_temp = t
        self.raw_pressure = p
        self._have_temp = True
        self._since_temp = 1
        self.compensate(p, t)

    def _read_adc(self):
        b = self._b3
        self.i2c.readfrom_mem_into(self.addr, _CMD_ADC_READ, b)
        return (b[0] << 16) | (b[1] << 8) | b[2]

    # -- compensation ------------------------------------------------------------------------

    def compensate(self, d1, d2):
        """Datasheet first- and second-order compensation of raw ``d1`` (pressure), ``d2``."""
        dt = d2 - self._c5x256  # |dT| < 2**24
        th = dt >> 12
        tl = dt & 0xFFF
        c6 = self._c6
        temp = 2000 + ((th * c6 + ((tl * c6) >> 12)) >> 11)  # 2000 + dT * C6 / 2**23
        # OFF = C2 * 2**16 + C4 * dT / 2**7 as oh * 2**16 + ol
        c = self._c4
        u = c * th
        v = (c * tl) >> 7
        oh = self._c2 + (u >> 11) + (v >> 16)
        ol = ((u & 0x7FF) << 5) + (v & 0xFFFF)
        # SENS = C1 * 2**15 + C3 * dT / 2**8 as sh * 2**16 + sl
        c = self._c3
        u = c * th
        v = (c * tl) >> 8
        c = self._c1
        sh = (c >> 1) + (u >> 12) + (v >> 16)
        sl = ((c & 1) << 15) + ((u & 0xFFF) << 4) + (v & 0xFFFF)
        if temp < 2000:  # second order
            d = temp - 2000
            d = d * d
            off2 = (5 * d) >> 1
            sens2 = (5 * d) >> 2
            if temp < -1500:
                d = temp + 1500
                d = d * d
                off2 += 7 * d
                sens2 += (11 * d) >> 1
            temp -= mul_shr(dt, dt, 31)
            oh -= off2 >> 16
            ol -= off2 & 0xFFFF
            sh -= sens2 >> 16
            sl -= sens2 & 0xFFFF
        oh += ol >> 16
        ol &= 0xFFFF
        sh += sl >> 16
        sl &= 0xFFFF
        self.temp_cdeg = temp
        # floor((D1 * SENS - OFF * 2**21) / 2**32), D1 = dh * 2**12 + dl
        dh = d1 >> 12
        dl = d1 & 0xFFF
        acc = (dl * sl) >> 12
        acc = (acc + dh * sl) >> 4
        acc = (acc + dl * sh) >> 5
        acc = (acc - ol) >> 7
        acc = (acc + dh * sh) >> 4
        self.pressure_q4_pa = acc - (oh << 5)
