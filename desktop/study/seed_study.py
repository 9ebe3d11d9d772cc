"""``python -m desktop montecarlo``: the seed's simulation study (its chapter 5), reproduced and
extended.

Simulates N flights with the seed's model (``desktop.sim.seed_model``), runs every comparison detector
(``desktop.study.baselines.METHODS``: boxcar, Butterworth, elliptic and the seed's float Kalman filter,
each with the seed's three-falling-samples rule and a velocity rule) and every integer detector of
``desktop.study.detect.METHODS`` when that module exists, and prints one row per method:

- mean, signed mean, median, 95th percentile and max of the timing error (detection time minus
  the true apogee time, the argmax of the 1 ms truth), over the flights with a detection;
- mean |true velocity| at the detection instant (m/s, the 1 ms truth);
- flights detected more than 1 s early, and flights with no detection.

Examples::

    python -m desktop montecarlo --flights 200 --seed 1
    python -m desktop montecarlo --flights 10000 --seed 1 --json
    python -m desktop montecarlo --flights 200 --seed 1 --plots out/
    python -m desktop montecarlo --seed 1 --export-csv flight7.csv --flight 7
    python -m desktop montecarlo --params seed --seed 1 --export-csv seed.csv --flight 0
    python -m desktop montecarlo --rocket examples/rockets/k400_dual_deploy.toml --flights 200 --seed 1

``--rocket`` runs the Monte-Carlo over a rocket design instead (desktop/study/rocket_study.py):
dispersed RocketPy flights, the sensor models, the flight computer and the comparison methods.

``--params seed`` flies the seed's default flight (160 m/s^2, 15 s) every time, only the noise
changing; its default pad is 0 s, the seed exactly. The Monte-Carlo default pad is 2 s.
"""

from __future__ import annotations

import argparse
import json
import math
import sys
import time
from dataclasses import asdict
from pathlib import Path

import numpy as np

from desktop.sim import seed_model as sm
from desktop.sim.seed_model import SEED_PAPER_G0_MPS2
from desktop.study import baselines

DEFAULT_PAD_S = {"montecarlo": 2.0, "seed": 0.0}
CHUNK_FLIGHTS = 2000
METRIC_KEYS = (
    "mean_abs_error_s", "mean_error_s", "median_abs_error_s", "p95_abs_error_s", "max_abs_error_s",
    "mean_abs_velocity_mps", "n_early_1s", "n_no_detection",
)
_HEADERS = ("mean|err| s", "mean err s", "median|err| s", "p95|err| s", "max|err| s",
            "mean|v| m/s", "early>1s", "none")


def detect_methods() -> dict:
    """``desktop.study.detect.METHODS`` when that module exists, else {} (other import errors raise)."""
    try:
        import desktop.study.detect as detect
    except ModuleNotFoundError as e:
        if e.name in ("desktop.study.detect",):
            return {}
        raise
    return dict(getattr(detect, "METHODS", {}))


def all_methods(include_detect: bool = True) -> dict:
    """Every method of the study, name -> callable(time_s, altitude_m, accel_mps2)."""
    methods = dict(baselines.METHODS)
    if include_detect:
        for name, fn in detect_methods().items():
            methods[name if name not in methods else f"detect:{name}"] = fn
    return methods


def simulate_flights(mode: str, seed: int, flight_indices, pad_s: float, **kw) -> sm.FlightBatch:
    """Flights of the study: drawn parameters (``montecarlo``) or the seed's default (``seed``)."""
    if mode == "seed":
        return sm.simulate(seed, flight_indices, params=sm.FlightParams.seed_default(), pad_s=pad_s, **kw)
    if mode == "montecarlo":
        return sm.simulate(seed, flight_indices, pad_s=pad_s, **kw)
    raise ValueError(f"unknown parameter mode {mode!r}")


