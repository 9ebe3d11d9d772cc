"""Sensor drivers (device/drivers) against their register-level fakes (desktop/fakes), on CPython.

Datasheet worked examples in both directions, driver + fake round trips over the flight envelope,
the integer compensation against the vendors' 64-bit reference with every intermediate checked to
stay inside the 31-bit small-int range of a 32-bit board, identity checks and bus faults.
The MicroPython runs are in test_drivers_micropython.py, the smbus2 adapter in
test_drivers_smbus.py.
"""

import random

import numpy as np
import pytest

from desktop.sim.fakes import (
    FakeADXL345,
    FakeADXL375,
    FakeBMP280,
    FakeBMP388,
    FakeBMP390,
    FakeI2CBus,
    FakeLSM6DSO,
    FakeLSM6DSO32,
    FakeMPU6050,
    FakeMS5611,
)
from desktop.sim.fakes import baro as fb
from device.drivers import CalibrationError, ChipIdError, SensorConfigError, SensorError, mul_shr
from device.drivers import ms5611 as ms5611_mod
from device.drivers.adxl375 import ADXL345, ADXL375
from device.drivers.bmp3xx import BMP3XX
from device.drivers.bmp280 import BMP280
from device.drivers.lsm6dso import LSM6DSO
from device.drivers.mpu6050 import MPU6050
from device.drivers.ms5611 import MS5611, crc4

G_MMPS2 = 9806.65
SMALL_INT = 1 << 30


# -- a checking int: any intermediate outside +-2**30 raises ---------------------------------------


class CheckedInt(int):
    """int whose arithmetic results must stay in MicroPython's 31-bit small-int range."""

    def __new__(cls, v):
        v = int(v)
        if not -SMALL_INT <= v < SMALL_INT:
            raise OverflowError("intermediate %d outside +-2**30" % v)
        return int.__new__(cls, v)


def _checked(name):
    op = getattr(int, name)

    def method(self, *args):
        r = op(int(self), *(int(a) for a in args))
        return r if r is NotImplemented else CheckedInt(r)

    return method


for _name in ("__add__ __radd__ __sub__ __rsub__ __mul__ __rmul__ __rshift__ __rrshift__ __lshift__ "
              "__rlshift__ __and__ __rand__ __or__ __ror__ __xor__ __rxor__ __neg__ __abs__ "
              "__floordiv__ __rfloordiv__ __mod__ __rmod__").split():  # fmt: skip
    setattr(CheckedInt, _name, _checked(_name))


def check_ints(driver):
    """Wrap every int attribute of ``driver`` (calibration, state) in CheckedInt."""
    for k, v in list(vars(driver).items()):
        if type(v) is int:
            setattr(driver, k, CheckedInt(v))
    return driver


def test_checked_int_catches_overflow():
    with pytest.raises(OverflowError):
        CheckedInt(1 << 20) * (1 << 10)
    assert CheckedInt(3) * 4 == 12


def test_mul_shr_is_exact_floor_and_small():
    rng = random.Random(5)
    for _ in range(20000):
        a = rng.randrange(-(1 << 28) + 1, 1 << 28)
        b = rng.randrange(-(1 << 28) + 1, 1 << 28)
        s = rng.randrange(28, 45)
        assert mul_shr(CheckedInt(a), CheckedInt(b), s) == (a * b) >> s
    for _ in range(20000):
        a = rng.randrange(-(1 << 24), 1 << 24)
        b = rng.randrange(0, 1 << 16)
        s = rng.randrange(14, 28)
        if abs((a * b) >> s) < (1 << 29):
            assert mul_shr(CheckedInt(a), CheckedInt(b), s) == (a * b) >> s


def on_bus(addr, fake):
    bus = FakeI2CBus()
    bus.add(addr, fake)
    return bus


# == BMP388 / BMP390 =================================================================================


