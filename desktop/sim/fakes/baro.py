"""Register-level fake barometers: BMP388, BMP390, BMP280 and MS5611.

Each fake holds the part's register file (or PROM and command state) and its calibration, and
``set_truth(pressure_pa, temp_c)`` turns a physical truth into the raw ADC words the real part
would return for that calibration: the vendor compensation (``bmp3_*``, ``bmp280_*``,
``ms5611_compensate`` below, exact integer transcriptions of the Bosch APIs' 64-bit code and of
the MS5611 datasheet) is inverted by integer bisection on the raw word, temperature first. Each
``set_truth`` is one sample: Gaussian noise (``noise_pa``, ``noise_c``; seeded numpy Generator or
``random.Random`` via ``rng=`` / ``seed=``) is drawn per call, the raw word is quantised where the
part documents it (BMP280: 16..20 bit by oversampling) and clipped to the ADC range.

Protocols modelled:

- BMP3xx: CHIP_ID, ERR (conf_err when normal mode is asked with a conversion longer than the ODR
  period; cleared on read), STATUS (cmd_rdy; drdy_press/drdy_temp set by a new sample, cleared by
  reading the data registers), DATA 0x04..0x09, PWR_CTRL/OSR/ODR/CONFIG, NVM_PAR 0x31..0x45,
  CMD 0xB6 soft reset; data update only in normal mode (or once per forced-mode write).
- BMP280: id 0xD0, reset 0xE0, status, ctrl_meas (osrs codes set the quantisation; osrs 0 =
  skipped gives 0x80000), config, data 0xF7..0xFC, calibration 0x88..0x9F; data update only when
  not sleeping.
- MS5611: RESET, PROM read (0xA0..0xAE, CRC-4 in word 7), CONVERT D1/D2 at any OSR, ADC read
  (returns 0 when no conversion is pending, when it was already read, or, with ``clock_us``, before
  the typical conversion time has passed).

Not modelled: the BMP IIR filter, FIFO, interrupts, SPI, self-heating.

Pure Python with MicroPython-compatible features only (long ints are needed for the reference
compensation), so these fakes also run on the MicroPython interpreters.
"""

from .i2c_bus import FakeI2CDevice, default_rng, gauss

# -- shared helpers ------------------------------------------------------------------------------


def _cdiv(a, b):
    """C99 integer division (truncates toward zero), as in the vendor C code."""
    q = abs(a) // abs(b)
    return q if (a >= 0) == (b > 0) else -q


def invert_monotonic(f, target, lo, hi):
    """Integer ``x`` in ``[lo, hi]`` whose ``f(x)`` is closest to ``target`` (f monotonic)."""
    flo = f(lo)
    fhi = f(hi)
    inc = fhi >= flo
    if (target <= flo) == inc:
        return lo
    if (target >= fhi) == inc:
        return hi
    while hi - lo > 1:
        mid = (lo + hi) // 2
        if (f(mid) < target) == inc:
            lo = mid
        else:
            hi = mid
    return lo if abs(f(lo) - target) <= abs(f(hi) - target) else hi


def _u16le(v):
    v &= 0xFFFF
    return [v & 0xFF, v >> 8]


