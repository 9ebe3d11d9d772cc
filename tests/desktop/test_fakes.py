"""The register-level fakes (desktop/fakes) on their own: bus semantics and fault injection, part
protocols, noise statistics, seeding, clipping, and that they run on MicroPython."""

import random

import numpy as np
import pytest

from desktop.hosts.micropython import run_micropython
from desktop.sim.fakes import (
    FakeADXL345,
    FakeADXL375,
    FakeBMP280,
    FakeBMP388,
    FakeI2CBus,
    FakeLSM6DSO,
    FakeLSM6DSO32,
    FakeMPU6050,
    FakeMS5611,
)
from desktop.sim.fakes import baro as fb
from device.drivers.bmp3xx import BMP3XX
from device.drivers.bmp280 import BMP280
from device.drivers.mpu6050 import MPU6050
from device.drivers.ms5611 import MS5611


def on_bus(addr, fake):
    bus = FakeI2CBus()
    bus.add(addr, fake)
    return bus


def _ms_collect(drv):
    drv.start()
    drv._t_start -= 100000  # pretend the conversion time has passed
    return drv.collect()


# == bus =============================================================================================


def test_bus_scan_pointer_and_unknown_address():
    bus = FakeI2CBus()
    bus.add(0x77, FakeBMP388())
    bus.add(0x53, FakeADXL375())
    assert bus.scan() == [0x53, 0x77]
    bus.nack(0x77)
    assert bus.scan() == [0x53]
    bus.nack(0x77, False)
    assert bus.writeto(0x77, b"\x00") == 1
    assert bus.readfrom(0x77, 1) == b"\x50"  # readfrom_into continues at the pointer
    assert bus.writeto(0x77, b"\x1d\x03") == 2  # pointer + data
    assert bus.readfrom_mem(0x77, 0x1D, 1) == b"\x03"
    with pytest.raises(OSError) as e:
        bus.readfrom_mem(0x42, 0, 1)
    assert e.value.errno == 19
    with pytest.raises(ValueError):
        bus.add(0x80, FakeBMP388())




# == fake noise statistics ===========================================================================


@pytest.mark.parametrize("fake_cls,sigma", [(FakeBMP388, 1.5), (FakeBMP280, 2.0), (FakeMS5611, 3.0)])
def test_baro_fake_noise_statistics(fake_cls, sigma):
    fake = fake_cls(noise_pa=sigma, noise_c=0.0, seed=7)
    addr = 0x76 if fake_cls is FakeBMP280 else 0x77
    if fake_cls is FakeBMP280:
        drv = BMP280(on_bus(addr, fake), osrs_p=16, osrs_t=2)
    elif fake_cls is FakeMS5611:
        drv = MS5611(on_bus(addr, fake), temp_every=1000000)
    else:
        drv = BMP3XX(on_bus(addr, fake))
    n = 1500
    out = np.empty(n)
    for i in range(n):
        fake.set_truth(80000.0, 10.0)
        if isinstance(drv, MS5611):
            _ms_collect(drv)
        else:
            drv.read()
        out[i] = drv.pressure_q4_pa / 16
    if isinstance(drv, MS5611):
        out = out[1:]  # the first conversion is the temperature
    assert abs(out.mean() - 80000.0) < 4 * sigma / np.sqrt(len(out)) + 0.05
    assert abs(out.std() / sigma - 1) < 0.08


def test_accel_fake_noise_statistics_and_bias():
    fake = FakeMPU6050(noise_mps2=0.2, bias_mps2=(0.5, 0.0, 0.0), seed=3)
    drv = MPU6050(on_bus(0x68, fake))
    xs = []
    for _ in range(2000):
        fake.set_truth((0.0, 0.0, 9.80665))
        drv.read()
        xs.append(drv.accel_mmps2[0])
    xs = np.array(xs) / 1000
    assert abs(xs.mean() - 0.5) < 0.02
    assert abs(xs.std() / 0.2 - 1) < 0.08


