"""The portable core on real MicroPython: imports unchanged, runs a whole flight with the heap
locked (zero allocations per sample), and produces the same integer states as CPython, sample by
sample, on the 64-bit unix port and on the 32-bit wasm build (31-bit small ints, as on a board).

These tests fail, never skip, when an interpreter is missing.
"""

import math
import subprocess
from pathlib import Path

import pytest

from desktop.hosts.micropython import INTERPRETERS, REPO_ROOT, run_micropython
from tools.bench_step import run_flight
from tools.synthetic_flight import make_flight

pytestmark = pytest.mark.micropython

SHARED_MODULES = sorted(p.stem for p in (REPO_ROOT / "shared").glob("*.py") if p.stem != "__init__")

# (name, make_flight keyword arguments, index from which the rule is enabled)
FLIGHTS = {
    "typical": (dict(rate_hz=100, seed=11), 600),
    "seed_rate": (dict(rate_hz=20, seed=12, pad_s=1), 100),
    # 400 m and 40 s of descent: the main and the backup channels fire (the whole descent path)
    "descent": (dict(rate_hz=50, seed=13, boost_mmps2=40000, after_apogee_s=40), 150),
    # 30 km class: 100 g for 0.78 s -> 766 m/s, drag-free apogee ~30 km above a 1 km site
    "extreme_30km": (dict(rate_hz=100, boost_mmps2=981000, burn_ms=780, after_apogee_s=3,
                          ground_mm=1000000, alt_noise_mm=5000, acc_noise_mmps2=14000, seed=13,
                          glitches=[(3000, 25000000), (3001, -25000000), (4000, 5000000),
                                    (5000, -20000000), (5001, -20000000)]), 300),
    # 1000 m/s: 100 g for 1.02 s; the drag-free apogee (51 km) exceeds the 33.5 km state limit,
    # so the clamps are exercised too
    "extreme_1000mps": (dict(rate_hz=50, boost_mmps2=981000, burn_ms=1020, after_apogee_s=2,
                             ground_mm=0, alt_noise_mm=3000, seed=14,
                             glitches=[(1000, 30000000), (2000, -30000000)]), 200),
    # a pressure pulse in coast: one reading 58 m low, within the spike test's 1,500 m/s at
    # 100 Hz, off the barometer's own path (docs/DESIGN.md D16 rule 19)
    "pulse": (dict(rate_hz=100, seed=16, glitches=[(1300, -58000)]), 600),
    # a pressure transient 8 s into the coast: +100 m within 0.2 s, decaying over 1.5 s (a
    # barometer-only board sets its ballistic floor: shared/ballistic.py)
    "transient": (dict(rate_hz=100, seed=15, glitches=[
        (1200 + k, int(100000 * min(k / 20, 1) * math.exp(-max(k - 20, 0) / 150)))
        for k in range(1000)]), 600),
}

GUEST = """
from tools.synthetic_flight import make_flight
from tools.bench_step import run_flight
flight = make_flight(**{kwargs})
fired_at, states = run_flight({table!r}, {rule!r}, flight, {enable_from}, True)
print(fired_at)
print(' '.join([str(x) for x in states]))
"""


def _guest_run(interp, name, table, rule):
    kwargs, enable_from = FLIGHTS[name]
    out = run_micropython(GUEST.format(kwargs=kwargs, table=table, rule=rule, enable_from=enable_from),
                          interp)
    fired_line, states_line = out.strip().split("\n")[-2:]
    return int(fired_line), [int(x) for x in states_line.split()]


@pytest.mark.parametrize("interp", INTERPRETERS)
def test_shared_modules_import_unchanged(interp):
    code = "\n".join("import shared.%s" % m for m in SHARED_MODULES) + "\nprint('imported')"
    assert run_micropython(code, interp).strip().endswith("imported")


def test_a_stray_module_in_the_temp_directory_shadows_nothing(tmp_path, monkeypatch):
    # the unix port puts the script's directory first on its path: a user's os.py in the system's
    # temp directory once broke every device test ("no module named 'numpy'", from that os.py)
    import tempfile

    (tmp_path / "os.py").write_text("raise ImportError('the stray os.py')\n")
    monkeypatch.setattr(tempfile, "tempdir", str(tmp_path))
    assert run_micropython("import os\nprint(os.getcwd() != '')\n", "unix").strip() == "True"