class _FakeBaro(FakeI2CDevice):
    def __init__(self, noise_pa=0.0, noise_c=0.0, rng=None, seed=0):
        super().__init__()
        self.noise_pa = noise_pa
        self.noise_c = noise_c
        self._rng = rng
        self._seed = seed
        self.pressure_pa = 101325.0
        self.temp_c = 20.0
        self.raw_pressure = 0
        self.raw_temp = 0

    @property
    def rng(self):
        if self._rng is None:
            self._rng = default_rng(self._seed)
        return self._rng

    def set_truth(self, pressure_pa, temp_c):
        """One sample of the given truth (plus noise) into the part's output registers."""
        self.pressure_pa = float(pressure_pa)
        self.temp_c = float(temp_c)
        p = self.pressure_pa + (gauss(self.rng, self.noise_pa) if self.noise_pa else 0.0)
        t = self.temp_c + (gauss(self.rng, self.noise_c) if self.noise_c else 0.0)
        self.raw_temp = self.quantise_temp(self.encode_temp(t))
        self.raw_pressure = self.encode_pressure(p, self.raw_temp)
        if not self._stuck:
            self._publish()

    @property
    def resolution_pa(self):
        """Pressure change of one raw step at the current truth (Pa), quantisation included."""
        step = self.raw_step()
        t = self.raw_temp
        a = self.compensated_pa(self.raw_pressure, t)
        b = self.compensated_pa(self.raw_pressure + step, t)
        return abs(b - a)

    def raw_step(self):
        return 1

    def quantise_temp(self, raw_temp):
        """The temperature word as the part outputs it (the pressure is then inverted with it)."""
        return raw_temp

    def set_raw(self, raw_pressure, raw_temp):
        """Put these raw ADC words (e.g. a datasheet example) in the output registers as they are."""
        self.raw_pressure = raw_pressure
        self.raw_temp = raw_temp
        if not self._stuck:
            self._publish(quantise=False)

    def _publish(self, quantise=True):
        raise NotImplementedError


# -- BMP388 / BMP390 ----------------------------------------------------------------------------

BMP3_FIELDS = ("t1", "t2", "t3", "p1", "p2", "p3", "p4", "p5", "p6", "p7", "p8", "p9", "p10", "p11")
_BMP3_SIZES = (2, 2, 1, 2, 2, 1, 1, 2, 2, 1, 1, 2, 1, 1)  # bytes; p1, p2, p9 and the s8 are signed

# NVM of a real BMP388 with a raw sample: published in the tests of the elixir-sensors/bmp3xx
# library (test/bmp3xx/bmp388/measurement_test.exs): press bytes 0x97 0x9F 0x6D, temp 0x73 0xD8
# 0x85 -> 100876.006 Pa, 30.4993 degC (double-precision formula).
BMP388_EXAMPLE_NVM = bytes(
    [0x23, 0x6B, 0x58, 0x49, 0xF6, 0x5C, 0xFF, 0xCE, 0xF4, 0x23, 0x00,
     0xEA, 0x63, 0x6E, 0x79, 0xF3, 0xF6, 0xAA, 0x43, 0x12, 0xC4]
)  # fmt: skip
BMP388_EXAMPLE_RAW = (0x6D9F97, 0x85D873)  # (UP, UT)
BMP388_EXAMPLE_RESULT = (100876.00634692199, 30.499314453874284)  # (Pa, degC)

# Synthetic BMP390 calibration (the BMP388 one, perturbed within the spread seen on real parts).
BMP390_SYNTHETIC_CAL = {
    "t1": 27992, "t2": 19143, "t3": -7, "p1": 412, "p2": -2480, "p3": 30, "p4": -1,
    "p5": 25201, "p6": 30460, "p7": -9, "p8": -12, "p9": 16012, "p10": 24, "p11": -48,
}  # fmt: skip


def bmp3_parse_nvm(b):
    """Calibration dict from the 21 NVM bytes at 0x31."""
    cal = {}
    i = 0
    for k in range(len(BMP3_FIELDS)):
        name = BMP3_FIELDS[k]
        size = _BMP3_SIZES[k]
        if size == 2:
            v = b[i] | (b[i + 1] << 8)
            if name in ("p1", "p2", "p9") and v & 0x8000:
                v -= 65536
        else:
            v = b[i]
            if v & 0x80:
                v -= 256
        cal[name] = v
        i += size
    return cal


def bmp3_encode_nvm(cal):
    """The 21 NVM bytes for a calibration dict."""
    out = []
    for k in range(len(BMP3_FIELDS)):
        v = cal[BMP3_FIELDS[k]]
        out.extend(_u16le(v) if _BMP3_SIZES[k] == 2 else [v & 0xFF])
    return bytes(out)


