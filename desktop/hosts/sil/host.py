"""Host side of a software-in-the-loop run: prepare the board's files, run the guest, parse the result."""

import json
import shutil
from pathlib import Path

from desktop.hosts.micropython import REPO_ROOT, MicroPythonError, run_micropython
from device.board import pyro_pins_text

PICO = REPO_ROOT / "device" / "boards" / "pico.json"
ARM_PIN = 22  # pico.json: arming switch to GND (active low, pull-up)
DROGUE_PIN = 16
MAIN_PIN = 17
LED_PIN = 25
BUZZER_PIN = 15
ORIGIN_NEAR_WRAP = (1 << 30) - 40_000_000  # ticks_us wraps 40 s into the run


def prepare(workdir, scenario, board=None, config=None, pyro_pins=True):
    """The board's files in ``workdir`` (board.json: pico.json updated with ``board``; config.json;
    pyro_pins.txt) and the frames file of ``scenario`` (a flightgen Scenario or Recording)."""
    workdir = Path(workdir)
    workdir.mkdir(parents=True, exist_ok=True)
    desc = json.loads(PICO.read_text())
    desc.update(board or {})
    (workdir / "board.json").write_text(json.dumps(desc))
    (workdir / "config.json").write_text(json.dumps(config or {}))
    if pyro_pins:
        (workdir / "pyro_pins.txt").write_text(pyro_pins_text(desc))
    frames = workdir / "frames.bin"
    scenario.write(frames)
    return frames


def run_sil(workdir, scenario, board=None, config=None, inputs=None, adc=None, origin_us=ORIGIN_NEAR_WRAP,
            end_us=None, lock_heap=True, interp="unix", rtc_memory=True, pyro_pins=True):
    """Run boot.py + main.py on MicroPython against ``scenario``; returns the result dict.
    ``pyro_pins`` False keeps the workdir's own pyro_pins.txt."""
    frames = prepare(workdir, scenario, board, config, pyro_pins)
    if inputs is None:
        inputs = [[ARM_PIN, 0, 1_000_000]]  # arming switch closed 1 s after power-on
    if adc is None:
        adc = [[26, 40000], [27, 40000]]  # both igniters show continuity
    opts = {"repo": str(REPO_ROOT), "workdir": str(workdir), "frames": str(frames), "inputs": inputs,
            "adc": adc, "origin_us": origin_us, "lock_heap": lock_heap, "rtc_memory": rtc_memory}
    if end_us is not None:
        opts["end_us"] = end_us
    out = run_micropython("from desktop.hosts.sil.runner import main\nmain(%r)\n" % (opts,), interp)
    console = []
    result = None
    for line in out.splitlines():
        if line.startswith("SILRESULT "):
            result = json.loads(line[len("SILRESULT "):])
        else:
            console.append(line)
    if result is None:
        raise MicroPythonError("the software-in-the-loop guest printed no result:\n" + out[-3000:])
    result["console"] = console
    result["log"] = Path(workdir) / "flight.log"
    return result


def rises(result, pin):
    """[(t_us, duration_us)] of every high pulse on ``pin``."""
    out = []
    t_high = None
    for t, p, level in result["pins"]:
        if p != pin:
            continue
        if level and t_high is None:
            t_high = t
        elif not level and t_high is not None:
            out.append((t_high, t - t_high))
            t_high = None
    if t_high is not None:
        out.append((t_high, None))
    return out


def copy_log(result, dest):
    shutil.copy(result["log"], dest)
