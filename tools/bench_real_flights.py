"""Replay the 16 real AltOS flights through the flight computer and print a markdown table of
our drogue times beside the reference apogee and the boards' own decisions.

    python tools/bench_real_flights.py
"""

import json
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from desktop.io.flightcsv import read_flight_csv  # noqa: E402
from desktop.review.replay import config_for, replay  # noqa: E402

DATA = ROOT / "tests" / "data" / "flights" / "altos"


def main():
    reference = json.loads((DATA / "reference.json").read_text())["flights"]
    print("| flight | board | reference apogee s | ours: drogue s | error s | board logged s | board error s "
          "| ours: main s at baro m |")
    print("|---|---|---|---|---|---|---|---|")
    ours, boards = [], []
    for name, ref in sorted(reference.items()):
        log = read_flight_csv(DATA / name)
        res = replay(log, config_for(log))
        drogue, main_ev = res.first("drogue"), res.first("main")
        apogee = ref["apogee_time_s"]
        err = drogue.time_s - apogee if drogue and apogee is not None else None
        board_err = ref["board_logged_s"] - apogee if apogee is not None else None
        if ref["clean"]:
            ours.append(abs(err))
            boards.append(abs(board_err))
        main_txt = "-"
        if main_ev is not None:
            baro_m = float(np.median(res.raw_agl_m[main_ev.index - 2:main_ev.index + 1]))
            main_txt = "%.2f at %.0f" % (main_ev.time_s, baro_m)
        note = " (non-flight)" if ref["non_flight"] else ("" if ref["clean"] else " (anomalous)")
        print("| %s%s | %s | %s | %s | %s | %.2f | %s | %s |" % (
            name.replace(".csv", ""), note, ref["board"], "-" if apogee is None else "%.2f" % apogee,
            "none" if drogue is None else "%.2f" % drogue.time_s, "-" if err is None else "%+.2f" % err,
            ref["board_logged_s"], "-" if board_err is None else "%+.2f" % board_err, main_txt))
    print()
    print("14 clean flights: ours mean |error| %.3f s, max %.3f s; boards mean %.3f s, max %.3f s"
          % (np.mean(ours), np.max(ours), np.mean(boards), np.max(boards)))


if __name__ == "__main__":
    main()
