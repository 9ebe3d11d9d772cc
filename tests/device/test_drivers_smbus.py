"""desktop/hosts/smbus_i2c.py: the machine.I2C adapter over smbus2, with smbus2.SMBus mocked.

The mock turns each ``i2c_rdwr`` transaction into calls on a FakeI2CBus, so the real drivers run
end to end through the adapter and the real ``smbus2.i2c_msg`` structures (no hardware here).
"""

import ctypes
from array import array

import pytest
import smbus2

from desktop.hosts.smbus_i2c import SMBusI2C
from desktop.sim.fakes import FakeADXL375, FakeBMP388, FakeI2CBus, FakeMS5611
from device.drivers.adxl375 import ADXL375
from device.drivers.bmp3xx import BMP3XX
from device.drivers.ms5611 import MS5611


class MockSMBus:
    """Stands in for smbus2.SMBus: records transactions and serves them from a FakeI2CBus."""

    instances = []

    def __init__(self, bus=None, force=False):
        self.bus_number = bus
        self.fake = FakeI2CBus()
        self.log = []
        self.closed = False
        self.fail = None
        MockSMBus.instances.append(self)

    def close(self):
        self.closed = True

    def i2c_rdwr(self, *msgs):
        self.log.append([(m.addr, m.flags, bytes(m) if not m.flags & smbus2.smbus2.I2C_M_RD else m.len)
                         for m in msgs])  # fmt: skip
        if self.fail is not None:
            raise self.fail
        if len(msgs) == 2 and not msgs[0].flags and msgs[1].flags & smbus2.smbus2.I2C_M_RD:
            reg = bytes(msgs[0])
            assert len(reg) == 1 and msgs[0].addr == msgs[1].addr
            buf = bytearray(msgs[1].len)
            self.fake.readfrom_mem_into(msgs[1].addr, reg[0], buf)
            ctypes.memmove(msgs[1].buf, bytes(buf), len(buf))
        elif len(msgs) == 1 and msgs[0].flags & smbus2.smbus2.I2C_M_RD:
            buf = bytearray(msgs[0].len)
            self.fake.readfrom_into(msgs[0].addr, buf)
            ctypes.memmove(msgs[0].buf, bytes(buf), len(buf))
        elif len(msgs) == 1:
            self.fake.writeto(msgs[0].addr, bytes(msgs[0]))
        else:
            raise AssertionError("unexpected transaction %r" % (msgs,))


@pytest.fixture
def smbus(monkeypatch):
    MockSMBus.instances.clear()
    monkeypatch.setattr(smbus2, "SMBus", MockSMBus)
    i2c = SMBusI2C(1)
    mock = MockSMBus.instances[-1]
    assert mock.bus_number == 1
    return i2c, mock


def test_readfrom_mem_into_is_one_combined_transaction(smbus):
    i2c, mock = smbus
    mock.fake.add(0x77, FakeBMP388())
    buf = bytearray(3)
    assert i2c.readfrom_mem_into(0x77, 0x00, buf) is None
    assert buf[0] == 0x50
    assert mock.log == [[(0x77, 0, b"\x00"), (0x77, smbus2.smbus2.I2C_M_RD, 3)]]
    assert i2c.readfrom_mem(0x77, 0x31, 2) == bytes([0x23, 0x6B])
    words = array("h", [0, 0])  # machine.I2C fills any buffer, counting bytes
    i2c.readfrom_mem_into(0x77, 0x31, words)
    assert words[0] == 0x6B23


def test_writes(smbus):
    i2c, mock = smbus
    fake = mock.fake.add(0x77, FakeBMP388())
    i2c.writeto_mem(0x77, 0x1D, bytearray(b"\x03"))
    assert mock.log[-1] == [(0x77, 0, b"\x1d\x03")]
    assert fake.regs[0x1D] == 0x03
    assert i2c.writeto(0x77, b"\x1c\x05") == 2
    assert fake.regs[0x1C] == 0x05
    assert i2c.writeto(0x77, b"\x00") == 1
    assert i2c.readfrom(0x77, 1) == b"\x50"
    buf = bytearray(1)
    i2c.readfrom_into(0x77, buf)
    assert buf == b"\x00"  # pointer advanced to 0x01


def test_errors_are_oserror_and_addrsize_checked(smbus):
    i2c, mock = smbus
    with pytest.raises(OSError) as e:
        i2c.readfrom_mem(0x42, 0, 1)  # the fake bus: nothing at 0x42
    assert e.value.errno == 19
    mock.fail = OSError(121, "Remote I/O error")
    with pytest.raises(OSError) as e:
        i2c.writeto(0x42, b"\x00")
    assert e.value.errno == 121
    with pytest.raises(ValueError):
        i2c.readfrom_mem_into(0x77, 0, bytearray(1), addrsize=16)


def test_scan_and_close(smbus):
    i2c, mock = smbus
    mock.fake.add(0x53, FakeADXL375())
    mock.fake.add(0x77, FakeBMP388())
    assert i2c.scan() == [0x53, 0x77]
    with i2c:
        pass
    assert mock.closed
    i2c.close()  # idempotent


def test_drivers_run_over_the_adapter(smbus):
    i2c, mock = smbus
    baro = mock.fake.add(0x77, FakeBMP388())
    acc = mock.fake.add(0x53, FakeADXL375())
    drv = BMP3XX(i2c)
    baro.set_truth(87654.3, 7.5)
    drv.read()
    assert abs(drv.pressure_q4_pa / 16 - 87654.3) < 0.1 and drv.temp_cdeg == 750
    a = ADXL375(i2c)
    acc.set_truth((0.0, -9.80665 * 3, 9.80665 * 50))
    a.read()
    assert list(a.raw) == [0, -61, 1020]
    ms_bus = MockSMBus(1)
    ms = ms_bus.fake.add(0x76, FakeMS5611())
    i2c.__dict__["_bus"] = ms_bus
    m = MS5611(i2c, addr=0x76, osr=256)
    ms.set_truth(70000.0, -10.0)
    m.read()
    assert abs(m.pressure_q4_pa / 16 - 70000.0) < 0.1 and m.temp_cdeg == -1000
    assert [(0x76, 0, b"\x1e")] in ms_bus.log  # RESET is a bare one-byte write