def test_bmp388_real_part_example_decodes():
    """NVM and raw sample of a real BMP388 (elixir-sensors/bmp3xx tests): 100876.006 Pa, 30.4993 C."""
    fake = FakeBMP388()
    drv = BMP3XX(on_bus(0x77, fake))
    up, ut = fb.BMP388_EXAMPLE_RAW
    fake.set_raw(up, ut)
    drv.read()
    p_ref, t_ref = fb.BMP388_EXAMPLE_RESULT
    assert (drv.raw_pressure, drv.raw_temp) == (up, ut)
    assert abs(drv.pressure_q4_pa / 16 - p_ref) <= 1 / 16
    assert drv.temp_cdeg == round(t_ref * 100)  # 3050 (Bosch truncates to 3049)
    bosch = fb.bmp3_pressure_cpa(fake.cal, up, fb.bmp3_t_lin(fake.cal, ut))
    assert bosch == 10087600
    assert abs(drv.pressure_q4_pa - bosch * 16 / 100) <= 1
    p_float, t_float = fb.bmp3_float(fake.cal, up, ut)
    assert abs(p_float - p_ref) < 1e-6 and abs(t_float - t_ref) < 1e-9


def test_bmp388_real_part_example_encodes():
    fake = FakeBMP388()
    p_ref, t_ref = fb.BMP388_EXAMPLE_RESULT
    fake.set_truth(p_ref, t_ref)
    up, ut = fb.BMP388_EXAMPLE_RAW
    assert abs(fake.raw_temp - ut) <= 2
    assert abs(fake.raw_pressure - up) <= 2
    assert abs(fake.compensated_pa(fake.raw_pressure, fake.raw_temp) - p_ref) <= 0.015


def test_bmp3_nvm_parse_round_trip():
    cal = fb.bmp3_parse_nvm(fb.BMP388_EXAMPLE_NVM)
    assert cal == {"t1": 27427, "t2": 18776, "t3": -10, "p1": -164, "p2": -2866, "p3": 35,
                   "p4": 0, "p5": 25578, "p6": 31086, "p7": -13, "p8": -10, "p9": 17322, "p10": 18,
                   "p11": -60}  # fmt: skip
    assert fb.bmp3_encode_nvm(cal) == fb.BMP388_EXAMPLE_NVM


def _random_bmp3_cal(rng):
    return {
        "t1": 27427 + rng.randint(-2000, 2000), "t2": 18776 + rng.randint(-2000, 2000),
        "t3": rng.randint(-20, 0), "p1": rng.randint(-1000, 1000), "p2": rng.randint(-4000, -1000),
        "p3": rng.randint(0, 60), "p4": rng.randint(-10, 10), "p5": rng.randint(20000, 30000),
        "p6": rng.randint(25000, 35000), "p7": rng.randint(-30, 0), "p8": rng.randint(-20, 5),
        "p9": rng.randint(10000, 25000), "p10": rng.randint(0, 40), "p11": rng.randint(-100, -20),
    }  # fmt: skip


@pytest.mark.slow  # sweeps of the compensation
def test_bmp3_compensation_within_31_bits_and_bosch():
    """Random calibrations around a real part, -45..90 C, 0.5..130 kPa: <= 0.0625 Pa from Bosch."""
    rng = random.Random(11)
    checked = 0
    for _ in range(40):
        cal = _random_bmp3_cal(rng)
        fake = FakeBMP3xxCal(cal)
        drv = check_ints(BMP3XX(on_bus(0x77, fake)))
        for ut in range(0, 1 << 24, 1 << 19):
            t_lin = fb.bmp3_t_lin(cal, ut)
            if not -45 * 65536 < t_lin < 90 * 65536:
                continue
            for up in range(0, 1 << 24, 1 << 19):
                ref_cpa = fb.bmp3_pressure_cpa(cal, up, t_lin)
                if not 50000 < ref_cpa < 13000000:
                    continue
                drv.compensate(CheckedInt(up), CheckedInt(ut))
                assert abs(drv.pressure_q4_pa - ref_cpa * 16 / 100) <= 1.0, (cal, up, ut)
                assert abs(drv.temp_cdeg - fb.bmp3_temperature_cdeg(t_lin)) <= 1
                checked += 1
    assert checked > 5000


class FakeBMP3xxCal(fb.FakeBMP3xx):
    CHIP_ID = 0x50

    def __init__(self, cal, **kw):
        super().__init__(calibration=cal, **kw)


@pytest.mark.parametrize("fake_cls", [FakeBMP388, FakeBMP390])
def test_bmp3_round_trip_grid(fake_cls):
    fake = fake_cls()
    drv = BMP3XX(on_bus(0x77, fake))
    assert drv.part == fake.part
    for p in np.linspace(1000, 110000, 23):
        for t in range(-20, 61, 10):
            fake.set_truth(p, t)
            drv.read()
            tol = fake.resolution_pa / 2 + 0.01 + 1 / 16
            assert abs(drv.pressure_q4_pa / 16 - p) <= tol, (p, t)
            assert abs(drv.temp_cdeg - t * 100) <= 1