def bmp3_t_lin(cal, ut):
    """Bosch BMP3 API integer compensation: t_lin (degC * 2**16) for raw temperature ``ut``."""
    pd1 = ut - 256 * cal["t1"]
    pd5 = cal["t2"] * pd1 * 262144 + pd1 * pd1 * cal["t3"]
    return _cdiv(pd5, 4294967296)


def bmp3_temperature_cdeg(t_lin):
    return _cdiv(t_lin * 25, 16384)


def bmp3_pressure_cpa(cal, up, t_lin):
    """Bosch BMP3 API 64-bit integer pressure in 0.01 Pa (without the range clamp)."""
    c = cal
    pd1 = t_lin * t_lin
    pd2 = _cdiv(pd1, 64)
    pd3 = _cdiv(pd2 * t_lin, 256)
    pd4 = _cdiv(c["p8"] * pd3, 32)
    pd5 = c["p7"] * pd1 * 16
    pd6 = c["p6"] * t_lin * 4194304
    offset = c["p5"] * 140737488355328 + pd4 + pd5 + pd6
    pd2 = _cdiv(c["p4"] * pd3, 32)
    pd4 = c["p3"] * pd1 * 4
    pd5 = (c["p2"] - 16384) * t_lin * 2097152
    sensitivity = (c["p1"] - 16384) * 70368744177664 + pd2 + pd4 + pd5
    pd1 = _cdiv(sensitivity, 16777216) * up
    pd3 = c["p10"] * t_lin + 65536 * c["p9"]
    pd4 = _cdiv(pd3 * up, 8192)
    pd5 = _cdiv(up * _cdiv(pd4, 10), 512) * 10
    pd2 = _cdiv(c["p11"] * up * up, 65536)
    pd3 = _cdiv(pd2 * up, 128)
    pd4 = _cdiv(offset, 4) + pd1 + pd5 + pd3
    return _cdiv(pd4 * 25, 1099511627776)


def bmp3_float(cal, up, ut):
    """Bosch's double-precision compensation: (pressure Pa, temperature degC)."""
    c = cal
    d = ut - c["t1"] * 256.0
    t = d * (c["t2"] / 2.0**30) + d * d * (c["t3"] / 2.0**48)
    p1 = (c["p1"] - 16384) / 2.0**20
    p2 = (c["p2"] - 16384) / 2.0**29
    o1 = c["p5"] * 8.0 + c["p6"] / 64.0 * t + c["p7"] / 256.0 * t * t + c["p8"] / 32768.0 * t * t * t
    o2 = up * (p1 + p2 * t + c["p3"] / 2.0**32 * t * t + c["p4"] / 2.0**37 * t * t * t)
    o3 = up * up * (c["p9"] / 2.0**48 + c["p10"] / 2.0**48 * t) + up * up * up * c["p11"] / 2.0**65
    return o1 + o2 + o3, t


def _bmp3_measurement_us(osr_code_p, osr_code_t):
    return 234 + 392 + (1 << osr_code_p) * 2000 + 313 + (1 << osr_code_t) * 2000


