"""The flight code on a real ARMv6-M MicroPython: MicroPython's qemu port built for a Cortex-M0
(tools/armboard.py), run under ``qemu-system-arm -icount shift=0``.

In every deployed form (frozen bytecode, frozen source, .mpy and .py loaded at run time) the
whole flight of tools/bench_step.py, the extreme flights of tests/shared/test_micropython_core.py and
the firmware's per-sample path (device/ on the software-in-the-loop fakes) run heap-locked (any
allocation raises MemoryError) and give the integer states CPython gives, sample by sample. The
full step stays within its instruction budget (instruction counts under icount are exact: this is
a regression guard, not a timing).

Without the toolchain these tests skip, saying how to install it; with APOGEE_REQUIRE_ARM=1
(.ci/run) they fail instead.
"""

import json
import os
import subprocess
import sys

import pytest

from desktop.hosts.sil.flightgen import Scenario
from desktop.hosts.sil.host import prepare
from tests.shared.test_micropython_core import FLIGHTS
from tools import armboard
from tools import armboard_guest as guest
from tools.bench_step import run_fc_flight, run_flight
from tools.synthetic_flight import make_flight

ARM = [pytest.mark.arm, pytest.mark.slow]
# One pytest-xdist worker runs this file in turn: the firmware builds, the mpy files and the board
# files share build/arm/ (tools/armboard.py), and each form's board boots once.
pytestmark = pytest.mark.xdist_group("arm")
BOARD = "m0"
# Budget of FlightComputer.step on the Cortex-M0, heap locked (guest instructions per sample):
# 93k mean and 107k worst measured; the margin is for the arbitration work to come.
FULL_STEP_MEAN_MAX = 115_000
FULL_STEP_WORST_MAX = 140_000
BENCH_RATE_HZ = 100
EXTREME = ("extreme_30km", "extreme_1000mps")
# The firmware path: 14 s of a 50 Hz board through apogee, the barometer dead from 12 s on (its
# OSError raised and caught inside the heap-locked sample).
FW_SAMPLES = 700
FW_SCENARIO = dict(duration_s=16, launch_s=1.0, boost_mps2=80.0, burn_s=1.0, seed=21, kill_baro_s=12.0)


def _require_toolchain():
    missing = armboard.toolchain_missing()
    if missing is None:
        return
    msg = "%s; these tests then run (APOGEE_REQUIRE_ARM=1 makes them required)" % missing
    if os.environ.get("APOGEE_REQUIRE_ARM") == "1":
        pytest.fail(msg)
    pytest.skip(msg)


def test_no_big_int_in_a_constant_tuple_of_the_firmware():
    # mpy-tool freezes such an int as a long-int object: every use of it allocates
    for rel in armboard.module_files():
        if rel.startswith(armboard.FIRMWARE_DIRS):
            assert armboard.big_tuple_ints(armboard.ROOT / rel) == [], rel


def test_big_tuple_ints_finds_them(tmp_path):
    src = tmp_path / "m.py"
    src.write_text("from micropython import const\n_K = const(9000)\nA = (1, -8193)\nB = ((2, _K),)\n"
                   "C = tuple([100000])\nD = (x, 99999)\n")
    assert armboard.big_tuple_ints(src) == [(3, -8193), (4, 9000)]


def test_frozen_tuple_long_ints_finds_only_those_in_tuples():
    c_text = ("static const mp_obj_int_t const_obj_shared_a_0_1 = {{&mp_type_int}, {.neg=0}};\n"
              "static const mp_obj_int_t const_obj_shared_a_2 = {{&mp_type_int}, {.neg=0}};\n"
              "static const mp_rom_obj_tuple_t const_obj_shared_a_0 = {{&mp_type_tuple}, 2, {\n"
              "    MP_ROM_INT(1),\n    MP_ROM_PTR(&const_obj_shared_a_0_1),\n}};\n")
    assert armboard.frozen_tuple_long_ints(c_text) == ["const_obj_shared_a_0_1"]