def test_bmp3_configuration_registers():
    fake = FakeBMP388()
    drv = BMP3XX(on_bus(0x77, fake))
    assert fake.soft_resets == 1
    assert (fake.regs[0x1C], fake.regs[0x1D], fake.regs[0x1F], fake.regs[0x1B]) == (0x03, 0x02, 0x00, 0x33)
    assert drv.measurement_us == 18939 and drv.period_us == 20000
    drv100 = BMP3XX(on_bus(0x76, fake := FakeBMP390()), addr=0x76, osr_p=2, odr_hz=100, iir=3)
    assert (fake.regs[0x1C], fake.regs[0x1D], fake.regs[0x1F]) == (0x01, 0x01, 0x04)
    assert drv100.period_us == 10000


def test_bmp3_fresh_flag_follows_drdy():
    fake = FakeBMP388()
    drv = BMP3XX(on_bus(0x77, fake))
    fake.set_truth(95000, 15)
    drv.read()
    assert drv.fresh
    drv.read()
    assert not drv.fresh  # no new conversion: same values, flagged
    assert abs(drv.pressure_q4_pa / 16 - 95000) < 0.1


def test_bmp3_rejects_too_long_conversion():
    with pytest.raises(SensorConfigError, match="longer than the 20000 us ODR period"):
        BMP3XX(on_bus(0x77, FakeBMP388()), osr_p=16)
    with pytest.raises(ValueError):
        BMP3XX(on_bus(0x77, FakeBMP388()), osr_p=3)
    with pytest.raises(ValueError):
        BMP3XX(on_bus(0x77, FakeBMP388()), odr_hz=60)


def test_bmp3_fake_sets_conf_err_and_driver_reports_it():
    fake = FakeBMP388()
    bus = on_bus(0x77, fake)
    bus.writeto_mem(0x77, 0x1C, b"\x05")  # x32 pressure
    bus.writeto_mem(0x77, 0x1D, b"\x00")  # 200 Hz
    bus.writeto_mem(0x77, 0x1B, b"\x33")
    assert bus.readfrom_mem(0x77, 0x02, 1) == b"\x04"
    assert fake.mode == 0
    assert bus.readfrom_mem(0x77, 0x02, 1) == b"\x00"  # ERR clears on read

    class AlwaysConfErr(FakeBMP388):
        def _write_reg(self, reg, value):
            super()._write_reg(reg, value)
            if reg == 0x1B:
                self.regs[0x02] |= 0x04

    with pytest.raises(SensorConfigError, match=r"BMP388 at 0x77: ERR=0x04"):
        BMP3XX(on_bus(0x77, AlwaysConfErr()))


def test_bmp3_chip_id_errors():
    with pytest.raises(ChipIdError) as e:
        BMP3XX(on_bus(0x77, FakeBMP388(chip_id=0x58)))
    assert str(e.value) == "BMP388/BMP390 at 0x77: chip id 0x58, expected 0x50 (BMP388) or 0x60 (BMP390)"
    assert isinstance(e.value, SensorError) and isinstance(e.value, RuntimeError)


def test_bmp3_blank_nvm():
    with pytest.raises(CalibrationError):
        BMP3XX(on_bus(0x77, FakeBMP388(calibration=bytes(21))))


# == BMP280 ==========================================================================================


def test_bmp280_datasheet_example_decodes():
    fake = FakeBMP280()
    drv = BMP280(on_bus(0x76, fake))
    adc_p, adc_t = fb.BMP280_DATASHEET_RAW
    fake.set_raw(adc_p, adc_t)
    drv.read()
    t_fine, temp, p64 = fb.BMP280_DATASHEET_RESULT
    assert (drv.raw_pressure, drv.raw_temp) == (adc_p, adc_t)
    assert drv.t_fine == t_fine == fb.bmp280_t_fine(fake.cal, adc_t)
    assert drv.temp_cdeg == temp
    assert fb.bmp280_pressure_q24_8(fake.cal, adc_p, t_fine) == p64
    assert drv.pressure_q4_pa >> 4 == 100653
    assert abs(drv.pressure_q4_pa - p64 / 16) <= 1


