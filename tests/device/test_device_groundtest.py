"""Ground test, bench flight and boot on real MicroPython (unix port) with the fake machine.

The ground test (device/groundtest.py) must refuse unless disarmed and idle, want the channel
name typed again and a second confirmation when continuity shows an igniter, drive the pin low in
a ``finally`` (Ctrl-C), and bound the pulse by a hardware timer that works even when the code
that raised the pin never lowers it. The bench flight (device/benchflight.py) must print the same
events at the same samples as the desktop replay of the same flight CSV.
"""

import json
import shutil

import pytest

from desktop.hosts.micropython import REPO_ROOT, run_micropython
from tests.support.boot_run import boot_pin_states
from tests.support.groundtest_guest import run_groundtest
from tools.deploy import bench_file

pytestmark = pytest.mark.micropython

PICO = REPO_ROOT / "device" / "boards" / "pico.json"
ALTOS = REPO_ROOT / "tests" / "data" / "flights" / "altos" / "2012-09-29-serial-341-flight-005.csv"

def _workdir(tmp_path):
    wd = tmp_path / "board"
    wd.mkdir()
    shutil.copy(PICO, wd / "board.json")
    return wd


def _run(tmp_path, body):
    wd = _workdir(tmp_path)
    return run_groundtest(wd, body), wd


def test_ground_test_refusals_and_pulse(tmp_path):
    res, _wd = _run(tmp_path, """
out["no_confirm"] = attempt(channel="drogue", ms=50)
out["wrong_confirm"] = attempt(channel="drogue", ms=50, confirm="main")
out["too_long"] = attempt(channel="drogue", ms=5000, confirm="drogue")
out["bad_channel"] = attempt(channel="both", ms=50, confirm="both")
fake_machine.set_input(22, 0)                      # arming switch on
out["armed"] = attempt(channel="drogue", ms=50, confirm="drogue")
fake_machine.set_input(22, 1)
open("armed.flag", "w").write("switch")           # a reset while armed
out["flag"] = attempt(channel="drogue", ms=50, confirm="drogue")
os.remove("armed.flag")
fake_machine.ADC_VALUES[26] = 40000                # an igniter on the drogue channel
out["igniter"] = attempt(channel="drogue", ms=50, confirm="drogue")
out["igniter_ok"] = attempt(channel="drogue", ms=50, confirm="drogue", igniter=LIVE)
fake_machine.ADC_VALUES[26] = 0
out["main"] = attempt(channel="main", ms=120, confirm="main")
""")
    for key in ("no_confirm", "wrong_confirm", "too_long", "bad_channel", "armed", "flag", "igniter"):
        assert "refused" in res[key], key
    assert "type the channel name again" in res["no_confirm"]["refused"]
    assert "arming input is on" in res["armed"]["refused"]
    assert "armed.flag" in res["flag"]["refused"]
    assert "igniter connected" in res["igniter"]["refused"]
    ok = res["igniter_ok"]
    assert ok["took"] == 50
    assert ok["pins"] == [[0, 16, 1], [50000, 16, 0]]  # only the chosen channel, exactly 50 ms
    assert res["main"]["pins"] == [[0, 17, 1], [120000, 17, 0]]


def test_ground_test_ctrl_c_and_hardware_bound(tmp_path):
    res, _wd = _run(tmp_path, """
# Ctrl-C over mpremote 20 ms into the pulse: the finally drives the pin low at once
_tick = fake_time.hook
def ctrl_c(now, t_stop=[fake_time.elapsed + 20000]):
    _tick(now)
    if t_stop[0] and now >= t_stop[0]:
        t_stop[0] = 0
        raise KeyboardInterrupt
fake_time.hook = ctrl_c
out["ctrl_c"] = attempt(channel="drogue", ms=500, confirm="drogue")
fake_time.hook = _tick
# code that raised a pin and never lowers it (hung, or interrupted before its finally):
# the hardware timer armed by Pyro.guard drives it low
from device import board
from device.pyro import Pyro
b = board.load("board.json")
p = Pyro(machine, b)
n0 = fake_machine.EV_N[0]
t0 = fake_time.elapsed
assert p.guard(1, 80)
p.main_pin.value(1)
fake_time.advance(200000)
out["guard"] = [(t - t0, pin, l) for (t, pin, l) in fake_machine.pin_events()[n0:]]
""")
    assert res["ctrl_c"]["took"] == "interrupted"
    assert res["ctrl_c"]["pins"] == [[0, 16, 1], [20000, 16, 0]]
    assert res["guard"] == [[0, 17, 1], [80000, 17, 0]]


def test_boot_py_falls_back_to_board_json(tmp_path):
    """Without pyro_pins.txt, boot.py reads the pins from board.json; pins that were high (a soft
    reset in the middle of something) go low."""
    wd = _workdir(tmp_path)
    assert boot_pin_states(wd) == [0, 0, 1]


def test_bench_flight_matches_desktop_replay(tmp_path):
    wd = _workdir(tmp_path)
    result, _config = bench_file(ALTOS, None, wd / "bench.bin")
    expected = [[e.index, e.event] for e in result.events]
    decisions = [n for _i, n in expected if n not in ("health", "mode")]
    assert decisions[:3] == ["launch", "burnout", "apogee"]
    code = """
import json, os
from desktop.hosts.sil import fake_machine, fake_time
fake_machine.install()
os.chdir(%r)
from device.benchflight import main
events = main("bench.bin", speed=0, verbose=False)
print("RESULT", json.dumps({"events": [[i, n] for (i, n, _t, _a) in events],
                            "pins": [e for e in fake_machine.pin_events() if e[1] in (16, 17)]}))
""" % str(wd)
    out = run_micropython(code, "unix")
    res = json.loads(out.split("RESULT ")[1])
    assert res["events"] == expected
    levels = [(p, lvl) for _t, p, lvl in res["pins"]]
    assert levels[:2] == [(16, 1), (16, 0)] and (17, 1) in levels  # drogue pulsed, then main
    assert levels[-1][1] == 0


def test_bench_flight_refused_when_armed(tmp_path):
    wd = _workdir(tmp_path)
    bench_file(ALTOS, None, wd / "bench.bin")
    code = """
import os
from desktop.hosts.sil import fake_machine
fake_machine.install()
fake_machine.set_input(22, 0)
os.chdir(%r)
from device.benchflight import main
from device.groundtest import Refused
try:
    main("bench.bin", speed=0)
    print("RESULT ran")
except Refused as e:
    print("RESULT refused", e)
""" % str(wd)
    assert "RESULT refused the arming input is on" in run_micropython(code, "unix")