def test_profile_table_names_functions_that_exist_with_their_arity():
    # a row whose function was renamed, moved or re-signed is left out of --profile silently
    import importlib
    import inspect

    from shared.apogee import VelocityRule
    from shared.arbitration import Arbitration
    from shared.detector import Detector
    from shared.flight import FlightComputer
    from shared.health import SensorHealth
    from shared.kalman import Kalman
    from shared.padcal import PadCalibration

    classes = {"fc": FlightComputer, "health": SensorHealth, "pad": PadCalibration, "arb": Arbitration,
               "det": Detector, "kf": Kalman, "rule": VelocityRule}
    for label, where, name, arity in guest.PROFILE:
        if where.startswith("module:"):
            fn = getattr(importlib.import_module(where[7:]), name, None)
            params = arity
        else:
            fn = getattr(classes[where], name, None)
            params = arity + 1  # self
        assert fn is not None, label
        assert len(inspect.signature(fn).parameters) == params, label


@pytest.fixture(scope="session")
def fw_files(tmp_path_factory):
    """board.json, config.json and the frames of the firmware-path flight, as board files."""
    work = tmp_path_factory.mktemp("armboard_sil")
    prepare(work, Scenario(**FW_SCENARIO))
    return work, {"sil/" + name: (work / name).read_bytes()
                  for name in ("board.json", "config.json", "frames.bin")}


@pytest.fixture(scope="module", params=armboard.FORMS)
def board(request, fw_files):
    """A booted Cortex-M0 with the modules in one form; (form, Board, instructions per tick, overhead)."""
    _require_toolchain()
    form = request.param
    b = armboard.start(BOARD, form, files=fw_files[1])
    try:
        scale = armboard.calibrate(b)
        overhead = armboard.parse_ints(b.exec("from tools import armboard_guest as g\n"
                                              "g.print_ints('overhead', [g.overhead()])"), "overhead")[0]
        yield form, b, scale, overhead
    finally:
        b.close()


@pytest.mark.arm
@pytest.mark.slow
def test_calibration_counts_instructions(board):
    _form, _b, scale, overhead = board
    assert 60 < scale < 65  # the micro:bit model's SysTick runs at 16 MHz: 62.5 ns, one per instruction
    assert 0 < overhead * scale < 2000


_BENCH_RUNS = {}  # form -> (states, phases, states_cpy, phases_cpy, summary): one qemu run per form


def _bench_flight(board):
    form, b, scale, overhead = board
    if form not in _BENCH_RUNS:
        out = b.exec("from tools.synthetic_flight import make_flight\n"
                     "g.dump('fc', g.count_fc(make_flight(rate_hz=%d), True))\n" % BENCH_RATE_HZ)
        ticks, phases, states = armboard.parse_dump(out, "fc")
        _t, phases_cpy, states_cpy = guest.count_fc(make_flight(rate_hz=BENCH_RATE_HZ), False)
        _BENCH_RUNS[form] = (states, phases, states_cpy, phases_cpy,
                             armboard.summarise(ticks, phases, overhead, scale))
    return _BENCH_RUNS[form]