def test_fake_noise_is_seeded_and_accepts_random_random():
    def series(**kw):
        fake = FakeBMP388(noise_pa=1.0, **kw)
        vals = []
        for _ in range(20):
            fake.set_truth(90000, 20)
            vals.append(fake.raw_pressure)
        return vals

    assert series(seed=1) == series(seed=1) != series(seed=2)
    assert series(rng=random.Random(4)) == series(rng=random.Random(4))
    assert series(rng=np.random.default_rng(4)) == series(seed=4)


def test_baro_fake_clips_to_adc_range():
    fake = FakeBMP388()
    fake.set_truth(-5e6, 20)
    assert fake.raw_pressure == (1 << 24) - 1  # pressure falls with UP on this part
    fake.set_truth(5e6, 20)
    assert fake.raw_pressure == 0
    bmp280 = FakeBMP280()
    BMP280(on_bus(0x76, bmp280))
    bmp280.set_truth(1e7, 20)
    assert bmp280.published[0] == 0


def test_accel_data_frozen_until_configured():
    fake = FakeMPU6050()
    bus = on_bus(0x68, fake)
    fake.set_truth((0, 0, 9.80665))
    assert bus.readfrom_mem(0x68, 0x3B, 6) == bytes(6)  # asleep after power-up
    MPU6050(bus)
    assert bus.readfrom_mem(0x68, 0x3F, 2) == (2048).to_bytes(2, "big")




def test_device_fail_after_and_revive():
    fake = FakeBMP388()
    bus = on_bus(0x77, fake)
    fake.fail_after(2)
    bus.readfrom_mem(0x77, 0x00, 1)
    bus.readfrom_mem(0x77, 0x00, 1)
    with pytest.raises(OSError) as e:
        bus.readfrom_mem(0x77, 0x00, 1)
    assert e.value.errno == 5 and e.value.args[0] == 5 and fake.dead
    with pytest.raises(OSError):
        bus.writeto_mem(0x77, 0x1D, b"\x01")  # a dead device fails writes too
    fake.revive()
    assert bus.readfrom_mem(0x77, 0x00, 1) == b"\x50"


def test_stuck_register_file_ignores_writes_and_new_samples():
    fake = FakeBMP388()
    bus = on_bus(0x77, fake)
    BMP3XX(bus)
    fake.set_truth(90000, 10)
    frozen = bus.readfrom_mem(0x77, 0x04, 6)
    fake.stuck = True
    fake.set_truth(50000, 40)
    bus.writeto_mem(0x77, 0x1D, b"\x04")
    assert bus.readfrom_mem(0x77, 0x04, 6) == frozen
    assert bus.readfrom_mem(0x77, 0x03, 1)[0] & 0x60 == 0  # no drdy: nothing new, ever
    assert fake.regs[0x1D] == 0x02


def test_nack_errno_choice():
    bus = on_bus(0x68, FakeMPU6050())
    for errno in (19, 5, 110):
        bus.nack(0x68, True, errno=errno)
        with pytest.raises(OSError) as e:
            bus.readfrom_mem(0x68, 0x75, 1)
        assert e.value.errno == errno
    bus.nack(0x68, False)
    assert bus.readfrom_mem(0x68, 0x75, 1) == b"\x68"


# == part protocols ==================================================================================


