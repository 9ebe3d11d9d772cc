"""``device.board.Sensors`` over recorded integers: no bus, no driver (allocation-free).

The per-sample measurements (tests/support/sil_measure.py on the unix and wasm32 MicroPython,
tools/armboard_guest.py on the emulated Cortex-M0) replay a run's sensor readings through a new
flight loop with it, to measure the firmware's own cost. Portable: MicroPython and CPython.
"""


class ReplaySensors:
    """The board's sensor interface, each ``read()`` taking the next recorded reading."""

    def __init__(self, pressures, accels, haves):
        self.p = pressures  # Pa x 16 per sample
        self.a = accels  # axial specific force, mm/s^2 per sample
        self.h = haves  # which sensors have a new reading, per sample
        self.i = 0
        self.pressure_q4_pa = 0
        self.temp_cdeg = 1500
        self.accel_mmps2 = 0
        self.have = 0
        self.baro_errors = 0
        self.accel_errors = 0

    def read(self):
        i = self.i
        self.pressure_q4_pa = self.p[i]
        self.accel_mmps2 = self.a[i]
        self.have = self.h[i]
        self.i = i + 1
