"""Slow barometers: pressure transients on a barometer read at 20 or 10 Hz beside a 100 Hz
accelerometer, through the flight computer; drogue minus true apogee per rate.

    python tools/bench_slow_baro.py            # 432 runs per rate, about 4 minutes
    python tools/bench_slow_baro.py --json     # every run

The three rockets of tests/support/fault_flight.py (Mach 1.0, 1.65, 2.4); transients of +-120 and
+-300 m rising in 0.1, 0.3 and 0.5 s, decaying over 0.5 s, 3 s or persisting, at burnout + 0.3 s,
mid coast, 2 s and 0.5 s before apogee. The fault benchmark's boards read at 50 and 100 Hz; real
logs of other boards read their barometer at 10 to 20 Hz (docs/BENCHMARKS.md, "A pressure pulse in
one reading; slots that wait"). The backup timer at nominal apogee + 3 s, as docs/CONFIG.md says.
"""

import argparse
import itertools
import json
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from tests.support.fault_flight import (  # noqa: E402
    MACH_ROCKET,
    SUBSONIC_ROCKET,
    Faults,
    Rocket,
    fly,
    run,
    slow_barometer,
)

ROCKETS = {"mach1.0": SUBSONIC_ROCKET, "mach1.65": Rocket(thrust_n=480.0, burn_s=1.8, prop_kg=0.3),
           "mach2.4": MACH_ROCKET}
RATES_HZ = (20, 10)
AMPLITUDES_M = (300, -300, 120, -120)
RISES_S = (0.1, 0.3, 0.5)
DECAYS_S = (0.5, 3.0, 0.0)  # 0: persists
EARLY_S = 0.5  # the goal: no drogue more than this before the true apogee
LATE_S = 1.0


def onsets_s(rocket, apogee_s):
    """When the transients begin: just after burnout, mid coast, 2 s and 0.5 s before apogee."""
    return (rocket.burn_s + 0.3, 0.5 * (rocket.burn_s + apogee_s), apogee_s - 2.0, apogee_s - 0.5)


def runs(rockets, rates_hz, progress=None):
    """One dict per run: the case and its drogue minus the true apogee (s; None: no drogue)."""
    out = []
    for name in rockets:
        rocket = ROCKETS[name]
        apogee_s = fly(rocket, Faults()).apogee_s
        for at_s, dh_m, rise_s, decay_s in itertools.product(onsets_s(rocket, apogee_s), AMPLITUDES_M,
                                                            RISES_S, DECAYS_S):
            flight = fly(rocket, Faults(transient_at_s=at_s, transient_m=dh_m, transient_rise_s=rise_s,
                                        transient_decay_s=decay_s))
            for hz in rates_hz:
                res = run(slow_barometer(flight, hz), backup_drogue_s=round(apogee_s + 3))
                error_s = None if res.drogue_s is None else round(res.drogue_s - flight.apogee_s, 3)
                out.append({"rocket": name, "rate_hz": hz, "at_s": round(at_s, 2), "dh_m": dh_m,
                            "rise_s": rise_s, "decay_s": decay_s, "error_s": error_s})
                if progress is not None:
                    progress.update(1)
    return out


def summary(rows, rates_hz):
    """Per rate: runs, drogues more than EARLY_S early and more than LATE_S late, none, the most
    early and most late (s), mean |error| (s)."""
    table = []
    for hz in rates_hz:
        err = [r["error_s"] for r in rows if r["rate_hz"] == hz and r["error_s"] is not None]
        table.append({"rate_hz": hz, "runs": sum(r["rate_hz"] == hz for r in rows),
                      "early": sum(e < -EARLY_S for e in err), "late": sum(e > LATE_S for e in err),
                      "none": sum(r["rate_hz"] == hz and r["error_s"] is None for r in rows),
                      "most_early_s": -min(err), "most_late_s": max(err),
                      "mean_abs_s": round(float(np.mean(np.abs(err))), 3)})
    return table


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--rockets", nargs="+", default=list(ROCKETS), choices=list(ROCKETS),
                    help="rockets (default: all three)")
    ap.add_argument("--rates", nargs="+", type=int, default=list(RATES_HZ), choices=[10, 20, 25, 50],
                    help="barometer rates, Hz (default: 20 10)")
    ap.add_argument("--json", action="store_true", help="print the summary and every run as JSON")
    args = ap.parse_args(argv)
    from tqdm import tqdm

    n = len(args.rockets) * len(AMPLITUDES_M) * len(RISES_S) * len(DECAYS_S) * 4 * len(args.rates)
    with tqdm(total=n, unit="run", file=sys.stderr, disable=None) as bar:
        rows = runs(args.rockets, args.rates, bar)
    table = summary(rows, args.rates)
    if args.json:
        print(json.dumps({"summary": table, "runs": rows}, indent=1))
        return 0
    print("| barometer | runs | more than %.1f s early | more than %.1f s late | no drogue | most early s "
          "| most late s | mean \\|err\\| s |" % (EARLY_S, LATE_S))
    print("|---|---|---|---|---|---|---|---|")
    for t in table:
        print("| %d Hz | %d | %d | %d | %d | %.2f | %.2f | %.3f |" % (
            t["rate_hz"], t["runs"], t["early"], t["late"], t["none"], t["most_early_s"], t["most_late_s"],
            t["mean_abs_s"]))
    return 0


if __name__ == "__main__":
    sys.exit(main())