def test_bmp3_fake_conf_err_soft_reset_and_forced_mode():
    fake = FakeBMP388()
    bus = on_bus(0x77, fake)
    bus.writeto_mem(0x77, 0x1C, b"\x05")  # x32 pressure
    bus.writeto_mem(0x77, 0x1D, b"\x00")  # 200 Hz: 66 ms conversion in a 5 ms period
    bus.writeto_mem(0x77, 0x1B, b"\x33")
    assert bus.readfrom_mem(0x77, 0x02, 1) == b"\x04"  # conf_err
    assert fake.mode == 0
    assert bus.readfrom_mem(0x77, 0x02, 1) == b"\x00"  # ERR clears on read
    bus.writeto_mem(0x77, 0x7E, b"\xb6")
    assert fake.soft_resets == 1 and fake.regs[0x1C] == 0x02
    fake.set_truth(80000, 0)  # asleep: the data registers keep the reset value
    assert bus.readfrom_mem(0x77, 0x04, 3) == b"\x00\x00\x80"
    bus.writeto_mem(0x77, 0x1B, b"\x13")  # forced: one conversion, back to sleep
    assert fake.mode == 0
    up = int.from_bytes(bus.readfrom_mem(0x77, 0x04, 3), "little")
    assert up == fake.raw_pressure and abs(fake.compensated_pa(up, fake.raw_temp) - 80000) < 0.02
    assert bus.readfrom_mem(0x77, 0x03, 1)[0] & 0x60 == 0  # drdy cleared by the data read


def test_bmp280_fake_quantisation_follows_osrs():
    fake = FakeBMP280()
    bus = on_bus(0x76, fake)
    for osrs_p, step in ((1, 16), (2, 8), (3, 4), (4, 2), (5, 1)):
        bus.writeto_mem(0x76, 0xF4, bytes([(1 << 5) | (osrs_p << 2) | 3]))
        fake.set_truth(95000.3, 21.0)
        assert fake.published[0] % step == 0 and fake.published[1] % 16 == 0
        assert fake.raw_step() == step
    bus.writeto_mem(0x76, 0xF4, bytes([(1 << 5) | (0 << 2) | 3]))  # pressure skipped
    fake.set_truth(95000.3, 21.0)
    assert fake.published[0] == 0x80000


def test_ms5611_fake_adc_protocol():
    now = [0]
    fake = FakeMS5611(clock_us=lambda: now[0])
    bus = on_bus(0x77, fake)
    fake.set_truth(100000, 20)
    adc = bytearray(3)
    bus.readfrom_mem_into(0x77, 0x00, adc)
    assert adc == bytes(3)  # no conversion started
    bus.writeto(0x77, b"\x48")  # D1, OSR 4096
    now[0] += 8000
    bus.readfrom_mem_into(0x77, 0x00, adc)
    assert adc == bytes(3)  # 8.0 ms < 8.22 ms: too early, conversion lost
    bus.writeto(0x77, b"\x48")
    now[0] += 8300
    bus.readfrom_mem_into(0x77, 0x00, adc)
    assert int.from_bytes(adc, "big") == fake.raw_pressure
    bus.readfrom_mem_into(0x77, 0x00, adc)
    assert adc == bytes(3)  # already read
    bus.writeto(0x77, b"\x50")  # D2, OSR 256
    now[0] += 600
    bus.readfrom_mem_into(0x77, 0x00, adc)
    assert int.from_bytes(adc, "big") == fake.raw_temp
    prom = [int.from_bytes(bus.readfrom_mem(0x77, 0xA0 + 2 * i, 2), "big") for i in range(8)]
    assert prom == fake.prom and prom[1:7] == list(fb.MS5611_DATASHEET_C)
    assert fb.ms5611_crc4(prom) == prom[7] & 0xF
    bus.writeto(0x77, b"\x1e")
    assert fake.resets == 1


def test_adxl345_fake_data_format_ranges():
    fake = FakeADXL345()
    bus = on_bus(0x53, fake)
    bus.writeto_mem(0x53, 0x2D, b"\x08")
    for fmt, lo, hi, counts_per_g in ((0x08, -512, 511, 256), (0x0B, -4096, 4095, 256),
                                      (0x00, -512, 511, 256), (0x03, -512, 511, 32)):  # fmt: skip
        bus.writeto_mem(0x53, 0x31, bytes([fmt]))
        assert fake.code_range() == (lo, hi)
        fake.set_truth((9.80665, -100.0, 0.0))
        assert fake.counts[0] == counts_per_g
        assert fake.counts[1] == max(lo, round(-100.0 / 9.80665 * counts_per_g))


