"""Guest side of a software-in-the-loop run (MicroPython unix port; CPython works too).

``run(opts)`` installs the fake ``machine``/``time``/``micropython``, builds the I2C bus with the
register-level fakes fed by ``desktop/hosts/sil/world.py``, changes to the work directory (board.json,
config.json, pyro_pins.txt there, as on a board's filesystem), runs ``device/boot.py`` and then
``device/main.py`` unchanged, and returns what happened as a dict (printed as JSON by the tests).
A watchdog bite reboots: boot.py and main.py run again with the RTC memory kept.
"""

import json
import os
import sys

from desktop.hosts.sil import fake_machine, fake_micropython, fake_time


def _forget_firmware():
    for name in list(sys.modules):
        if name.startswith("device") or name.startswith("shared"):
            del sys.modules[name]


def run(opts):
    fake_machine.install(opts.get("origin_us", 0))
    repo = opts["repo"]
    world = fake_machine.install_world(opts["frames"])
    for pin, level, at_us in opts.get("inputs", []):
        if at_us <= 0:
            fake_machine.set_input(pin, level)
        else:
            fake_machine.schedule_input(pin, level, at_us)
    fake_machine.RTC_MEMORY[0] = opts.get("rtc_memory", True)
    for pin, value in opts.get("adc", []):
        fake_machine.ADC_VALUES[pin] = value
    fake_time.set_end(opts.get("end_us", world.end_us - 100000))
    os.chdir(opts["workdir"])
    with open(repo + "/device/boot.py") as f:
        boot_src = f.read()
    with open(repo + "/device/main.py") as f:
        main_src = f.read()
    result = {"boots": [], "resets": 0, "end": ""}
    cause = fake_machine.PWRON_RESET
    while True:
        fake_machine.reset_state(cause)
        _forget_firmware()
        exec(boot_src, {"__name__": "boot"})
        result["boots"].append({"t_us": fake_time.elapsed, "modes": list(fake_machine.MODES[:32]),
                                "levels": list(fake_machine.LEVELS[:32])})
        import device.flightloop

        device.flightloop.LOCK_HEAP = opts.get("lock_heap", True)
        try:
            exec(main_src, {"__name__": "__main__"})
            result["end"] = "main returned"
            break
        except fake_time.SimulationEnd:
            result["end"] = "simulation end"
            break
        except fake_machine.WatchdogReset:
            result["resets"] += 1
            cause = fake_machine.WDT_RESET
            if result["resets"] > 3:
                result["end"] = "too many resets"
                break
    import device.app

    app = device.app.CURRENT
    result["t_end_us"] = fake_time.elapsed
    result["pins"] = fake_machine.pin_events()
    result["kbd"] = fake_micropython.KBD_HISTORY
    result["kbd_now"] = fake_micropython.KBD[0]
    if app is not None:
        result["errors"] = app.errors
        result["summary"] = app.last_summary
        result["pad"] = getattr(app, "pad_figures", None)
        loop = app.last_loop
        if loop is not None:
            result["loop"] = {"samples": loop.samples, "missed": loop.missed, "handovers": loop.handovers,
                              "baro_errors": loop.sensors.baro_errors,
                              "accel_errors": loop.sensors.accel_errors, "state": loop.fc.state,
                              "guard_failures": loop.pyro.guard_failures}
    result["timers_fired"] = [t.fired for t in fake_machine._timers]
    return result


def main(opts):
    print("SILRESULT " + json.dumps(run(opts)))
