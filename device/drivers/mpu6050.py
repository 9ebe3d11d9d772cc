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

from . import BIG_ENDIAN, Accelerometer, const, sleep_ms

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


class MPU6050(Accelerometer):
    """MPU-6050 accelerometer at +-16 g (WHO_AM_I 0x68)."""

    def __init__(self, i2c, addr=0x68, dlpf=1, scale_ng=None):
        if not 0 <= dlpf <= 6:
            raise ValueError("MPU6050: dlpf must be 0..6")
        # 488281 nano-g/LSB = 1 g / 2048 (AFS_SEL = 3)
        super().__init__(i2c, addr, "MPU6050", 16, 1000, scale_ng, 488281, -32768, 32767)
        self._check_id(_REG_WHO_AM_I, (_WHO_AM_I,), "MPU6050", "0x68")
        self._write8(_REG_PWR_MGMT_1, _RESET)
        sleep_ms(100)
        self._write8(_REG_PWR_MGMT_1, _CLK_PLL_X)
        self._write8(_REG_SMPLRT_DIV, 0)
        self._write8(_REG_CONFIG, dlpf)
        self._write8(_REG_GYRO_CONFIG, _FS_2000DPS)
        self._write8(_REG_ACCEL_CONFIG, _FS_16G)

    def read(self):
        """One burst read of ACCEL_XOUT_H..ACCEL_ZOUT_L; updates ``raw``, ``accel_mmps2``,
        ``clipped``."""
        self._read_accel(_REG_ACCEL_XOUT_H, BIG_ENDIAN)