@pytest.mark.arm
@pytest.mark.slow
def test_bench_flight_heap_locked_bit_identical(board):
    states, phases, states_cpy, phases_cpy, s = _bench_flight(board)
    assert len(states) == len(states_cpy)
    for i in range(0, len(states), 4):
        assert states[i:i + 4] == list(states_cpy[i:i + 4]), "first difference at sample %d" % (i // 4)
    assert phases == list(phases_cpy)
    assert set(s["phases"]) == {"pad", "boost", "coast", "descent"}


@pytest.mark.arm
@pytest.mark.slow
def test_bench_flight_within_instruction_budget(board):
    form = board[0]
    s = _bench_flight(board)[4]
    print("\n%s: full step %.0f mean, %.0f worst instructions per sample" % (form, s["mean"], s["worst"]))
    assert s["mean"] <= FULL_STEP_MEAN_MAX, form
    assert s["worst"] <= FULL_STEP_WORST_MAX, form


@pytest.mark.arm
@pytest.mark.slow
@pytest.mark.parametrize("table,rule", [("project", "velocity"), ("project", "seed")])
def test_bench_flight_detector_heap_locked_bit_identical(board, table, rule):
    _form, b, _scale, _overhead = board
    flight = make_flight(rate_hz=BENCH_RATE_HZ)
    enable_from = len(flight[0]) // 4
    out = b.exec("from tools.bench_step import run_flight\n"
                 "from tools.synthetic_flight import make_flight\n"
                 "fired, states = run_flight(%r, %r, make_flight(rate_hz=%d), %d, True)\n"
                 "g.print_ints('fired', [fired])\ng.print_ints('states', states)\n"
                 % (table, rule, BENCH_RATE_HZ, enable_from))
    fired_cpy, states_cpy = run_flight(table, rule, flight, enable_from, False)
    assert armboard.parse_ints(out, "fired") == [fired_cpy]
    assert armboard.parse_ints(out, "states") == list(states_cpy)


@pytest.mark.arm
@pytest.mark.slow
@pytest.mark.parametrize("name", EXTREME)
def test_extreme_flights_heap_locked_bit_identical(board, name):
    _form, b, _scale, _overhead = board
    kwargs, enable_from = FLIGHTS[name]
    flight = make_flight(**kwargs)
    out = b.exec("import gc\ngc.collect()\n"
                 "from tools.bench_step import run_flight, run_fc_flight\n"
                 "from tools.synthetic_flight import make_flight\n"
                 "flight = make_flight(**%r)\n"
                 "fired, states = run_flight('project', 'velocity', flight, %d, True)\n"
                 "g.print_ints('fired', [fired])\ng.print_ints('states', states)\n"
                 "states = None\ngc.collect()\n"
                 "g.print_ints('fc', run_fc_flight(flight, True, None))\n"
                 "flight = None\ngc.collect()\n" % (kwargs, enable_from))
    fired_cpy, states_cpy = run_flight("project", "velocity", flight, enable_from, False)
    assert armboard.parse_ints(out, "fired") == [fired_cpy]
    assert armboard.parse_ints(out, "states") == list(states_cpy)
    assert armboard.parse_ints(out, "fc") == list(run_fc_flight(flight, False, None))


@pytest.mark.arm
@pytest.mark.slow
def test_firmware_sample_path_heap_locked_bit_identical(board, fw_files):
    # last on each board: it installs the fake machine, time and micropython modules
    form, b, scale, overhead = board
    work, _files = fw_files
    out = b.exec("g.dump('fw', g.firmware_path('/ram/sil/frames.bin', '/ram/sil', %d, True))" % FW_SAMPLES)
    ticks, phases, states = armboard.parse_dump(out, "fw")
    code = ("from tools import armboard_guest as g\n"
            "g.dump('fw', g.firmware_path(%r, %r, %d, False))\n" % (str(work / "frames.bin"), str(work),
                                                                     FW_SAMPLES))
    env = dict(os.environ, PYTHONPATH=str(armboard.ROOT))  # the guest changes directory
    proc = subprocess.run([sys.executable, "-c", code], cwd=str(armboard.ROOT), capture_output=True,
                          text=True, timeout=600, env=env)
    assert proc.returncode == 0, proc.stderr[-2000:]
    _t, phases_cpy, states_cpy = armboard.parse_dump(proc.stdout, "fw")
    assert phases == phases_cpy
    for i in range(0, len(states), 6):
        assert states[i:i + 6] == states_cpy[i:i + 6], "first difference at sample %d" % (i // 6)
    assert max(states[4::6]) >= 4  # the flight reached the drogue
    assert states[-1] > 0  # the dead barometer's errors were raised, caught and counted under the lock
    s = armboard.summarise(ticks, phases, overhead, scale)
    print("\n%s: firmware sample() %.0f mean, %.0f worst instructions" % (form, s["mean"], s["worst"]))
    print(json.dumps(s["phases"]))
