"""Software in the loop: the firmware (device/boot.py, device/main.py and everything they import)
runs unchanged on the MicroPython unix port, with fake ``machine``/``time`` modules and the
register-level sensor fakes fed by a simulated flight (desktop/hosts/sil/). The sample step runs under
``micropython.heap_lock()`` (``device.flightloop.LOCK_HEAP``): any allocation in it raises.

The fake clock starts 40 s before ``ticks_us`` wraps at 2**30, so every run crosses the wrap.
These tests fail, never skip, when the interpreter is missing.
"""

import json

import numpy as np
import pytest

from desktop.hosts.sil.flightgen import Scenario
from desktop.hosts.sil.host import ARM_PIN, DROGUE_PIN, MAIN_PIN, rises
from desktop.hosts.sil.host import run_sil as _run_sil
from desktop.io.logdecode import read_log, to_columns, write_csv
from tests.support.decoded_replay import check_replay


def run_sil(*args, **kw):
    """The host's run, failing on an allocation under the heap lock (the loop would survive it by
    counting it in heap_lock_faults and flying on unlocked)."""
    result = _run_sil(*args, **kw)
    assert not (result.get("summary") or {}).get("heap_lock_faults"), "sample() allocated under the heap lock"
    return result


pytestmark = pytest.mark.micropython

PERIOD_US = 20000  # pico.json: 50 Hz
PULSE_US = 500000  # default pulse_ms
EV_LAUNCH, EV_APOGEE, EV_DROGUE, EV_MAIN, EV_LANDED = 1, 4, 8, 16, 32


def _decode(result, tmp_path):
    log = read_log(result["log"])
    csv, cfg = write_csv(log, tmp_path / "FLIGHT.csv")
    return log, csv, cfg


def _board_rows(log):
    cols, _meta = to_columns(log)
    return cols