def test_bmp280_undefined_compensation_is_an_error_not_pressure_0():
    # the datasheet's code returns 0 Pa when its var1 <= 0 (it would divide by zero); a flight
    # computer would take 0 Pa for 31 km. The driver raises instead, and keeps its last pressure
    from device.drivers import ReadingError

    fake = FakeBMP280()
    drv = BMP280(on_bus(0x76, fake))
    fake.set_raw(*fb.BMP280_DATASHEET_RAW)
    drv.read()
    good = drv.pressure_q4_pa
    drv._p2x8 = -(1 << 30)  # a calibration term that drives var1 below 0 at this temperature
    with pytest.raises(ReadingError):
        drv.read()
    assert drv.pressure_q4_pa == good != 0


def test_bmp280_datasheet_example_encodes():
    fake = FakeBMP280()
    BMP280(on_bus(0x76, fake), osrs_p=16, osrs_t=16)  # 20-bit output words: no quantisation
    t_fine, _, p64 = fb.BMP280_DATASHEET_RESULT
    fake.set_truth(p64 / 256, t_fine / 5120)
    adc_p, adc_t = fb.BMP280_DATASHEET_RAW
    assert abs(fake.raw_temp - adc_t) <= 1
    assert abs(fake.raw_pressure - adc_p) <= 1
    assert fake.published == (fake.raw_pressure, fake.raw_temp)


@pytest.mark.slow  # sweeps of the compensation
def test_bmp280_compensation_within_31_bits_and_int64():
    rng = random.Random(12)
    checked = 0
    for _ in range(40):
        cal = {"T1": rng.randint(19000, 35000), "T2": rng.randint(22000, 30000),
               "T3": rng.randint(-3000, -1000), "P1": rng.randint(30000, 42000),
               "P2": rng.randint(-12970, -8000), "P3": rng.randint(-5000, 8000),
               "P4": rng.randint(-10000, 18000), "P5": rng.randint(-500, 1100),
               "P6": rng.randint(-1000, 1000), "P7": rng.randint(-32768, 32767),
               "P8": rng.randint(-30000, 10000), "P9": rng.randint(-10000, 30000)}  # fmt: skip
        drv = check_ints(BMP280(on_bus(0x76, FakeBMP280(calibration=cal))))
        for adc_t in range(0, 1 << 20, 1 << 15):
            t_fine = fb.bmp280_t_fine(cal, adc_t)
            if not -4000 <= (t_fine * 5 + 128) >> 8 <= 8500:
                continue
            for adc_p in range(0, 1 << 20, 1 << 15):
                ref = fb.bmp280_pressure_q24_8(cal, adc_p, t_fine) / 256
                if not 500 < ref < 130000:
                    continue
                drv.compensate(CheckedInt(adc_p), CheckedInt(adc_t))
                assert drv.t_fine == t_fine
                assert abs(drv.pressure_q4_pa / 16 - ref) <= 0.04 + 1 / 32, (cal, adc_p, adc_t)
                checked += 1
    assert checked > 5000


def test_bmp280_round_trip_grid_and_quantisation():
    fake = FakeBMP280()
    drv = BMP280(on_bus(0x76, fake))  # x4: 18-bit pressure, x1: 16-bit temperature
    assert (fake.regs[0xF4], fake.regs[0xF5]) == (0x2F, 0x00)
    for p in np.linspace(1000, 110000, 23):
        for t in range(-20, 61, 10):
            fake.set_truth(p, t)
            drv.read()
            assert drv.raw_pressure % 4 == 0 and drv.raw_temp % 16 == 0
            tol = fake.resolution_pa / 2 + 0.05 + 1 / 16
            # the 16-bit temperature (0.05 C steps here) also moves the pressure by up to ~0.1 Pa
            assert abs(drv.pressure_q4_pa / 16 - p) <= tol + 0.15, (p, t)
            assert abs(drv.temp_cdeg - t * 100) <= 6


def test_bmp280_chip_ids():
    with pytest.raises(ChipIdError, match="BMP280 at 0x76: chip id 0x50, expected 0x58"):
        BMP280(on_bus(0x76, FakeBMP280(chip_id=0x50)))
    assert BMP280(on_bus(0x76, FakeBMP280(chip_id=0x60))).part == "BME280"


# == MS5611 ==========================================================================================


def _ms_collect(drv):
    drv.start()
    drv._t_start -= 100000  # pretend the conversion time has passed
    return drv.collect()


