"""Register-level fakes of the board's I2C sensors, for desktop tests and simulations.

``FakeI2CBus`` stands in for ``machine.I2C``; the part fakes hold register files and turn a
physical truth into the raw bytes the real part would return (``set_truth``). The package only uses
features MicroPython also has, so the same fakes run on the unix and wasm32 MicroPython
interpreters (``desktop/hosts/micropython.py``) to measure the drivers' allocations.

Example::

    from desktop.sim.fakes import FakeI2CBus, FakeBMP388
    from device.drivers.bmp3xx import BMP3XX
    bus = FakeI2CBus()
    baro = bus.add(0x77, FakeBMP388(noise_pa=0.2))
    drv = BMP3XX(bus)
    baro.set_truth(89874.6, 15.0)
    drv.read()          # drv.pressure_q4_pa ~ 89874.6 * 16
"""

from .accel import FakeADXL345, FakeADXL375, FakeLSM6DSO, FakeLSM6DSO32, FakeMPU6050
from .baro import FakeBMP3xx, FakeBMP280, FakeBMP388, FakeBMP390, FakeMS5611
from .i2c_bus import FakeI2CBus, FakeI2CDevice

__all__ = [
    "FakeI2CBus",
    "FakeI2CDevice",
    "FakeBMP3xx",
    "FakeBMP388",
    "FakeBMP390",
    "FakeBMP280",
    "FakeMS5611",
    "FakeADXL375",
    "FakeADXL345",
    "FakeMPU6050",
    "FakeLSM6DSO",
    "FakeLSM6DSO32",
]