class FakeBMP3xx(_FakeBaro):
    """BMP388/BMP390 register file. ``chip_id`` overrides the id (wrong-part tests)."""

    CHIP_ID = 0x50
    part = "BMP3xx"
    DEFAULT_NVM = BMP388_EXAMPLE_NVM

    def __init__(self, calibration=None, chip_id=None, noise_pa=0.0, noise_c=0.0, rng=None, seed=0):
        super().__init__(noise_pa, noise_c, rng, seed)
        if calibration is None:
            nvm = self.DEFAULT_NVM
        elif isinstance(calibration, dict):
            nvm = bmp3_encode_nvm(calibration)
        else:
            nvm = bytes(calibration)
        self.nvm = nvm
        self.cal = bmp3_parse_nvm(nvm)
        self.chip_id = self.CHIP_ID if chip_id is None else chip_id
        self.soft_resets = 0
        self._reset_registers()
        self.set_truth(self.pressure_pa, self.temp_c)

    def _reset_registers(self):
        r = self.regs
        for i in range(256):
            r[i] = 0
        r[0x00] = self.chip_id
        r[0x03] = 0x10  # cmd_rdy
        r[0x06] = 0x80  # data reset value 0x800000
        r[0x09] = 0x80
        r[0x1C] = 0x02  # OSR reset value
        r[0x31 : 0x31 + 21] = self.nvm

    @property
    def mode(self):
        return (self.regs[0x1B] >> 4) & 0x03

    def encode_temp(self, temp_c):
        target = int(round(temp_c * 65536))
        cal = self.cal
        return invert_monotonic(lambda ut: bmp3_t_lin(cal, ut), target, 0, (1 << 24) - 1)

    def encode_pressure(self, pressure_pa, raw_temp):
        cal = self.cal
        t_lin = bmp3_t_lin(cal, raw_temp)
        target = int(round(pressure_pa * 100))
        return invert_monotonic(lambda up: bmp3_pressure_cpa(cal, up, t_lin), target, 0, (1 << 24) - 1)

    def compensated_pa(self, up, ut):
        """The vendor (Bosch 64-bit integer) pressure for these raw words, in Pa."""
        return bmp3_pressure_cpa(self.cal, up, bmp3_t_lin(self.cal, ut)) / 100.0

    def _publish(self, quantise=True):
        if self.mode != 0x03:
            return
        self._load_sample()

    def _load_sample(self):
        r = self.regs
        up = self.raw_pressure
        ut = self.raw_temp
        r[0x04] = up & 0xFF
        r[0x05] = (up >> 8) & 0xFF
        r[0x06] = up >> 16
        r[0x07] = ut & 0xFF
        r[0x08] = (ut >> 8) & 0xFF
        r[0x09] = ut >> 16
        r[0x03] |= 0x60  # drdy_press | drdy_temp

    def _after_read(self, reg, n):
        end = reg + n
        if reg <= 0x02 < end:
            self.regs[0x02] = 0  # ERR clears on read
        if reg < 0x0A and end > 0x04:
            self.regs[0x03] &= 0x9F  # reading data clears drdy

    def _write_reg(self, reg, value):
        if self._stuck:
            return
        r = self.regs
        if reg == 0x7E:
            if value == 0xB6:
                self.soft_resets += 1
                self._reset_registers()
            return
        if reg in (0x00, 0x02, 0x03) or 0x04 <= reg <= 0x09 or 0x31 <= reg <= 0x45:
            return  # read-only
        if reg == 0x1B:
            mode = (value >> 4) & 0x03
            if mode == 0x03:
                osr = r[0x1C]
                need = _bmp3_measurement_us(osr & 0x07, (osr >> 3) & 0x07)
                period = 5000 << (r[0x1D] & 0x1F)
                if need >= period:
                    r[0x02] |= 0x04  # conf_err; the part stays asleep
                    r[0x1B] = value & 0x03
                    return
                r[0x1B] = value & 0x33
                self._load_sample()
                return
            if mode in (0x01, 0x02):  # forced: one conversion, then sleep
                r[0x1B] = value & 0x03
                self._load_sample()
                return
            r[0x1B] = value & 0x03
            return
        r[reg] = value


class FakeBMP388(FakeBMP3xx):
    CHIP_ID = 0x50
    part = "BMP388"


class FakeBMP390(FakeBMP3xx):
    CHIP_ID = 0x60
    part = "BMP390"
    DEFAULT_NVM = bmp3_encode_nvm(BMP390_SYNTHETIC_CAL)


# -- BMP280 -------------------------------------------------------------------------------------

BMP280_FIELDS = ("T1", "T2", "T3", "P1", "P2", "P3", "P4", "P5", "P6", "P7", "P8", "P9")
# Datasheet (BST-BMP280-DS001) section 8 worked example.
BMP280_DATASHEET_CAL = {
    "T1": 27504, "T2": 26435, "T3": -1000, "P1": 36477, "P2": -10685, "P3": 3024,
    "P4": 2855, "P5": 140, "P6": -7, "P7": 15500, "P8": -14600, "P9": 6000,
}  # fmt: skip
BMP280_DATASHEET_RAW = (415148, 519888)  # (adc_P, adc_T)
BMP280_DATASHEET_RESULT = (128422, 2508, 25767233)  # t_fine, T (0.01 degC), int64 P (Q24.8)