def test_lsm6dso_fake_fs_table_and_reset():
    for fake_cls, codes in ((FakeLSM6DSO, (2, 16, 4, 8)), (FakeLSM6DSO32, (4, 32, 8, 16))):
        fake = fake_cls()
        bus = on_bus(0x6A, fake)
        for fs_code, fs_g in enumerate(codes):
            bus.writeto_mem(0x6A, 0x10, bytes([0x70 | (fs_code << 2)]))
            fake.set_truth((2 * fs_g * 9.80665, 0.5 * fs_g * 9.80665, 0.0))
            # nominal mg/LSB (0.061 for 2 g ...) make half scale 16393 counts, not 16384
            assert fake.counts[0] == 32767 and abs(fake.counts[1] - 16384) <= 20
        bus.writeto_mem(0x6A, 0x12, b"\x01")
        assert fake.regs[0x12] == 0x04 and fake.regs[0x10] == 0 and fake.resets == 1


def test_accel_fake_bias_scale_error_and_clipping():
    fake = FakeADXL375(bias_mps2=(0.0, 0.0, 4.9), scale_error=0.02)
    bus = on_bus(0x53, fake)
    bus.writeto_mem(0x53, 0x2D, b"\x08")
    fake.set_truth((100 * 9.80665, -300 * 9.80665, 9.80665))
    assert fake.counts[0] == round(102 / 0.049)
    assert fake.counts[1] == -4096
    assert fake.counts[2] == round((1.02 + 0.5) / 0.049)


# == MicroPython =====================================================================================


@pytest.mark.micropython
@pytest.mark.parametrize("interp", ["unix", "wasm32"])
def test_fakes_run_on_micropython(interp):
    code = (
        "from desktop.sim.fakes import FakeI2CBus, FakeBMP388, FakeBMP280, FakeMS5611, FakeADXL375\n"
        "from desktop.sim.fakes import baro as fb\n"
        "bus = FakeI2CBus()\n"
        "b = bus.add(0x77, FakeBMP388())\n"
        "b.set_truth(89874.6, 15.0)\n"
        "print(b.raw_pressure, b.raw_temp)\n"
        "p = bus.add(0x76, FakeBMP280())\n"
        "p.set_truth(89874.6, 15.0)\n"
        "print(p.raw_pressure, p.raw_temp)\n"
        "m = FakeMS5611()\n"
        "m.set_truth(89874.6, 15.0)\n"
        "print(m.raw_pressure, m.raw_temp, fb.ms5611_crc4(m.prom), m.prom[7] & 15)\n"
        "a = bus.add(0x53, FakeADXL375())\n"
        "bus.writeto_mem(0x53, 0x2D, b'\\x08')\n"
        "a.set_truth((1.0, -200.0, 3000.0))\n"
        "print(bus.readfrom_mem(0x53, 0x32, 6) == bytes([2, 0, 0x60, 0xfe, 0xff, 0x0f]))\n"
        "try:\n"
        "    bus.readfrom_mem(0x42, 0, 1)\n"
        "except OSError as e:\n"
        "    print('errno', e.args[0], e.errno)\n"
    )
    out = run_micropython(code, interp).split("\n")
    b, p, m = FakeBMP388(), FakeBMP280(), FakeMS5611()
    for f in (b, p, m):
        f.set_truth(89874.6, 15.0)
    assert out[0] == "%d %d" % (b.raw_pressure, b.raw_temp)
    assert out[1] == "%d %d" % (p.raw_pressure, p.raw_temp)
    assert out[2] == "%d %d %d %d" % (m.raw_pressure, m.raw_temp, m.prom[7] & 15, m.prom[7] & 15)
    assert out[3] == "True"
    assert out[4] == "errno 19 19"
