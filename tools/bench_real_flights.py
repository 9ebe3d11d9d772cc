"""Replay the 16 real AltOS flights and the 3 FIRM flights through the flight computer and print
markdown tables of our drogue times beside the reference apogee, the boards' own decisions and
AltOS's published algorithm replayed on the same record (desktop/study/altos.py).

    python tools/bench_real_flights.py
    python tools/bench_real_flights.py --layout alternating   # the sensors on separate rows

``--layout`` rewrites each AltOS flight's rows first (tests/support/row_layouts.py): ``alternating``,
``merged_alternating``, ``mixed_rate``, ``bursty`` or ``split_rows``.
"""

import argparse
import json
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from desktop.io.flightcsv import read_flight_csv  # noqa: E402
from desktop.review.replay import config_for, replay  # noqa: E402
from desktop.study.altos import run_altos_log  # noqa: E402

DATA = ROOT / "tests" / "data" / "flights" / "altos"
FIRM = ROOT / "tests" / "data" / "flights" / "firm"


LAYOUTS = ("alternating", "merged_alternating", "mixed_rate", "bursty", "split_rows")


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--layout", choices=LAYOUTS,
                    help="rewrite the rows of each AltOS flight first (the FIRM flights as logged)")
    args = ap.parse_args(argv)
    from tests.support import row_layouts

    reference = json.loads((DATA / "reference.json").read_text())["flights"]
    print("| flight | board | reference apogee s | ours: drogue s | error s | board logged s | board error s "
          "| ours: main s at baro m | AltOS replay: error s |")
    print("|---|---|---|---|---|---|---|---|---|")
    ours, boards, altos = [], [], []
    for name, ref in sorted(reference.items()):
        log = read_flight_csv(DATA / name)
        if args.layout:
            log = getattr(row_layouts, args.layout)(log)
        res = replay(log, config_for(log))
        drogue, main_ev = res.first("drogue"), res.first("main")
        apogee = ref["apogee_time_s"]
        err = drogue.time_s - apogee if drogue and apogee is not None else None
        board_err = ref["board_logged_s"] - apogee if apogee is not None else None
        altos_s = run_altos_log(log).time("drogue")
        altos_txt = "none" if not np.isfinite(altos_s) else (
            "%.2f" % altos_s if apogee is None else "%+.2f" % (altos_s - apogee))
        if ref["clean"]:
            ours.append(abs(err))
            boards.append(abs(board_err))
            altos.append(abs(altos_s - apogee))
        main_txt = "-"
        if main_ev is not None:
            # (the last three barometric readings: a layout may leave rows without one)
            baro = res.raw_agl_m[:main_ev.index + 1]
            baro_m = float(np.median(baro[~np.isnan(baro)][-3:]))
            main_txt = "%.2f at %.0f" % (main_ev.time_s, baro_m)
        note = " (non-flight)" if ref["non_flight"] else ("" if ref["clean"] else " (anomalous)")
        print("| %s%s | %s | %s | %s | %s | %.2f | %s | %s | %s |" % (
            name.replace(".csv", ""), note, ref["board"], "-" if apogee is None else "%.2f" % apogee,
            "none" if drogue is None else "%.2f" % drogue.time_s, "-" if err is None else "%+.2f" % err,
            ref["board_logged_s"], "-" if board_err is None else "%+.2f" % board_err, main_txt, altos_txt))
    print()
    print("14 clean flights: ours mean |error| %.3f s, max %.3f s; boards mean %.3f s, max %.3f s; "
          "AltOS replay mean %.3f s, max %.3f s" % (np.mean(ours), np.max(ours), np.mean(boards),
                                                    np.max(boards), np.mean(altos), np.max(altos)))
    print()
    print("| FIRM flight | reference apogee s | ours: drogue s | error s | ours: main s "
          "| AltOS replay: error s |")
    print("|---|---|---|---|---|---|")
    for path in sorted(FIRM.glob("*.csv")):
        log = read_flight_csv(path)
        apogee = log.metadata_float("reference_apogee_time_s")
        res = replay(log, config_for(log))
        drogue, main_ev = res.first("drogue"), res.first("main")
        altos_s = run_altos_log(log).time("drogue")
        print("| %s | %.2f | %s | %s | %s | %+.2f |" % (
            path.stem, apogee, "none" if drogue is None else "%.2f" % drogue.time_s,
            "-" if drogue is None else "%+.2f" % (drogue.time_s - apogee),
            "-" if main_ev is None else "%.2f" % main_ev.time_s, altos_s - apogee))


if __name__ == "__main__":
    main()