def bmp280_encode_calib(cal):
    out = []
    for name in BMP280_FIELDS:
        out.extend(_u16le(cal[name]))
    return bytes(out)


def bmp280_t_fine(cal, adc_t):
    """Datasheet 32-bit temperature compensation: t_fine."""
    t1 = cal["T1"]
    var1 = (((adc_t >> 3) - (t1 << 1)) * cal["T2"]) >> 11
    d = (adc_t >> 4) - t1
    var2 = (((d * d) >> 12) * cal["T3"]) >> 14
    return var1 + var2


def bmp280_pressure_q24_8(cal, adc_p, t_fine):
    """Datasheet 64-bit pressure compensation: Pa in Q24.8 (0 when var1 == 0)."""
    c = cal
    var1 = t_fine - 128000
    var2 = var1 * var1 * c["P6"]
    var2 = var2 + ((var1 * c["P5"]) << 17)
    var2 = var2 + (c["P4"] << 35)
    var1 = ((var1 * var1 * c["P3"]) >> 8) + ((var1 * c["P2"]) << 12)
    var1 = (((1 << 47) + var1) * c["P1"]) >> 33
    if var1 == 0:
        return 0
    p = 1048576 - adc_p
    p = _cdiv(((p << 31) - var2) * 3125, var1)
    var1 = (c["P9"] * (p >> 13) * (p >> 13)) >> 25
    var2 = (c["P8"] * p) >> 19
    return ((p + var1 + var2) >> 8) + (c["P7"] << 4)


class FakeBMP280(_FakeBaro):
    """BMP280 register file (chip id 0x58; ``chip_id=0x60`` makes a BME280)."""

    CHIP_ID = 0x58
    part = "BMP280"

    def __init__(self, calibration=None, chip_id=None, noise_pa=0.0, noise_c=0.0, rng=None, seed=0):
        super().__init__(noise_pa, noise_c, rng, seed)
        self.cal = dict(BMP280_DATASHEET_CAL if calibration is None else calibration)
        self.chip_id = self.CHIP_ID if chip_id is None else chip_id
        self.soft_resets = 0
        self.published = (0x80000, 0x80000)
        self._reset_registers()
        self.set_truth(self.pressure_pa, self.temp_c)

    def _reset_registers(self):
        r = self.regs
        for i in range(256):
            r[i] = 0
        r[0x88 : 0x88 + 24] = bmp280_encode_calib(self.cal)
        r[0xD0] = self.chip_id
        r[0xF7] = 0x80
        r[0xFA] = 0x80

    @staticmethod
    def _bits(osrs_code):
        return 15 + min(osrs_code, 5)  # x1 16 bit ... x16 20 bit

    def _quantise(self, raw, osrs_code):
        if osrs_code == 0:
            return 0x80000
        step = 1 << (20 - self._bits(osrs_code))
        raw = (raw + (step >> 1)) // step * step
        return max(0, min(raw, (1 << 20) - step))

    def encode_temp(self, temp_c):
        cal = self.cal
        target = int(round(temp_c * 5120))
        return invert_monotonic(lambda a: bmp280_t_fine(cal, a), target, 0, (1 << 20) - 1)

    def encode_pressure(self, pressure_pa, raw_temp):
        cal = self.cal
        t_fine = bmp280_t_fine(cal, raw_temp)
        target = int(round(pressure_pa * 256))
        return invert_monotonic(lambda a: bmp280_pressure_q24_8(cal, a, t_fine), target, 0, (1 << 20) - 1)

    def compensated_pa(self, adc_p, adc_t):
        """The datasheet's 64-bit integer pressure for these raw words, in Pa."""
        return bmp280_pressure_q24_8(self.cal, adc_p, bmp280_t_fine(self.cal, adc_t)) / 256.0

    def quantise_temp(self, raw_temp):
        return self._quantise(raw_temp, (self.regs[0xF4] >> 5) & 0x07) if self.regs[0xF4] >> 5 else raw_temp

    def raw_step(self):
        code = (self.regs[0xF4] >> 2) & 0x07
        return 1 << (20 - self._bits(code)) if code else 1

    def _publish(self, quantise=True):
        if self.regs[0xF4] & 0x03:
            self._load_sample(quantise)

    def _load_sample(self, quantise=True):
        r = self.regs
        ctrl = r[0xF4]
        p = self.raw_pressure
        t = self.raw_temp
        if quantise:
            p = self._quantise(p, (ctrl >> 2) & 0x07)
            t = self._quantise(t, (ctrl >> 5) & 0x07)
        self.published = (p, t)
        r[0xF7] = p >> 12
        r[0xF8] = (p >> 4) & 0xFF
        r[0xF9] = (p & 0x0F) << 4
        r[0xFA] = t >> 12
        r[0xFB] = (t >> 4) & 0xFF
        r[0xFC] = (t & 0x0F) << 4

    def _write_reg(self, reg, value):
        if self._stuck:
            return
        if reg == 0xE0:
            if value == 0xB6:
                self.soft_resets += 1
                self._reset_registers()
            return
        if reg in (0xF4, 0xF5):
            self.regs[reg] = value
            if reg == 0xF4 and value & 0x03:
                self._load_sample()
                if value & 0x03 != 0x03:  # forced: back to sleep after one conversion
                    self.regs[0xF4] = value & 0xFC
            return
        # everything else (id, calibration, data, status) is read-only


