"""Register-level fake accelerometers: ADXL375, ADXL345, MPU6050, LSM6DSO, LSM6DSO32.

``set_truth(accel_mps2_xyz)`` takes the specific force on the three sensor axes in m/s^2 (+9.81 on
the axis pointing up at rest) and stores the raw counts the part would output in its data
registers, for the scale selected by the part's own configuration registers:

    counts = clip(round((a * (1 + scale_error) + bias + noise) / lsb), code_min, code_max)

with ``lsb`` in m/s^2 (g = 9.80665), Gaussian ``noise_mps2`` per axis (seeded numpy Generator or
``random.Random`` via ``rng=`` / ``seed=``; one draw per ``set_truth``), a constant ``bias_mps2``
and the full-scale clipping of the part's code range. ``counts`` holds the last raw values.

Protocols modelled: identity register; ADXL POWER_CTL Measure bit (data registers frozen at 0
until set), BW_RATE, DATA_FORMAT (ADXL345 range and FULL_RES select scale and code range; the
ADXL375 is fixed at 49 mg/LSB, 13 bit); MPU6050 PWR_MGMT_1 (SLEEP after reset, DEVICE_RESET),
ACCEL_CONFIG AFS_SEL, big-endian data; LSM6DSO CTRL1_XL ODR (0 = power-down) and the
non-monotonic FS table, CTRL3_C SW_RESET (self-clearing). Not modelled: FIFO, interrupts, self
test, gyro output, offset registers.
"""

from shared.physics import G0_MPS2 as G0

from .i2c_bus import FakeI2CDevice, default_rng, gauss


def _round(x):
    return int(x + 0.5) if x >= 0 else -int(-x + 0.5)


class _FakeAccel(FakeI2CDevice):
    CHIP_ID_REG = 0x00
    CHIP_ID = 0x00
    DATA_REG = 0x00
    BIG_ENDIAN = False

    def __init__(self, chip_id=None, noise_mps2=0.0, bias_mps2=(0.0, 0.0, 0.0), scale_error=0.0,
                 rng=None, seed=0):  # fmt: skip
        super().__init__()
        self.chip_id = self.CHIP_ID if chip_id is None else chip_id
        self.noise_mps2 = noise_mps2
        self.bias_mps2 = tuple(float(b) for b in bias_mps2)
        self.scale_error = scale_error
        self._rng = rng
        self._seed = seed
        self.truth_mps2 = (0.0, 0.0, G0)
        self.counts = [0, 0, 0]
        self.resets = 0
        self._reset_registers()
        self.set_truth(self.truth_mps2)

    @property
    def rng(self):
        if self._rng is None:
            self._rng = default_rng(self._seed)
        return self._rng

    # per part
    def _reset_registers(self):
        r = self.regs
        for i in range(256):
            r[i] = 0
        r[self.CHIP_ID_REG] = self.chip_id

    def lsb_g(self):
        """Current scale, g per LSB."""
        raise NotImplementedError

    def code_range(self):
        return -32768, 32767

    def measuring(self):
        return True

    def set_truth(self, accel_mps2_xyz):
        """One sample of the specific force (m/s^2, three axes) into the data registers."""
        a = [float(accel_mps2_xyz[i]) for i in range(3)]
        self.truth_mps2 = tuple(a)
        lsb = self.lsb_g() * G0
        lo, hi = self.code_range()
        for i in range(3):
            v = a[i] * (1.0 + self.scale_error) + self.bias_mps2[i]
            if self.noise_mps2:
                v += gauss(self.rng, self.noise_mps2)
            self.counts[i] = max(lo, min(hi, _round(v / lsb)))
        if not self._stuck:
            self._publish()

    def _publish(self):
        if not self.measuring():
            return
        r = self.regs
        base = self.DATA_REG
        for i in range(3):
            v = self.counts[i] & 0xFFFF
            if self.BIG_ENDIAN:
                r[base + 2 * i] = v >> 8
                r[base + 2 * i + 1] = v & 0xFF
            else:
                r[base + 2 * i] = v & 0xFF
                r[base + 2 * i + 1] = v >> 8


# -- ADXL375 / ADXL345 --------------------------------------------------------------------------