@pytest.fixture(scope="module")
def flight(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("sil_flight")
    sc = Scenario(duration_s=90, launch_s=30, stalls=[(12.0, 70000), (33.0, 50000)], seed=3)
    result = run_sil(tmp / "board", sc)
    return sc, result, tmp


def test_boot_drives_pyro_low_first(flight):
    _sc, result, _tmp = flight
    boot = result["boots"][0]
    assert boot["t_us"] == 0  # before anything else ran
    for pin in (DROGUE_PIN, MAIN_PIN):
        assert boot["modes"][pin] == 1 and boot["levels"][pin] == 0


def test_flight_runs_to_landing_heap_locked(flight):
    _sc, result, _tmp = flight
    assert result["end"] == "simulation end", result["console"]
    s = result["summary"]
    assert s["reason"] == "landed"
    assert result["loop"]["state"] == 6
    assert s["handovers"] >= 3  # pad epochs exercised
    assert s["log_dropped"] == 0 and not s["log_incomplete"]
    assert 470_000 < s["max_agl_mm"] < 490_000  # truth apogee 479.9 m
    # two stalls (70 ms on the pad, 50 ms in coast): deadlines counted, never absorbed
    assert s["missed_deadlines"] >= 2
    assert any("pad checks passed" in line for line in result["console"])


def test_pins_low_on_pad_and_boost_then_one_pulse_each(flight):
    sc, result, _tmp = flight
    t_apogee, _h = sc.apogee()
    d = rises(result, DROGUE_PIN)
    m = rises(result, MAIN_PIN)
    assert len(d) == 1 and len(m) == 1, (d, m)
    t_d, dur_d = d[0]
    t_m, dur_m = m[0]
    assert dur_d == PULSE_US and dur_m == PULSE_US  # exactly the pulse length
    assert t_d > (sc.launch_s + sc.burn_s) * 1e6  # nothing on the pad or in boost
    assert t_apogee * 1e6 - 200_000 <= t_d <= t_apogee * 1e6 + 1_500_000
    agl_at_main = sc.truth(t_m / 1e6)[0]
    assert 225 <= agl_at_main <= 250, agl_at_main
    # the hardware pulse guards were armed (and fired after the state machine's own turn-off)
    assert result["timers_fired"] == [1, 1]
    assert result["loop"]["guard_failures"] == 0


def test_ctrl_c_disabled_while_armed(flight):
    sc, result, _tmp = flight
    kbd = result["kbd"]
    assert kbd[0][1] == -1 and kbd[0][0] < sc.launch_s * 1e6
    d = rises(result, DROGUE_PIN)[0][0]
    m = rises(result, MAIN_PIN)[0][0]
    restored = [t for t, c in kbd if c == 3]
    assert restored and restored[0] > max(d, m)  # restored only after landing
    assert result["kbd_now"] == 3


def test_log_decodes_and_replays_bit_identically(flight):
    sc, result, tmp = flight
    log, csv, cfg = _decode(result, tmp)
    assert not log.problems
    assert log.summary["reason"] == "landed"
    n, problems = check_replay(csv, cfg)
    assert not problems
    assert n > 2000
    cols = _board_rows(log)
    ev = cols["board_events"]
    i_drogue = int(np.flatnonzero(ev & EV_DROGUE)[0])
    i_main = int(np.flatnonzero(ev & EV_MAIN)[0])
    assert ev[i_drogue] & EV_APOGEE  # the drogue fires on the apogee sample (no delay configured)
    # the pins moved at the logged samples: pin times and log times agree to the microsecond
    t = np.round(cols["time_s"] * 1e6).astype(np.int64)
    t_d = rises(result, DROGUE_PIN)[0][0]
    t_m = rises(result, MAIN_PIN)[0][0]
    assert t_m - t_d == t[i_main] - t[i_drogue]
    # missed deadlines are in the log as multiples of the period, flagged
    dt = np.diff(t)
    assert np.all(dt % PERIOD_US == 0)
    missed = np.flatnonzero(dt > PERIOD_US)
    assert len(missed) >= 1
    assert np.all(cols["board_flags"][missed + 1] & 8)
    # the events in the log are the board's summary events
    logged = [[int(log.sample[log.sample >= log.fc_start][i]), int(ev[i])] for i in np.flatnonzero(ev)]
    assert logged == [[e[0], e[1]] for e in log.summary["events"]]


def test_desktop_replay_command_reproduces_events(flight, capsys):
    _sc, result, tmp = flight
    from desktop.cli import main

    assert main(["logdecode", str(result["log"]), "--out", str(tmp / "cli.csv"), "--check"]) == 0
    out = capsys.readouterr().out
    assert "replay reproduces the board's decisions" in out
    assert main(["replay", str(tmp / "cli.csv"), "--config", str(tmp / "cli.config.json"), "--json"]) == 0
    rep = json.loads(capsys.readouterr().out)
    names = [e["event"] for e in rep["events"]]
    assert names == ["launch", "burnout", "apogee", "drogue", "main", "landed"]


def test_pad_only_with_knocks_never_fires(tmp_path):
    knocks = [(8.0 + 4 * k, 0.05, 25.0) for k in range(8)] + [(20.0, 0.02, 100.0), (27.0, 0.3, 30.0)]
    steps = [(15.0, 2.0, -40.0), (24.0, 0.5, 60.0), (31.0, 0.2, -600.0)]
    sc = Scenario(duration_s=45, launch_s=None, knocks=knocks, pressure_steps=steps, seed=5)
    # arm at 1 s, disarm at 40 s: the loop ends "disarmed" and writes its log
    result = run_sil(tmp_path / "board", sc, inputs=[[ARM_PIN, 0, 1_000_000], [ARM_PIN, 1, 40_000_000]])
    assert rises(result, DROGUE_PIN) == [] and rises(result, MAIN_PIN) == []
    s = result["summary"]
    # the 0.3 s, 3 g push at 27 s looks like a launch to the accelerometer; the barometer never
    # confirms a climb, so no firing path opens, and the switch still disarms the board
    assert s["reason"] == "disarmed" and not s["flight_proven"]
    assert all(ev & (EV_APOGEE | EV_DROGUE | EV_MAIN) == 0 for _i, ev, _agl in s["events"])
    assert result["kbd_now"] == 3 and [c for _t, c in result["kbd"]][:2] == [-1, 3]
    log, csv, cfg = _decode(result, tmp_path)
    n, problems = check_replay(csv, cfg)
    assert not problems and n > 150


def test_baro_dies_in_flight_counted_no_crash(tmp_path):
    sc = Scenario(duration_s=70, launch_s=30, kill_baro_s=34.0, seed=7)
    t_apogee, _h = sc.apogee()
    # the backup timer as docs/CONFIG.md tells users: nominal apogee + 3 s after launch
    backup_s = round(t_apogee - 30 + 3)
    result = run_sil(tmp_path / "board", sc, config={"backup_drogue_s": backup_s})
    assert result["end"] == "simulation end"
    loop = result["loop"]
    assert loop["baro_errors"] > 0
    # retried once a second after three failures: a dead part does not eat every sample
    assert loop["baro_errors"] <= 3 + 3 * (70 - 34 + 1)
    assert loop["accel_errors"] == 0
    assert loop["samples"] > (70 - 8) * 50  # the loop kept its rate to the end
    d = rises(result, DROGUE_PIN)
    assert len(d) == 1 and d[0][1] == PULSE_US
    # accelerometer only from 4 s after launch: apogee when its highest possible velocity is 0,
    # never early (docs/DESIGN.md D16), or the backup timer
    assert t_apogee - 0.5 <= d[0][0] / 1e6 <= 30 + backup_s + 0.2
    # never landed (no barometer): the log is still in RAM; it is the loop that matters here
    assert result["summary"] is None


def test_accel_dies_on_pad_no_firing(tmp_path):
    sc = Scenario(duration_s=40, launch_s=None, kill_accel_s=15.0, knocks=[(20.0, 0.3, 40.0)], seed=9)
    result = run_sil(tmp_path / "board", sc, inputs=[[ARM_PIN, 0, 1_000_000], [ARM_PIN, 1, 35_000_000]])
    assert rises(result, DROGUE_PIN) == [] and rises(result, MAIN_PIN) == []
    s = result["summary"]
    assert s["reason"] == "disarmed" and s["state"] == 0
    assert s["accel_errors"] > 0
    log, csv, cfg = _decode(result, tmp_path)
    cols = _board_rows(log)
    assert np.isnan(cols["accel_mps2"][-1])  # marked missing
    assert np.any(cols["board_flags"] & 4)
    n, problems = check_replay(csv, cfg)
    assert not problems


def test_reset_in_flight_resumes_without_new_ground(tmp_path):
    """A 2.5 s stall in coast starves the watchdog (2 s): the board resets in flight. It must not
    calibrate a new ground in the air or go back to pad mode: it restores the resume record
    (device/resume.py; here the fake RTC memory) and carries on: one drogue pulse near apogee, one
    main pulse at the main altitude, Ctrl-C disabled again at once."""
    sc = Scenario(duration_s=75, launch_s=30, stalls=[(36.0, 2_500_000)], seed=11)
    result = run_sil(tmp_path / "board", sc)
    assert result["resets"] == 1 and len(result["boots"]) == 2
    reboot = result["boots"][1]
    assert reboot["levels"][DROGUE_PIN] == 0 and reboot["levels"][MAIN_PIN] == 0
    assert any("resuming in state coast" in line for line in result["console"])
    assert not any("pad checks" in line for line in result["console"][3:])
    d = rises(result, DROGUE_PIN)
    m = rises(result, MAIN_PIN)
    assert len(d) == 1 and len(m) == 1
    t_apogee, _h = sc.apogee()
    assert abs(d[0][0] / 1e6 - t_apogee) < 1.5
    assert 225 <= sc.truth(m[0][0] / 1e6)[0] <= 250
    t_reboot = reboot["t_us"]
    assert [c for t, c in result["kbd"] if t > t_reboot][0] == -1  # disabled again after the reset
    log = read_log(result["log"])
    assert any("resumed" in p or "reset" in p for p in log.problems)


def test_reset_without_resume_record_stays_disarmed(tmp_path):
    """armed.flag left by a reset, but no usable record: error 7, no pad mode, no firing, until the
    arming switch is cycled."""
    (tmp_path / "board").mkdir()
    (tmp_path / "board" / "armed.flag").write_text("switch")
    sc = Scenario(duration_s=12, launch_s=None, seed=13)
    # the switch is on from power-on: without cycling it the board must not arm
    result = run_sil(tmp_path / "board", sc, inputs=[[ARM_PIN, 0, 0]])
    assert result["errors"][0][0] == 7
    assert any("error 7" in line for line in result["console"])
    assert not any("pad checks" in line for line in result["console"])
    assert -1 not in [c for _t, c in result["kbd"]]
    assert rises(result, DROGUE_PIN) == [] and rises(result, MAIN_PIN) == []
    assert (tmp_path / "board" / "armed.flag").exists()


def test_100hz_board_with_apogee_delay(tmp_path):
    """100 Hz (the BMP390 converts at 50 Hz: every other sample has no fresh pressure), a 1 s apogee
    delay, main at 300 m, 300 ms pulses; the log still replays bit for bit."""
    sc = Scenario(duration_s=95, launch_s=25, seed=17)
    config = {"apogee_delay_s": 1, "main_deploy_m": 300, "pulse_ms": 300}
    result = run_sil(tmp_path / "board", sc, board={"sample_hz": 100, "log_ram_kb": 96}, config=config)
    assert result["summary"]["reason"] == "landed"
    d = rises(result, DROGUE_PIN)
    m = rises(result, MAIN_PIN)
    assert [x[1] for x in d] == [300000] and [x[1] for x in m] == [300000]
    log, csv, cfg = _decode(result, tmp_path)
    cols = _board_rows(log)
    ev = cols["board_events"]
    t = np.round(cols["time_s"] * 1e6).astype(np.int64)
    i_apogee = int(np.flatnonzero(ev & EV_APOGEE)[0])
    i_drogue = int(np.flatnonzero(ev & EV_DROGUE)[0])
    assert t[i_drogue] - t[i_apogee] == 1_000_000
    assert 280 <= sc.truth(m[0][0] / 1e6)[0] <= 300
    have = np.isnan(cols["pressure_pa"].astype(float))
    assert 0.4 < have.mean() < 0.6  # half the samples without a fresh barometer reading
    assert not check_replay(csv, cfg)[1]


def test_reset_in_flight_on_the_rp2040_resumes_from_the_scratch_registers(tmp_path):
    """The RP2040 port has no RTC memory: the resume record lives in the watchdog's four free
    scratch registers, rewritten every 0.1 s (before: a file written at events only, so a reset in
    coast resumed from the burnout record, seconds stale, and the drogue fired at +36 m/s). After
    the reset the clock is advanced by the worst-case reset time: one pulse per channel, the drogue
    near apogee, the main at the main altitude, the board lands and says so."""
    sc = Scenario(duration_s=95, launch_s=30, stalls=[(36.0, 2_500_000)], seed=11)
    result = run_sil(tmp_path / "board", sc, rtc_memory=False)
    assert result["resets"] == 1
    assert any("resuming in state coast" in line for line in result["console"])
    d = rises(result, DROGUE_PIN)
    m = rises(result, MAIN_PIN)
    assert len(d) == 1 and len(m) == 1
    t_apogee, _h = sc.apogee()
    assert abs(d[0][0] / 1e6 - t_apogee) < 1.0
    assert 225 <= sc.truth(m[0][0] / 1e6)[0] <= 250
    assert result["summary"]["reason"] == "landed"
    assert not (tmp_path / "board" / "resume.bin").exists()
    assert not (tmp_path / "board" / "armed.flag").exists()


def test_an_allocation_under_the_heap_lock_is_counted_and_the_flight_goes_on_unlocked():
    # sample() allocates once (a path no test took): the loop must not die in flight
    from desktop.hosts.micropython import run_micropython

    code = """
from desktop.hosts.sil import fake_machine
fake_machine.install()
import device.flightloop as fl
class Loop(fl.FlightLoop):
    def __init__(self):
        self.period_us = 10000
        self.done = False
        self.missed = self.worst_late_us = self.samples = self.heap_lock_faults = 0
        self.max_samples = 5
        self.wdt = None
        self.lock_heap = True
        self.locked_at = []
    def sample(self, dt_us):
        self.locked_at.append(self.lock_heap)
        if self.samples == 1:
            [0] * 100
    def after_sample(self):
        self.samples += 1
loop = Loop()
print(loop.run(), loop.samples, loop.heap_lock_faults, loop.locked_at)
"""
    out = run_micropython(code, "unix").strip().splitlines()[-1]
    assert out == "sample limit 5 1 [True, True, False, False, False]"
