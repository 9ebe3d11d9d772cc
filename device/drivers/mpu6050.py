"""InvenSense MPU-6050 accelerometer (+-16 g) over I2C; the gyro is configured but not read.

Usage::

    from device.drivers.mpu6050 import MPU6050
    imu = MPU6050(i2c)              # 0x68 (AD0 low) or 0x69 (AD0 high)
    imu.read()                      # imu.accel_mmps2[0..2], imu.clipped, imu.clip_count

Settings (register values written by ``__init__``):

===================  ======================================================================
register             value
===================  ======================================================================
PWR_MGMT_1 0x6B      0x80 (device reset), 100 ms, then 0x01 (awake, clock = PLL on X gyro)
SMPLRT_DIV 0x19      0x00 (sample rate = 1 kHz gyro rate / 1)
CONFIG 0x1A          ``dlpf`` = 1 (default): accel bandwidth 184 Hz, delay 2.0 ms
                     (0: 260 Hz / 0 ms, 2: 94 Hz / 3.0 ms, 3: 44 Hz / 4.9 ms)
GYRO_CONFIG 0x1B     0x18 (+-2000 deg/s)
ACCEL_CONFIG 0x1C    0x18 (AFS_SEL = 3: +-16 g, 2048 LSB/g)
===================  ======================================================================

So the accelerometer registers refresh at 1 kHz with a 184 Hz low-pass; read them at the loop rate.
The MPU-6050 saturates at 16 g: a high-power motor's boost clips it, so ``clipped`` (any axis at
-32768 or 32767) and ``clip_count`` tell the flight code when to trust a high-g part instead.

``read()`` burst-reads ACCEL_XOUT_H..ACCEL_ZOUT_L (0x3B..0x40, big-endian int16) into ``raw`` and
stores the specific force in ``accel_mmps2`` (mm/s^2, +9807 on the axis pointing up at rest),
with 2048 LSB/g nominal (``scale_ng`` = 488 281 nano-g/LSB; override per unit, +-3 % between
units).
"""

from array import array

try:
    from micropython import const
except ImportError:  # CPython

    def const(x):
        return x


from . import accel_scale_q, chip_id_error, sleep_ms

_REG_SMPLRT_DIV = const(0x19)
_REG_CONFIG = const(0x1A)
_REG_GYRO_CONFIG = const(0x1B)
_REG_ACCEL_CONFIG = const(0x1C)
_REG_ACCEL_XOUT_H = const(0x3B)
_REG_PWR_MGMT_1 = const(0x6B)
_REG_WHO_AM_I = const(0x75)

_WHO_AM_I = const(0x68)
_RESET = const(0x80)
_CLK_PLL_X = const(0x01)
_FS_16G = const(0x18)
_FS_2000DPS = const(0x18)


class MPU6050:
    """MPU-6050 accelerometer at +-16 g (WHO_AM_I 0x68)."""

    def __init__(self, i2c, addr=0x68, dlpf=1, scale_ng=None):
        if not 0 <= dlpf <= 6:
            raise ValueError("MPU6050: dlpf must be 0..6")
        self.i2c = i2c
        self.addr = addr
        self.part = "MPU6050"
        self.range_g = 16
        self.rate_hz = 1000
        self.scale_ng = scale_ng if scale_ng is not None else 488281  # 1 g / 2048
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
            raise chip_id_error("MPU6050", addr, who, "0x68")
        self._write8(_REG_PWR_MGMT_1, _RESET)
        sleep_ms(100)
        self._write8(_REG_PWR_MGMT_1, _CLK_PLL_X)
        self._write8(_REG_SMPLRT_DIV, 0)
        self._write8(_REG_CONFIG, dlpf)
        self._write8(_REG_GYRO_CONFIG, _FS_2000DPS)
        self._write8(_REG_ACCEL_CONFIG, _FS_16G)

    def _read8(self, reg):
        self.i2c.readfrom_mem_into(self.addr, reg, self._b1)
        return self._b1[0]

    def _write8(self, reg, value):
        self._b1[0] = value
        self.i2c.writeto_mem(self.addr, reg, self._b1)

    def read(self):
        """One burst read of the accelerometer; updates ``raw``, ``accel_mmps2``, ``clipped``."""
        b = self._buf
        self.i2c.readfrom_mem_into(self.addr, _REG_ACCEL_XOUT_H, b)
        raw = self.raw
        out = self.accel_mmps2
        ki = self._ki
        kf = self._kf
        shift = self._shift
        half = self._half
        clipped = False
        for i in range(3):
            v = (b[2 * i] << 8) | b[2 * i + 1]
            if v & 0x8000:
                v -= 65536
            if v >= 32767 or v <= -32768:
                clipped = True
            raw[i] = v
            out[i] = v * ki + ((v * kf + half) >> shift)
        self.clipped = clipped
        if clipped:
            self.clip_count += 1