# -- MS5611 -------------------------------------------------------------------------------------

MS5611_DATASHEET_C = (40127, 36924, 23317, 23282, 33464, 28312)  # C1..C6
MS5611_DATASHEET_RAW = (9085466, 8569150)  # (D1, D2)
MS5611_DATASHEET_RESULT = (2007, 100009)  # TEMP (0.01 degC), P (0.01 mbar = Pa)
MS5611_TYP_CONVERSION_US = (500, 1100, 2100, 4100, 8220)  # OSR 256..4096, datasheet typical


def ms5611_crc4(words):
    """AN520 CRC-4 over the 8 PROM words (the low nibble of word 7 excluded)."""
    n_rem = 0
    for cnt in range(16):
        w = words[cnt >> 1]
        if cnt == 15:
            w &= 0xFF00
        n_rem ^= (w & 0xFF) if cnt & 1 else (w >> 8)
        for _ in range(8):
            n_rem = ((n_rem << 1) ^ 0x3000) & 0xFFFF if n_rem & 0x8000 else (n_rem << 1) & 0xFFFF
    return (n_rem >> 12) & 0xF


def ms5611_compensate(c, d1, d2):
    """Datasheet first- and second-order compensation: (TEMP 0.01 degC, P Pa, P in Pa x 16)."""
    c1, c2, c3, c4, c5, c6 = c
    dt = d2 - (c5 << 8)
    temp = 2000 + ((dt * c6) >> 23)
    off = (c2 << 16) + ((c4 * dt) >> 7)
    sens = (c1 << 15) + ((c3 * dt) >> 8)
    if temp < 2000:
        t2 = (dt * dt) >> 31
        off2 = (5 * (temp - 2000) * (temp - 2000)) >> 1
        sens2 = (5 * (temp - 2000) * (temp - 2000)) >> 2
        if temp < -1500:
            off2 += 7 * (temp + 1500) * (temp + 1500)
            sens2 += (11 * (temp + 1500) * (temp + 1500)) >> 1
        temp -= t2
        off -= off2
        sens -= sens2
    p = (((d1 * sens) >> 21) - off) >> 15
    q4 = (d1 * sens - (off << 21)) >> 32
    return temp, p, q4