def test_ms5611_datasheet_example_decodes():
    fake = FakeMS5611()
    drv = MS5611(on_bus(0x77, fake))
    assert drv.prom[1:7] == list(fb.MS5611_DATASHEET_C)
    fake.set_raw(*fb.MS5611_DATASHEET_RAW)
    assert _ms_collect(drv) is False  # temperature first
    assert _ms_collect(drv) is True
    assert drv.temp_cdeg == 2007
    assert drv.pressure_q4_pa >> 4 == 100009
    assert drv.pressure_q4_pa == 1600145  # 100009.07 Pa
    drv.read()  # blocking path, same result
    assert (drv.temp_cdeg, drv.pressure_q4_pa) == (2007, 1600145)


def test_ms5611_datasheet_example_encodes():
    fake = FakeMS5611()
    fake.set_truth(1600145 / 16, 20.0798)
    d1, d2 = fb.MS5611_DATASHEET_RAW
    assert abs(fake.raw_temp - d2) <= 4
    assert abs(fake.raw_pressure - d1) <= 4
    assert fb.ms5611_compensate(fake.c, fake.raw_pressure, fake.raw_temp)[:2] == (2007, 100009)


def test_ms5611_compensation_bit_exact_and_31_bits():
    """Any PROM, any D1, D2 with -40..85 C: bit-identical to the datasheet integer algorithm."""
    rng = random.Random(13)
    checked = 0
    for k in range(60):
        c = tuple(rng.randint(1, 65535) for _ in range(6)) if k % 2 else tuple(
            min(65535, max(1, v + rng.randint(-8000, 8000))) for v in fb.MS5611_DATASHEET_C)
        drv = check_ints(MS5611(on_bus(0x77, FakeMS5611(c=c))))
        for _ in range(30):
            d2 = rng.randrange(1 << 24)
            temp = fb.ms5611_compensate(c, 0, d2)[0]
            if not -4000 <= temp <= 8500:
                continue
            for _ in range(10):
                d1 = rng.randrange(1 << 24)
                ref_t, ref_p, ref_q4 = fb.ms5611_compensate(c, d1, d2)
                drv.compensate(CheckedInt(d1), CheckedInt(d2))
                assert (drv.temp_cdeg, drv.pressure_q4_pa) == (ref_t, ref_q4)
                assert drv.pressure_q4_pa >> 4 == ref_p
                checked += 1
    assert checked > 2000


def test_ms5611_round_trip_grid():
    fake = FakeMS5611()
    drv = MS5611(on_bus(0x77, fake), temp_every=1)
    for p in np.linspace(1000, 110000, 23):
        for t in range(-20, 61, 10):
            fake.set_truth(p, t)
            _ms_collect(drv)  # temperature
            assert _ms_collect(drv)
            assert abs(drv.pressure_q4_pa / 16 - p) <= 1 / 16 + 1 / 32, (p, t)
            assert abs(drv.temp_cdeg - t * 100) <= 1


def test_ms5611_prom_crc():
    assert crc4(FakeMS5611().prom) == FakeMS5611().prom[7] & 0xF
    with pytest.raises(CalibrationError, match=r"MS5611 at 0x77: PROM CRC"):
        MS5611(on_bus(0x77, FakeMS5611(prom_crc_ok=False)))
    with pytest.raises(CalibrationError, match="PROM reads all"):
        MS5611(on_bus(0x77, FakeMS5611(c=(0, 0, 0, 0, 0, 0))))


def test_ms5611_two_phase_schedule_and_timing(monkeypatch):
    now = [0]
    clock = lambda: now[0]  # noqa: E731
    monkeypatch.setattr(ms5611_mod, "ticks_us", clock)
    fake = FakeMS5611(clock_us=clock)
    bus = on_bus(0x77, fake)
    drv = MS5611(bus)  # OSR 4096: 9040 us, one temperature per 4 pressures
    assert drv.conversion_us == 9040 and fake.resets == 1
    fake.set_truth(90000, 5)
    kinds = []
    for _ in range(10):
        drv.start()
        reads = fake.reads
        now[0] += 5000
        assert not drv.ready() and drv.collect() is False
        assert fake.reads == reads  # not ready: the bus is not touched
        now[0] += 5000
        kinds.append("P" if drv.collect() else "T")
    assert "".join(kinds) == "TPPPPTPPPP"
    assert abs(drv.pressure_q4_pa / 16 - 90000) < 0.1 and drv.temp_cdeg == 500
    assert fake.conversions == 10 and drv.dropped == 0
    # an ADC read before the conversion ended returns 0: counted, no update
    drv._state = 1
    drv._since_temp = 0
    bus.writeto(0x77, b"\x48")
    drv._t_start = now[0] - 10000  # the driver believes it waited, the part has not finished
    assert drv.collect() is False and drv.dropped == 1