def metrics(detection_s, true_apogee_s, true_velocity_mps) -> dict:
    """The table's row for one method (NaN detections count as "none" and are left out of the
    error statistics)."""
    det = np.asarray(detection_s, dtype=np.float64)
    err = det - np.asarray(true_apogee_s, dtype=np.float64)
    ok = ~np.isnan(det)
    e = err[ok]
    v = np.abs(np.asarray(true_velocity_mps, dtype=np.float64)[ok])
    nan = float("nan")
    return {
        "mean_abs_error_s": float(np.mean(np.abs(e))) if e.size else nan,
        "mean_error_s": float(np.mean(e)) if e.size else nan,
        "median_abs_error_s": float(np.median(np.abs(e))) if e.size else nan,
        "p95_abs_error_s": float(np.percentile(np.abs(e), 95)) if e.size else nan,
        "max_abs_error_s": float(np.max(np.abs(e))) if e.size else nan,
        "mean_abs_velocity_mps": float(np.mean(v)) if v.size else nan,
        "n_early_1s": int(np.sum(e < -1.0)),
        "n_no_detection": int(np.sum(~ok)),
    }


class StudyResult:
    """Per-flight detections of every method, the truth, and the table."""

    def __init__(self, parameters, flight_index, true_apogee_s, true_apogee_m, detections,
                 velocities, elapsed_s):
        self.parameters = parameters
        self.flight_index = flight_index
        self.true_apogee_s = true_apogee_s
        self.true_apogee_m = true_apogee_m
        self.detections = detections      # name -> (n_flights,) detection times, NaN when none
        self.velocities = velocities      # name -> (n_flights,) 1 ms truth velocity at detection
        self.elapsed_s = elapsed_s        # name -> seconds spent in the method; "simulate" too
        self.table = {name: metrics(d, true_apogee_s, velocities[name]) for name, d in detections.items()}

    def to_json(self) -> dict:
        def clean(x):
            return None if isinstance(x, float) and not math.isfinite(x) else x

        return {
            "seed": self.parameters["seed"],
            "parameters": self.parameters,
            "methods": {n: {k: clean(v) for k, v in m.items()} for n, m in self.table.items()},
            "timing_s": {k: round(v, 4) for k, v in self.elapsed_s.items()},
        }


def run_study(n_flights: int, seed: int, *, mode: str = "montecarlo", pad_s: float | None = None,
              methods: dict | None = None, chunk: int = CHUNK_FLIGHTS, progress: bool = False) -> StudyResult:
    """Simulate flights 0..n_flights-1 of ``seed`` and run every method on them (in chunks of
    ``chunk`` flights; every method works flight by flight, so chunking does not change a result)."""
    if pad_s is None:
        pad_s = DEFAULT_PAD_S[mode]
    if methods is None:
        methods = all_methods()
    n_flights = int(n_flights)
    if n_flights < 1:
        raise ValueError("need at least one flight")
    det = {name: np.full(n_flights, np.nan) for name in methods}
    vel = {name: np.full(n_flights, np.nan) for name in methods}
    apo_t = np.empty(n_flights)
    apo_m = np.empty(n_flights)
    elapsed = {"simulate": 0.0, **{name: 0.0 for name in methods}}
    bar = None
    if progress:
        from tqdm import tqdm

        bar = tqdm(total=n_flights * (1 + len(methods)), unit="flight-step", file=sys.stderr,
                   desc="montecarlo", leave=False)
    batch = None
    try:
        for c0 in range(0, n_flights, chunk):
            c1 = min(n_flights, c0 + chunk)
            t0 = time.perf_counter()
            batch = simulate_flights(mode, seed, np.arange(c0, c1), pad_s)
            elapsed["simulate"] += time.perf_counter() - t0
            apo_t[c0:c1] = batch.true_apogee_time_s
            apo_m[c0:c1] = batch.true_apogee_m
            if bar is not None:
                bar.update(c1 - c0)
            for name, fn in methods.items():
                t0 = time.perf_counter()
                d = np.asarray(fn(batch.time_s, batch.altitude_m, batch.accel_mps2), dtype=np.float64)
                elapsed[name] += time.perf_counter() - t0
                if d.shape != (c1 - c0,):
                    raise ValueError(f"method {name!r} returned shape {d.shape}, expected ({c1 - c0},)")
                det[name][c0:c1] = d
                vel[name][c0:c1] = batch.true_velocity_at(d)
                if bar is not None:
                    bar.update(c1 - c0)
    finally:
        if bar is not None:
            bar.close()
    parameters = {
        "flights": n_flights,
        "seed": int(seed),
        "params": mode,
        "pad_s": float(pad_s),
        "t_length_s": batch.t_length_s,
        "ignition_time_s": batch.ignition_time_s,
        "sample_period_s": float(batch.time_s[1] - batch.time_s[0]),
        "ranges": asdict(sm.DEFAULT_RANGES) if mode == "montecarlo" else None,
        "baselines": {
            "boxcar_window": baselines.BOXCAR_WINDOW,
            "butterworth": {"order": baselines.BUTTER_ORDER, "cutoff_hz": baselines.BUTTER_CUTOFF_HZ},
            "elliptic": {"order": baselines.ELLIP_ORDER, "rp_db": baselines.ELLIP_RP_DB,
                         "rs_db": baselines.ELLIP_RS_DB, "cutoff_hz": baselines.ELLIP_CUTOFF_HZ},
            "lockout_s_after_launch": baselines.LOCKOUT_S,
            "launch_threshold_mps2": baselines.LAUNCH_THRESHOLD_MPS2,
        },
    }
    return StudyResult(parameters, np.arange(n_flights), apo_t, apo_m, det, vel, elapsed)


