"""``python -m desktop sil``: fly a simulated or recorded flight through the unchanged firmware.

The board's own ``boot.py`` and ``main.py`` (``device/``) run on the MicroPython unix port with
the fake ``machine``/``time``/``micropython`` modules and the register-level sensor fakes (a
BMP390 barometer and an ADXL375 accelerometer on I2C bus 0, as on the ``pico`` board): the board
powers up, the arming switch closes after 1 s, it runs its pad checks and flies, and writes its
``flight.log`` into the output folder exactly as on a board's filesystem. ``logdecode`` and
``replay --check`` then read that log.
"""

import json
import sys

import numpy as np

from desktop.errors import DesktopError
from desktop.hosts.micropython import MicroPythonError
from desktop.hosts.sil.flightgen import Recording, Scenario
from desktop.hosts.sil.host import DROGUE_PIN, MAIN_PIN, rises, run_sil
from desktop.io.files import make_output_dir


class SilInputError(DesktopError):
    """A flight or configuration the software-in-the-loop run cannot use (one line)."""


def recording_from(path):
    """A Recording of the flight file at ``path`` (any format ``desktop.io.importers`` reads)."""
    from desktop.io.importers import read_flight

    log = read_flight(path)
    if not log.has_accel:
        raise SilInputError(f"{path}: no accelerometer readings; the simulated board has an "
                            "accelerometer and needs them")
    if log.pressure_pa is None or not log.has_pressure:
        raise SilInputError(f"{path}: no pressure readings; the simulated board's barometer needs "
                            "pressure_pa (an altitude-only file cannot drive it)")
    return Recording(np.asarray(log.time_us) / 1e6, log.pressure_pa, log.accel_mps2)


def register(subparsers):
    p = subparsers.add_parser(
        "sil", help="fly a simulated or recorded flight through the unchanged firmware (no board)",
        description="Software in the loop: run the board's firmware (device/boot.py and main.py, "
                    "unchanged) on the MicroPython unix port with fake machine/time modules and "
                    "register-level sensor fakes fed by a simulated flight (default) or a recorded "
                    "one (--flight), and write the board's flight.log into OUT.")
    p.add_argument("--out", required=True, metavar="DIR", help="folder for the board's files and flight.log")
    p.add_argument("--flight", metavar="FILE", help="recorded flight to fly (flight CSV or an "
                   "importable export: docs/IMPORT.md); default: a simulated flight")
    p.add_argument("--config", metavar="CONFIG.json",
                   help="the board's flight configuration (docs/CONFIG.md)")
    p.add_argument("--seed", type=int, default=1, help="noise seed of the simulated flight (default 1)")
    p.add_argument("--boost", type=float, default=60.0, metavar="M/S2",
                   help="simulated flight: boost acceleration (default 60)")
    p.add_argument("--burn", type=float, default=1.5, metavar="S",
                   help="simulated flight: burn time (default 1.5)")
    p.add_argument("--descent", type=float, default=20.0, metavar="M/S",
                   help="simulated flight: descent rate under the drogue (default 20)")
    p.add_argument("--json", action="store_true", help="print the result as JSON")
    p.set_defaults(func=run)


def _config(path):
    """The configuration file's settings, validated (one-line errors), or {} without a file."""
    if path is None:
        return {}
    from desktop.io.config_file import config_file_values
    from shared.config import load_config

    values = config_file_values(path)
    load_config(values)
    return values


def run(args):
    out = make_output_dir(args.out, "output folder")
    config = _config(args.config)
    if args.flight:
        source = recording_from(args.flight)
    else:
        source = Scenario(seed=args.seed, boost_mps2=args.boost, burn_s=args.burn,
                          descent_mps=args.descent)
    try:
        result = run_sil(out, source, config=config)
    except MicroPythonError as exc:
        print("error: " + str(exc).splitlines()[0], file=sys.stderr)
        return 2
    summary = result.get("summary") or {}
    report = {
        "log": str(result["log"]),
        "end": result["end"],
        "reason": summary.get("reason"),
        "max_altitude_m": summary.get("max_agl_mm", 0) / 1000,
        "drogue_pulses_s": [round(t / 1e6, 3) for t, _d in rises(result, DROGUE_PIN)],
        "main_pulses_s": [round(t / 1e6, 3) for t, _d in rises(result, MAIN_PIN)],
        "errors": result.get("errors", []),
        "decode": f"python -m desktop logdecode {result['log']} --out {out / 'flight.csv'}",
        "check": f"python -m desktop replay --check {result['log']}",
    }
    if isinstance(source, Recording):  # the pulses on the recorded flight's own time axis
        offset = source.offset_s()
        report["drogue_pulses_log_s"] = [round(t - offset, 3) for t in report["drogue_pulses_s"]]
        report["main_pulses_log_s"] = [round(t - offset, 3) for t in report["main_pulses_s"]]
    if args.json:
        print(json.dumps(report, indent=2))
    else:
        print(f"{report['log']}: board ended with '{report['reason']}', max altitude "
              f"{report['max_altitude_m']:.1f} m; drogue pulse at {report['drogue_pulses_s']} s, main at "
              f"{report['main_pulses_s']} s (simulated time)")
        if "drogue_pulses_log_s" in report:
            print(f"  on {args.flight}'s time axis: drogue {report['drogue_pulses_log_s']} s, main "
                  f"{report['main_pulses_log_s']} s")
        for code, text in report["errors"]:
            print(f"  board error {code}: {text}")
        print(f"  decode: {report['decode']}")
        print(f"  check:  {report['check']}")
    if not result["log"].exists():
        print(f"error: the board wrote no {result['log'].name} (it ended with: {result['end']})",
              file=sys.stderr)
        return 1
    return 0