def test_ms5611_blocking_read_waits():
    fake = FakeMS5611()
    drv = MS5611(on_bus(0x77, fake), osr=1024)
    fake.set_truth(101325, 21.5)
    drv.read()
    assert abs(drv.pressure_q4_pa / 16 - 101325) < 0.1 and drv.temp_cdeg == 2150
    assert fake.conversions == 2


# == accelerometers ==================================================================================


def _accel_grid(range_g):
    return np.linspace(-1.1 * range_g, 1.1 * range_g, 45) * 9.80665


def _check_accel(drv, fake, lsb_mmps2, code_min, code_max):
    for a in _accel_grid(drv.range_g):
        fake.set_truth((a, -a / 3, 9.80665))
        drv.read()
        want = round(a * 1000 / lsb_mmps2)
        want = max(code_min, min(code_max, want))
        assert drv.raw[0] == want
        assert abs(drv.accel_mmps2[0] - want * lsb_mmps2) <= 1.0
        assert abs(drv.accel_mmps2[2] - G_MMPS2) <= lsb_mmps2 / 2 + 1
        assert drv.clipped == (want in (code_min, code_max))
        if abs(a * 1000) < code_max * lsb_mmps2:
            assert abs(drv.accel_mmps2[0] - a * 1000) <= lsb_mmps2 / 2 + 1
            assert np.sign(drv.accel_mmps2[1]) == -np.sign(a) or abs(a) < lsb_mmps2 / 1000


def test_adxl375_scale_sign_and_clipping():
    fake = FakeADXL375()
    drv = ADXL375(on_bus(0x53, fake))
    assert (fake.regs[0x2C], fake.regs[0x31], fake.regs[0x2D], fake.regs[0x38]) == (0x0D, 0x0B, 0x08, 0)
    assert drv.range_g == 200 and fake.rate_hz == 800
    _check_accel(drv, fake, 49 * 9.80665, -4096, 4095)
    n = drv.clip_count
    fake.set_truth((0, 0, 250 * 9.80665))
    drv.read()
    assert drv.clipped and drv.clip_count == n + 1 and drv.raw[2] == 4095


def test_adxl345_scale_sign_and_clipping():
    fake = FakeADXL345()
    drv = ADXL375(on_bus(0x53, fake), part="ADXL345")
    assert drv.range_g == 16 and fake.regs[0x31] == 0x0B
    _check_accel(drv, fake, 9806.65 / 256, -4096, 4095)
    assert ADXL345(on_bus(0x1D, FakeADXL345()), addr=0x1D).part == "ADXL345"


def test_adxl_wrong_part_is_caught_by_the_1g_rest_check():
    """DEVID is 0xE5 on both: only |a| at rest tells an ADXL345 from an ADXL375 (DESIGN.md D4)."""
    def rest_g(fake, part):
        drv = ADXL375(on_bus(0x53, fake), part=part)
        fake.set_truth((0.0, 0.0, 9.80665))
        drv.read()
        return sum(v * v for v in drv.accel_mmps2) ** 0.5 / G_MMPS2

    assert abs(rest_g(FakeADXL375(), "ADXL375") - 1) < 0.05
    assert abs(rest_g(FakeADXL345(), "ADXL345") - 1) < 0.01
    assert rest_g(FakeADXL345(), "ADXL375") > 10  # 345 read as 375: ~12.5 g at rest
    assert rest_g(FakeADXL375(), "ADXL345") < 0.1  # 375 read as 345: ~0.08 g at rest


def test_mpu6050_scale_sign_and_clipping():
    fake = FakeMPU6050()
    drv = MPU6050(on_bus(0x68, fake))
    assert fake.resets == 1
    assert (fake.regs[0x6B], fake.regs[0x19], fake.regs[0x1A], fake.regs[0x1C]) == (0x01, 0, 1, 0x18)
    _check_accel(drv, fake, 9806.65 / 2048, -32768, 32767)