class FakeADXL375(_FakeAccel):
    """ADXL375: +-200 g, 13-bit, 49 mg/LSB nominal (``scale_ng`` sets this unit's true scale)."""

    part = "ADXL375"
    CHIP_ID = 0xE5
    DATA_REG = 0x32

    def __init__(self, scale_ng=49000000, **kw):
        self.scale_ng = scale_ng
        super().__init__(**kw)

    def _reset_registers(self):
        super()._reset_registers()
        self.regs[0x2C] = 0x0A  # BW_RATE reset: 100 Hz

    def lsb_g(self):
        return self.scale_ng * 1e-9

    def code_range(self):
        return -4096, 4095

    def measuring(self):
        return bool(self.regs[0x2D] & 0x08)

    @property
    def rate_hz(self):
        return 3200.0 / (1 << (0x0F - (self.regs[0x2C] & 0x0F)))

    def _write_reg(self, reg, value):
        if self._stuck or reg == 0x00 or 0x32 <= reg <= 0x37:
            return
        self.regs[reg] = value
        if reg in (0x2D, 0x31):
            self.set_truth(self.truth_mps2)


class FakeADXL345(FakeADXL375):
    """ADXL345: DATA_FORMAT range/FULL_RES choose 3.9 mg/LSB (full res) or 10-bit scaling."""

    part = "ADXL345"

    def __init__(self, **kw):
        super().__init__(scale_ng=3906250, **kw)

    def lsb_g(self):
        fmt = self.regs[0x31]
        rng = fmt & 0x03
        if fmt & 0x08:
            return self.scale_ng * 1e-9
        return self.scale_ng * 1e-9 * (1 << rng)

    def code_range(self):
        fmt = self.regs[0x31]
        if fmt & 0x08:
            half = 512 << (fmt & 0x03)  # 10..13 bit
            return -half, half - 1
        return -512, 511


# -- MPU6050 ------------------------------------------------------------------------------------


class FakeMPU6050(_FakeAccel):
    """MPU-6050: WHO_AM_I 0x68, asleep after reset, AFS_SEL 2/4/8/16 g, big-endian data."""

    part = "MPU6050"
    CHIP_ID_REG = 0x75
    CHIP_ID = 0x68
    DATA_REG = 0x3B
    BIG_ENDIAN = True

    def _reset_registers(self):
        super()._reset_registers()
        self.regs[0x6B] = 0x40  # SLEEP

    def lsb_g(self):
        return 1.0 / (16384 >> ((self.regs[0x1C] >> 3) & 0x03))

    def measuring(self):
        return not self.regs[0x6B] & 0x40

    def _write_reg(self, reg, value):
        if self._stuck or reg == 0x75 or 0x3B <= reg <= 0x48:
            return
        if reg == 0x6B and value & 0x80:
            self.resets += 1
            self._reset_registers()
            return
        self.regs[reg] = value
        if reg in (0x6B, 0x1C):
            self.set_truth(self.truth_mps2)


# -- LSM6DSO / LSM6DSO32 ------------------------------------------------------------------------


class FakeLSM6DSO(_FakeAccel):
    """LSM6DSO: WHO_AM_I 0x6C, FS_XL codes 00 2 g, 01 16 g, 10 4 g, 11 8 g, LE data at 0x28."""

    part = "LSM6DSO"
    CHIP_ID_REG = 0x0F
    CHIP_ID = 0x6C
    DATA_REG = 0x28
    FS_MG_PER_LSB = (0.061, 0.488, 0.122, 0.244)

    def _reset_registers(self):
        super()._reset_registers()
        self.regs[0x12] = 0x04  # CTRL3_C reset: IF_INC

    def lsb_g(self):
        return self.FS_MG_PER_LSB[(self.regs[0x10] >> 2) & 0x03] * 1e-3

    def measuring(self):
        return bool(self.regs[0x10] >> 4)

    def _write_reg(self, reg, value):
        if self._stuck or reg == 0x0F or 0x20 <= reg <= 0x2D:
            return
        if reg == 0x12 and value & 0x01:
            self.resets += 1
            self._reset_registers()  # SW_RESET clears itself
            return
        self.regs[reg] = value
        if reg == 0x10:
            self.set_truth(self.truth_mps2)


class FakeLSM6DSO32(FakeLSM6DSO):
    """LSM6DSO32: same id, FS_XL codes 00 4 g, 01 32 g, 10 8 g, 11 16 g."""

    part = "LSM6DSO32"
    FS_MG_PER_LSB = (0.122, 0.976, 0.244, 0.488)