def format_cell(key: str, v) -> str:
    """One table cell: counts as integers, the signed mean with a sign, "-" for no value."""
    if key.startswith("n_"):
        return f"{v:d}"
    if v is None or not math.isfinite(v):
        return "-"
    if key == "mean_error_s":
        return f"{v:+.3f}"
    if key == "mean_abs_velocity_mps":
        return f"{v:.2f}"
    return f"{v:.3f}"


def table_lines(title: str, table: dict) -> list[str]:
    """The text table: a title line, the header, one row per method (shared with the rocket study)."""
    name_w = max(len("method"), *(len(n) for n in table))
    lines = [title, "  ".join([f"{'method':<{name_w}}"] + [f"{h:>13}" for h in _HEADERS])]
    for name, m in table.items():
        lines.append("  ".join([f"{name:<{name_w}}"] + [f"{format_cell(k, m[k]):>13}" for k in METRIC_KEYS]))
    return lines


def format_table(result: StudyResult) -> str:
    p = result.parameters
    title = (f"{p['flights']} flights, seed {p['seed']}, params {p['params']}, pad {p['pad_s']:g} s, "
             f"flight {p['t_length_s']:g} s; error = detection - true apogee (s)")
    return "\n".join(table_lines(title, result.table))


# --------------------------------------------------------------------------------------------------
# Figures