def ms5611_temp_fine(c, d2):
    """TEMP in 0.01 degC x 256 (the datasheet's TEMP before flooring, second order included)."""
    dt = d2 - (c[4] << 8)
    temp = (2000 << 8) + ((dt * c[5]) >> 15)
    if temp < (2000 << 8):
        temp -= ((dt * dt) >> 31) << 8
    return temp


class FakeMS5611(_FakeBaro):
    """MS5611-01BA03 command protocol. ``prom_crc_ok=False`` corrupts the PROM CRC nibble.

    ``clock_us``: optional callable returning microseconds; when given, an ADC read before the
    typical conversion time of the pending conversion returns 0, as on the real part.
    """

    part = "MS5611"

    def __init__(self, c=MS5611_DATASHEET_C, word0=0x0C50, serial=0x1A6, prom_crc_ok=True,
                 noise_pa=0.0, noise_c=0.0, rng=None, seed=0, clock_us=None):  # fmt: skip
        super().__init__(noise_pa, noise_c, rng, seed)
        self.c = tuple(c)
        words = [word0 & 0xFFFF] + [v & 0xFFFF for v in self.c] + [(serial & 0xFFF) << 4]
        crc = ms5611_crc4(words)
        if not prom_crc_ok:
            crc ^= 0x5
        words[7] |= crc
        self.prom = words
        self.clock_us = clock_us
        self.resets = 0
        self.conversions = 0
        self._pending = 0  # 0 none, 1 D1, 2 D2
        self._pending_osr = 0
        self._t_start = 0
        self._last_adc = [0, 0, 0]  # by kind: 1 = D1, 2 = D2
        self.set_truth(self.pressure_pa, self.temp_c)

    def encode_temp(self, temp_c):
        c = self.c
        target = int(round(temp_c * 100 * 256))
        return invert_monotonic(lambda d2: ms5611_temp_fine(c, d2), target, 0, (1 << 24) - 1)

    def encode_pressure(self, pressure_pa, raw_temp):
        c = self.c
        target = int(round(pressure_pa * 16))
        return invert_monotonic(lambda d1: ms5611_compensate(c, d1, raw_temp)[2], target, 0, (1 << 24) - 1)

    def compensated_pa(self, d1, d2):
        """The datasheet's pressure for these raw words, in Pa (with 4 fractional bits)."""
        return ms5611_compensate(self.c, d1, d2)[2] / 16.0

    def _publish(self, quantise=True):
        pass  # the ADC word is produced by the next conversion command

    def command(self, data):
        self._check_alive(False)
        self.writes += 1
        if len(data) != 1:
            return
        cmd = data[0]
        if cmd == 0x1E:
            if not self._stuck:
                self.resets += 1
                self._pending = 0
        elif 0x40 <= cmd <= 0x48 or 0x50 <= cmd <= 0x58:
            self.conversions += 1
            self._pending = 1 if cmd < 0x50 else 2
            self._pending_osr = (cmd & 0x0F) >> 1
            if self.clock_us is not None:
                self._t_start = self.clock_us()
        else:
            self._ptr = cmd

    def read_into(self, reg, buf):
        self._check_alive(True)
        self.reads += 1
        n = len(buf)
        if reg == 0x00:  # ADC read
            kind = self._pending
            self._pending = 0
            if kind == 0:
                v = 0
            elif self._stuck:
                v = self._last_adc[kind]  # a stuck part repeats its last word of that kind
            elif self.clock_us is not None and (
                self.clock_us() - self._t_start < MS5611_TYP_CONVERSION_US[self._pending_osr]
            ):
                v = 0  # read before the conversion ended: 0, and the conversion is lost
            else:
                v = self.raw_pressure if kind == 1 else self.raw_temp
                self._last_adc[kind] = v
            for i in range(n):
                buf[i] = (v >> (8 * (2 - i))) & 0xFF if i < 3 else 0
            return
        if 0xA0 <= reg <= 0xAE:
            w = self.prom[(reg - 0xA0) >> 1]
            for i in range(n):
                buf[i] = (w >> 8) & 0xFF if i == 0 else (w & 0xFF if i == 1 else 0)
            return
        for i in range(n):
            buf[i] = 0