@pytest.mark.parametrize("interp", INTERPRETERS)
def test_32bit_interpreter_really_has_31bit_small_ints(interp):
    # guards the premise of the wasm32 tests: past 2**30 a product allocates and heap_lock catches it
    code = ("import micropython, sys\n"
            "def probe(x, y):\n    micropython.heap_lock()\n    try:\n        x * y * 2\n"
            "        r = 'no-alloc'\n    except MemoryError:\n        r = 'alloc'\n"
            "    micropython.heap_unlock()\n    return r\n"
            "print(sys.maxsize, probe(1 << 15, 1 << 14))")
    out = run_micropython(code, interp).split()
    assert out == (["2147483647", "alloc"] if interp == "wasm32" else ["9223372036854775807", "no-alloc"])


@pytest.mark.parametrize("interp", INTERPRETERS)
@pytest.mark.parametrize("name,table,rule", [
    ("typical", "project", "velocity"), ("typical", "project", "seed"), ("seed_rate", "seed", "seed"),
    ("extreme_30km", "project", "velocity"), ("extreme_1000mps", "project", "seed"),
])
def test_heap_locked_flight_is_bit_identical_to_cpython(interp, name, table, rule):
    kwargs, enable_from = FLIGHTS[name]
    flight = make_flight(**kwargs)
    fired_cpy, states_cpy = run_flight(table, rule, flight, enable_from, False)
    fired_mp, states_mp = _guest_run(interp, name, table, rule)
    assert len(states_mp) == len(states_cpy)
    for i in range(0, len(states_cpy), 3):
        assert states_mp[i:i + 3] == list(states_cpy[i:i + 3]), "first difference at sample %d" % (i // 3)
    assert fired_mp == fired_cpy


def test_typical_flight_detects_apogee_on_micropython():
    kwargs, enable_from = FLIGHTS["typical"]
    apogee = make_flight(**kwargs)[4]
    fired, _ = _guest_run("wasm32", "typical", "project", "velocity")
    assert abs(fired - apogee) <= 30  # 0.3 s at 100 Hz with 1.5 m barometer noise


def test_every_board_module_compiles_with_mpy_cross(tmp_path):
    from desktop.hosts.micropython import find_unix_binary

    mpy_cross = str(Path(find_unix_binary()).with_name("mpy-cross"))
    sources = sorted((REPO_ROOT / "shared").rglob("*.py")) + sorted((REPO_ROOT / "device").rglob("*.py"))
    assert len(sources) >= len(SHARED_MODULES)
    for src in sources:
        out = tmp_path / (src.stem + ".mpy")
        proc = subprocess.run([mpy_cross, str(src), "-o", str(out)], capture_output=True, text=True)
        assert proc.returncode == 0, "%s: %s" % (src, proc.stderr)
        assert out.stat().st_size > 0


FC_GUEST = """
from tools.synthetic_flight import make_flight
from tools.bench_step import run_fc_flight
flight = make_flight(**{kwargs})
out = run_fc_flight(flight, True, {config!r})
print(' '.join([str(x) for x in out]))
"""


@pytest.mark.parametrize("interp", INTERPRETERS)
@pytest.mark.parametrize("name,config", [
    ("typical", None),
    ("typical", {"apogee_rule": "seed", "sensors": "baro", "backup_drogue_s": 30}),
    ("seed_rate", {"sensors": "accel", "apogee_delay_s": 1}),
    ("extreme_30km", {"mach_lockout_mps": 250}),
    ("extreme_30km", {"sensors": "baro"}),
    ("extreme_1000mps", None),
    ("descent", {"backup_drogue_delay_s": 1, "backup_main_m": 150}),
    ("transient", {"sensors": "baro"}),
    ("pulse", None),
])
def test_state_machine_heap_locked_and_bit_identical(interp, name, config):
    from tools.bench_step import run_fc_flight

    kwargs, _ = FLIGHTS[name]
    expected = list(run_fc_flight(make_flight(**kwargs), False, config))
    out = run_micropython(FC_GUEST.format(kwargs=kwargs, config=config), interp)
    got = [int(x) for x in out.strip().split("\n")[-1].split()]
    assert len(got) == len(expected)
    for i in range(0, len(expected), 6):
        assert got[i:i + 6] == expected[i:i + 6], "first difference at sample %d" % (i // 6)
    states = {expected[i + 3] for i in range(0, len(expected), 6)}
    assert 1 in states  # it launched (state BOOST)
    if name == "typical":
        assert any(expected[i + 5] for i in range(0, len(expected), 6))  # it did fire
    if name == "descent":  # every output fired: drogue, main and both backups
        assert {expected[i + 5] for i in range(0, len(expected), 6)} >= {1, 2, 4, 8}


def test_the_transient_flight_sets_the_ballistic_floor():
    """(So that the heap-locked run above covers the floor's code.)"""
    from shared.config import load_config
    from shared.flight import FlightComputer

    dts, alts, accs = make_flight(**FLIGHTS["transient"][0])[:3]
    fc = FlightComputer(load_config({"sensors": "baro"}))
    held = False
    for d, a, f in zip(dts, alts, accs, strict=True):
        fc.step(d, a, f + 9807, 3)  # (as tools/bench_step.run_fc_loop: both readings)
        held = held or (fc.arb.ballistic.anchored and fc.arb.ballistic.floor_mmps > 0)
    assert held


def test_the_pulse_flight_drops_its_pulse_off_the_path():
    """(So that the heap-locked run above covers rule 19's code.)"""
    from shared.config import load_config
    from shared.flight import COAST, FlightComputer

    dts, alts, accs = make_flight(**FLIGHTS["pulse"][0])[:3]
    fc = FlightComputer(load_config({}))
    for i, (d, a, f) in enumerate(zip(dts, alts, accs, strict=True)):
        fc.step(d, a, f + 9807, 3)
        if i == 1300:
            assert fc.state == COAST and fc.health.baro_spikes == 1
    # (the reading after it came with the window's judgement due: not judged on the path)
    assert fc.health.baro_spikes == 1


@pytest.mark.parametrize("interp", INTERPRETERS)
def test_save_state_is_allocation_free_and_restores(interp):
    code = """
import micropython
from shared.config import load_config
from shared.flight import FlightComputer, STATE_RECORD_SIZE
from tools.synthetic_flight import make_flight
from tools.bench_step import run_fc_loop
flight = make_flight(rate_hz=50, seed=3, after_apogee_s=1)
fc = FlightComputer(load_config())
run_fc_loop(fc, flight[0], flight[1], flight[2], None)
buf = bytearray(STATE_RECORD_SIZE)
micropython.heap_lock()
try:
    for _ in range(100):
        fc.save_state(buf)
finally:
    micropython.heap_unlock()
other = FlightComputer(load_config())
print(other.restore_state(buf), other.state == fc.state, abs(other.vel_mmps - fc.vel_mmps) < 1000)
"""
    assert run_micropython(code, interp).split()[-3:] == ["True", "True", "True"]


@pytest.mark.parametrize("interp", INTERPRETERS)
def test_refused_launch_while_the_barometer_sees_a_flight_stays_in_31_bits(interp):
    # an upside-down board refuses launch, then stays in pad mode through a 30 km flight: its pad
    # averages must not overflow (found by this test on wasm32)
    kwargs, _ = FLIGHTS["extreme_30km"]
    code = """
from tools.synthetic_flight import make_flight
from tools.bench_step import run_fc_flight
f = make_flight(**{kwargs})
flight = (f[0], f[1], [-a - 2 * 9807 for a in f[2]])
out = run_fc_flight(flight, True, None)
print(max([out[i + 3] for i in range(0, len(out), 6)]), max([out[i + 5] for i in range(0, len(out), 6)]))
""".format(kwargs=kwargs)
    assert run_micropython(code, interp).split()[-2:] == ["0", "0"]  # state PAD throughout, no pyro


CLIMB_HOLD_AFTER_A_JUMP = """
from shared.arbitration import Arbitration, add_baro, close_slot, climbs_fast
from shared.config import load_config
arb = Arbitration(load_config({{}}))
arb.start(0)
alts = [0] * 200 + [k // 5 * 1000000 for k in range(5, 30)] + [5000000 + 100 * k for k in range(75)]
now_ms = 0
for alt_mm in alts:
    now_ms += 10
    if add_baro(arb, now_ms, alt_mm, True):
        close_slot(arb, now_ms, 0, 0)
got = None  # (a new global under the lock would allocate)
{lock}
try:
    got = climbs_fast(arb, 6000, 20000)
finally:
    {unlock}
print(arb.baro_rate_mmps, got)
"""


@pytest.mark.parametrize("interp", INTERPRETERS)
def test_the_climb_hold_over_a_window_after_a_jump_stays_in_31_bits(interp, capsys):
    # D16 rule 17's lower tier reads the window before the newest: 5 km of barometric jump there
    # (five slots of 1 km, the most a slot may step) and a climb at 10 m/s since. The rate over
    # that window is clamped as the judgement's is, else 5e9 allocates on a 32-bit board
    exec(CLIMB_HOLD_AFTER_A_JUMP.format(lock="", unlock="pass"), {})
    expected = capsys.readouterr().out.split()
    guest = CLIMB_HOLD_AFTER_A_JUMP.format(lock="import micropython\nmicropython.heap_lock()",
                                           unlock="micropython.heap_unlock()")
    assert run_micropython(guest, interp).split()[-2:] == expected


@pytest.mark.parametrize("interp", INTERPRETERS)
def test_pressure_glitches_of_50kpa_through_table_and_state_machine(interp):
    # a 30 km flight as the barometer sees it (Pa x 16 through shared/altitude.py), with pressure
    # glitches of +-50 kPa, at 20 Hz; table + state machine heap-locked, bit-identical to CPython
    from desktop.sim.trajectory import isa_pressure

    f = make_flight(rate_hz=20, boost_mmps2=981000, burn_ms=800, after_apogee_s=2, ground_mm=0,
                    alt_noise_mm=0, acc_noise_mmps2=5000, seed=21)
    pressure_q4 = [int(round(isa_pressure(h / 1000.0) * 16)) for h in f[3]]
    for i in range(100, len(pressure_q4), 97):
        pressure_q4[i] += (50000 * 16) if i % 2 else -(50000 * 16)
    code = """
import micropython
from array import array
from shared.altitude import pressure_to_alt_mm
from shared.config import load_config
from shared.flight import FlightComputer
dts = {dts}
pres = {pres}
accs = {accs}
fc = FlightComputer(load_config())
out = array('i', bytearray(4 * 3 * len(dts)))
# no free variables: on wasm32 the guest runs inside a function, and calling a closure with this
# many arguments allocates its argument array
def loop(fc, dts, pres, accs, out, to_alt_mm):
    for i in range(len(dts)):
        fc.step(dts[i], to_alt_mm(pres[i]), accs[i] + 9807, 3)
        out[3 * i] = fc.kf.alt_q4
        out[3 * i + 1] = fc.kf.vel_q4
        out[3 * i + 2] = fc.state
micropython.heap_lock()
try:
    loop(fc, dts, pres, accs, out, pressure_to_alt_mm)
finally:
    micropython.heap_unlock()
print(' '.join([str(x) for x in out]))
""".format(dts=list(f[0]), pres=pressure_q4, accs=list(f[2]))
    got = [int(x) for x in run_micropython(code, interp).strip().split("\n")[-1].split()]
    from shared.altitude import pressure_to_alt_mm
    from shared.config import load_config
    from shared.flight import FlightComputer

    fc = FlightComputer(load_config())
    expected = []
    for i in range(len(f[0])):
        fc.step(f[0][i], pressure_to_alt_mm(pressure_q4[i]), f[2][i] + 9807, 3)
        expected += [fc.kf.alt_q4, fc.kf.vel_q4, fc.state]
    assert got == expected
    assert max(got[i] for i in range(0, len(got), 3)) > 25_000_000 * 16  # it did reach 25 km+