def write_plots(result: StudyResult, out_dir, seed: int) -> list[Path]:
    """The seed's Figures 5.1, 5.2, 2.2-2.4 and one error histogram per method, as PNGs."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    written = []

    # One flight for the single-flight figures: the seed's default flight (no pad), flight 0.
    fl = sm.simulate_seed_flight(seed=seed, flight_index=0, pad_s=0.0)
    t = fl.time_s
    alt = fl.altitude_m
    acc = fl.accel_mps2
    t_ms = sm.seed_time_vector(fl.t_length_s)
    s_ms, _, _ = sm.integrate_truth(sm.acceleration_profile(fl.params, len(t_ms)))
    truth_t, truth_s = t_ms[:-1], s_ms[0, :-1]
    apo = float(fl.true_apogee_time_s[0])
    armed = baselines.armed_mask(t, acc)
    fs = 1.0 / baselines.sample_period_s(t)
    ks, kv, _ = baselines.seed_kalman(alt, acc - SEED_PAPER_G0_MPS2)
    filt = {
        "boxcar": baselines.boxcar(alt),
        "butterworth": baselines.butterworth(alt, fs),
        "elliptic": baselines.elliptic(alt, fs),
    }

    def det_pair(y, v=None):
        d_seed = baselines.detect_seed_rule(t, y, armed)[0]
        d_vel = baselines.detect_velocity_rule(t, baselines.first_difference(y) if v is None else v, armed)[0]
        return d_seed, d_vel

    def mark(ax, x, color, label, style="--"):
        if np.isfinite(x):
            ax.axvline(x, color=color, linestyle=style, linewidth=1.3, label=label)

    def flight_axes(title):
        fig, axes = plt.subplots(1, 2, figsize=(13, 5.6), gridspec_kw={"width_ratios": [1.3, 1]})
        fig.suptitle(title, fontsize=12)
        return fig, axes

    def finish(fig, axes, name, zoom=(apo - 2.5, apo + 2.5)):
        full, z = axes
        full.set_title("whole flight")
        z.set_title("around apogee")
        lo, hi = zoom
        z.set_xlim(lo, hi)
        ys = []
        for line in z.get_lines():
            x, y = (np.asarray(a, dtype=np.float64) for a in line.get_data())
            if x.size > 2:
                ys.append(y[(x >= lo) & (x <= hi)])
        ys = np.concatenate(ys)
        z.set_ylim(float(np.min(ys)) - 3, float(np.max(ys)) + 3)
        for ax in axes:
            ax.set_xlabel("time since ignition (s)")
            ax.set_ylabel("altitude (m)")
            ax.grid(alpha=0.3)
        handles, labels = full.get_legend_handles_labels()
        fig.legend(handles, labels, loc="lower center", ncol=4, fontsize=9, frameon=False)
        fig.tight_layout(rect=(0, 0.1, 1, 1))
        path = out / name
        fig.savefig(path, dpi=110)
        plt.close(fig)
        written.append(path)

    def fmt_err(x):
        return "none" if not np.isfinite(x) else f"{x - apo:+.2f} s"

    # Figure 5.1: truth, raw, boxcar, Kalman, detected apogee.
    fig, axes = flight_axes(f"Fig. 5.1: seed default flight (seed {seed}): Kalman vs boxcar "
                            f"(true apogee {apo:.2f} s, {fl.true_apogee_m[0]:.1f} m)")
    d_k = det_pair(ks[0:1], kv[0:1])[0]
    d_b = det_pair(filt["boxcar"])[0]
    for ax in axes:
        ax.plot(t, alt[0], ".", color="0.6", markersize=3, label="raw (noisy, quantised)")
        ax.plot(truth_t, truth_s, color="k", linewidth=1.2, label="truth (1 ms)")
        ax.plot(t, filt["boxcar"][0], color="tab:orange", label=f"boxcar ({baselines.BOXCAR_WINDOW} samples)")
        ax.plot(t, ks[0], color="tab:blue", label="seed Kalman position")
        mark(ax, apo, "k", "true apogee", ":")
        mark(ax, d_k, "tab:blue", f"Kalman, seed rule ({fmt_err(d_k)})")
        mark(ax, d_b, "tab:orange", f"boxcar, seed rule ({fmt_err(d_b)})")
    finish(fig, axes, "fig5_1_kalman_vs_boxcar.png")

    # Figures 2.2-2.4: raw vs filtered with both rules' detections.
    settings = {
        "boxcar": f"{baselines.BOXCAR_WINDOW}-sample moving average",
        "butterworth": f"Butterworth order {baselines.BUTTER_ORDER}, {baselines.BUTTER_CUTOFF_HZ:g} Hz",
        "elliptic": f"elliptic order {baselines.ELLIP_ORDER}, {baselines.ELLIP_RP_DB:g} dB / "
                    f"{baselines.ELLIP_RS_DB:g} dB, {baselines.ELLIP_CUTOFF_HZ:g} Hz",
    }
    colors = {"boxcar": "tab:orange", "butterworth": "tab:green", "elliptic": "tab:purple"}
    for fig_no, kind in (("2_2", "boxcar"), ("2_3", "butterworth"), ("2_4", "elliptic")):
        y = filt[kind]
        d_seed, d_vel = det_pair(y)
        fig, axes = flight_axes(f"Fig. {fig_no.replace('_', '.')}: raw altitude vs {settings[kind]} "
                                f"(seed default flight, seed {seed})")
        for ax in axes:
            ax.plot(t, alt[0], ".", color="0.6", markersize=3, label="raw (noisy, quantised)")
            ax.plot(truth_t, truth_s, color="k", linewidth=1.0, alpha=0.6, label="truth (1 ms)")
            ax.plot(t, y[0], color=colors[kind], linewidth=1.6, label=f"{kind} output")
            mark(ax, apo, "k", "true apogee", ":")
            mark(ax, d_seed, "tab:red", f"seed rule ({fmt_err(d_seed)})")
            mark(ax, d_vel, "tab:blue", f"velocity rule ({fmt_err(d_vel)})", "-.")
        finish(fig, axes, f"fig{fig_no}_{kind}.png")

    # Figure 5.2: per-flight absolute error, Kalman vs boxcar.
    kal, box = "seed-kalman/seed", "boxcar/seed"
    e_k = np.abs(result.detections[kal] - result.true_apogee_s)
    e_b = np.abs(result.detections[box] - result.true_apogee_s)
    fig, ax = plt.subplots(figsize=(11, 5))
    idx = result.flight_index
    ms = 4 if len(idx) <= 500 else 1.5
    ax.plot(idx, e_b, "o", color="tab:orange", markersize=ms,
            label=f"boxcar ({baselines.BOXCAR_WINDOW} samples), seed rule: mean {np.nanmean(e_b):.3f} s")
    ax.plot(idx, e_k, "o", color="tab:blue", markersize=ms,
            label=f"seed Kalman, seed rule: mean {np.nanmean(e_k):.3f} s")
    ax.axhline(np.nanmean(e_b), color="tab:orange", linewidth=1)
    ax.axhline(np.nanmean(e_k), color="tab:blue", linewidth=1)
    if "flight-computer" in result.detections:
        e_f = np.abs(result.detections["flight-computer"] - result.true_apogee_s)
        ax.plot(idx, e_f, "o", color="tab:green", markersize=ms,
                label=f"this flight computer (shared/): mean {np.nanmean(e_f):.3f} s")
        ax.axhline(np.nanmean(e_f), color="tab:green", linewidth=1)
    ax.set_xlabel("flight index")
    ax.set_ylabel("|detection - true apogee| (s)")
    p = result.parameters
    ax.set_title(f"Fig. 5.2: absolute error in apogee detection, {p['flights']} flights "
                 f"({p['params']}, seed {p['seed']}, pad {p['pad_s']:g} s)")
    ax.grid(alpha=0.3)
    ax.legend(loc="upper right")
    fig.tight_layout()
    path = out / "fig5_2_abs_error.png"
    fig.savefig(path, dpi=110)
    plt.close(fig)
    written.append(path)

    # Error histograms, one panel per method, common bins.
    names = list(result.detections)
    errs = {n: result.detections[n] - result.true_apogee_s for n in names}
    finite = np.concatenate([e[np.isfinite(e)] for e in errs.values()]) if names else np.array([0.0])
    lo = max(-5.0, float(np.floor(np.min(finite) * 4) / 4)) if finite.size else -1.0
    hi = min(5.0, float(np.ceil(np.max(finite) * 4) / 4)) if finite.size else 1.0
    if hi - lo < 0.5:
        lo, hi = lo - 0.25, hi + 0.25
    bins = np.linspace(lo, hi, 61)
    ncol = 2
    nrow = math.ceil(len(names) / ncol)
    fig, axes = plt.subplots(nrow, ncol, figsize=(12, 2.6 * nrow + 0.8), sharex=True, squeeze=False)
    for ax, name in zip(axes.flat, names, strict=False):
        e = errs[name]
        ok = e[np.isfinite(e)]
        outside = int(np.sum((ok < lo) | (ok > hi)))
        ax.hist(np.clip(ok, lo, hi), bins=bins, color="tab:blue", alpha=0.8)
        ax.axvline(0, color="k", linewidth=0.8)
        m = result.table[name]
        note = f"mean|e| {m['mean_abs_error_s']:.3f} s, none {m['n_no_detection']}"
        if outside:
            note += f", {outside} outside (clipped)"
        ax.set_title(f"{name}: {note}", fontsize=9)
        ax.set_ylabel("flights")
        ax.grid(alpha=0.3)
    for ax in axes.flat[len(names):]:
        ax.set_visible(False)
    for ax in axes[-1]:
        ax.set_xlabel("detection - true apogee (s)")
    fig.suptitle(f"Timing error per method ({p['flights']} flights, {p['params']}, seed {p['seed']}, "
                 f"pad {p['pad_s']:g} s)")
    fig.tight_layout()
    path = out / "error_histograms.png"
    fig.savefig(path, dpi=100)
    plt.close(fig)
    written.append(path)
    return written


# --------------------------------------------------------------------------------------------------
# Flight-CSV export


def export_csv(path, mode: str, seed: int, flight_index: int, pad_s: float) -> sm.FlightBatch:
    """Write flight ``flight_index`` of the study (same seed, mode and pad) as a flight CSV."""
    from desktop.io.flightcsv import write_flight_csv

    batch = simulate_flights(mode, seed, [flight_index], pad_s)
    columns, meta = sm.flight_csv_columns(batch, 0)
    meta["params"] = mode
    comments = (
        "Simulated with the seed study's flight model (desktop/sim/seed_model.py), "
        "python -m desktop montecarlo",
        "accel_mps2 is specific force: the floor-quantised kinematic acceleration + 9.81",
    )
    write_flight_csv(path, columns, meta, comments)
    return batch


# --------------------------------------------------------------------------------------------------
# CLI


def register(subparsers):
    p = subparsers.add_parser(
        "montecarlo",
        help="the seed's Monte-Carlo study: simulate flights, compare apogee detectors",
        description=__doc__.split("\n\n")[0],
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    p.add_argument("--flights", type=int, default=200, help="number of flights (default 200)")
    p.add_argument("--seed", type=int, default=1, help="random seed (default 1)")
    p.add_argument("--params", choices=("montecarlo", "seed"), default="montecarlo",
                   help="drawn parameters (default) or the seed's default flight every time")
    p.add_argument("--pad-s", type=float, default=None,
                   help="seconds at rest before ignition (default 2 for montecarlo, 0 for seed; with "
                        "--rocket: the rocket file's [board] pad_s)")
    p.add_argument("--json", action="store_true", help="print the results as JSON")
    p.add_argument("--plots", metavar="DIR", help="write the figures (PNG) to DIR")
    p.add_argument("--no-detect", action="store_true",
                   help="leave out desktop.study.detect's integer detectors")
    p.add_argument("--export-csv", metavar="PATH",
                   help="write flight --flight as a flight CSV and exit (no study)")
    p.add_argument("--flight", type=int, default=0, help="flight index for --export-csv (default 0)")
    r = p.add_argument_group(
        "Monte-Carlo over a rocket design (desktop/study/rocket_study.py, docs/SIMULATION.md)")
    r.add_argument("--rocket", metavar="ROCKET.toml",
                   help="fly dispersed RocketPy flights of this rocket instead of the seed's model")
    r.add_argument("--workers", type=int, metavar="K", help="processes (default: all cores)")
    r.add_argument("--sensors", metavar="PROFILE",
                   help="sensor profile BARO+ACCEL (default: the rocket file's [board] sensors)")
    r.add_argument("--max-wind-mps", type=float, metavar="V",
                   help="wind speed drawn uniformly in 0..V m/s (default 9)")
    p.set_defaults(func=main)
    return p


def main(args) -> int:
    if getattr(args, "rocket", None):
        from desktop.study import rocket_study as rocket_montecarlo

        return rocket_montecarlo.main(args)
    for flag in ("workers", "sensors", "max_wind_mps"):
        if getattr(args, flag, None) is not None:
            print(f"montecarlo: error: --{flag.replace('_', '-')} needs --rocket", file=sys.stderr)
            return 2
    pad_s = DEFAULT_PAD_S[args.params] if args.pad_s is None else args.pad_s
    if args.export_csv:
        batch = export_csv(args.export_csv, args.params, args.seed, args.flight, pad_s)
        print(f"wrote {args.export_csv}: flight {args.flight} of seed {args.seed} ({args.params}, pad "
              f"{pad_s:g} s), true apogee {batch.true_apogee_m[0]:.1f} m at "
              f"{batch.true_apogee_time_s[0]:.3f} s", file=sys.stderr if args.json else sys.stdout)
        return 0
    progress = (not args.json) and sys.stderr.isatty()
    result = run_study(args.flights, args.seed, mode=args.params, pad_s=pad_s,
                       methods=all_methods(include_detect=not args.no_detect), progress=progress)
    if args.json:
        print(json.dumps(result.to_json(), indent=2))
    else:
        print(format_table(result))
        total = sum(result.elapsed_s.values())
        print(f"compute: {args.flights} flights in {total:.2f} s, simulation and detectors "
              f"({args.flights / max(total, 1e-9):.0f} flights/s)")
    if args.plots:
        for path in write_plots(result, args.plots, args.seed):
            print(f"wrote {path}", file=sys.stderr)
    return 0