@pytest.mark.parametrize(
    "fake_cls,part,fs_g", [(FakeLSM6DSO, "LSM6DSO", 16), (FakeLSM6DSO32, "LSM6DSO32", 32)]
)
def test_lsm6dso_scale_sign_and_clipping(fake_cls, part, fs_g):
    fake = fake_cls()
    drv = LSM6DSO(on_bus(0x6A, fake), part=part)
    assert (fake.regs[0x10], fake.regs[0x11], fake.regs[0x12]) == (0x74, 0x00, 0x44)
    assert drv.range_g == fs_g
    _check_accel(drv, fake, (0.488 if fs_g == 16 else 0.976) * 9.80665, -32768, 32767)


@pytest.mark.parametrize("make,fake", [
    (lambda bus: ADXL375(bus, addr=0x53), FakeADXL375(chip_id=0x00)),
    (lambda bus: ADXL375(bus, addr=0x53, part="ADXL345"), FakeMPU6050()),
    (lambda bus: MPU6050(bus, addr=0x53), FakeADXL375()),
    (lambda bus: LSM6DSO(bus, addr=0x53), FakeLSM6DSO(chip_id=0x6B)),
])  # fmt: skip
def test_accel_chip_id_errors(make, fake):
    with pytest.raises(ChipIdError, match=r"at 0x53: chip id 0x.., expected 0x"):
        make(on_bus(0x53, fake))


def test_accel_chip_id_messages():
    with pytest.raises(ChipIdError) as e:
        ADXL375(on_bus(0x53, FakeADXL375(chip_id=0xE6)))
    assert str(e.value) == "ADXL375 at 0x53: chip id 0xe6, expected 0xe5 (ADXL345/ADXL375)"
    with pytest.raises(ChipIdError) as e:
        MPU6050(on_bus(0x68, FakeMPU6050(chip_id=0x70)))
    assert str(e.value) == "MPU6050 at 0x68: chip id 0x70, expected 0x68"


# == bus faults ======================================================================================


def _all_drivers():
    return [
        (0x77, FakeBMP388, BMP3XX),
        (0x76, FakeBMP280, BMP280),
        (0x77, FakeMS5611, lambda bus: MS5611(bus)),
        (0x53, FakeADXL375, ADXL375),
        (0x68, FakeMPU6050, MPU6050),
        (0x6A, FakeLSM6DSO, LSM6DSO),
    ]


def _read(drv):
    drv.read()


@pytest.mark.parametrize("addr,fake_cls,drv_cls", _all_drivers())
def test_missing_device_is_enodev(addr, fake_cls, drv_cls):
    bus = FakeI2CBus()
    bus.add(0x10, fake_cls())  # something else on the bus
    with pytest.raises(OSError) as e:
        drv_cls(bus)
    assert e.value.errno == 19


@pytest.mark.parametrize("addr,fake_cls,drv_cls", _all_drivers())
def test_nack_and_dead_device_propagate(addr, fake_cls, drv_cls):
    fake = fake_cls()
    bus = on_bus(addr, fake)
    drv = drv_cls(bus)
    _read(drv)
    bus.nack(addr, True)
    with pytest.raises(OSError) as e:
        _read(drv)
    assert e.value.errno == 19
    bus.nack(addr, True, errno=110)
    with pytest.raises(OSError) as e:
        _read(drv)
    assert e.value.errno == 110
    bus.nack(addr, False)
    _read(drv)
    fake.fail_after(1)
    with pytest.raises(OSError) as e:
        for _ in range(3):
            _read(drv)
    assert e.value.errno == 5 and fake.dead
    with pytest.raises(OSError):
        _read(drv)  # stays dead
    fake.revive()
    _read(drv)


@pytest.mark.parametrize("addr,fake_cls,drv_cls", _all_drivers())
def test_stuck_device_repeats_last_value(addr, fake_cls, drv_cls):
    fake = fake_cls()
    drv = drv_cls(on_bus(addr, fake))
    accel = hasattr(drv, "accel_mmps2")

    def truth(i):
        return ((1.0 + i, 2.0, 9.0),) if accel else (97000 - 1000 * i, 12 + i)

    def output():
        return list(drv.accel_mmps2) if accel else (drv.pressure_q4_pa, drv.temp_cdeg)

    fake.set_truth(*truth(0))
    drv.read()
    before = output()
    fake.stuck = True
    for i in range(1, 4):
        fake.set_truth(*truth(i))
        drv.read()
        assert output() == before
    fake.stuck = False
    fake.set_truth(*truth(5))
    drv.read()
    assert output() != before
