"""Figures of a rocket Monte-Carlo (PNG): each method's error histogram, one example flight with
every method's estimate, and the flight computer's error against the flight's draws.

Each figure is one function taking pyplot and what it draws, returning the path it wrote;
``write_plots`` draws them all for a study result.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from desktop.figures import pyplot, save_png
from desktop.study.rocket_comparison import BOXCAR_SECONDS, comparison_altitudes
from desktop.study.rocket_flight import METHODS, evaluate_flight
from desktop.study.rocket_results import RocketStudyResult


def error_histograms(plt, result: RocketStudyResult, path: Path, title: str) -> Path:
    """Timing error of each method, one panel each on its own scale."""
    fig, axes = plt.subplots(len(METHODS), 1, figsize=(10, 2.3 * len(METHODS) + 0.8), squeeze=False)
    for ax, m in zip(axes[:, 0], METHODS, strict=True):
        e = result.errors(m)
        ok = e[np.isfinite(e)]
        lo = float(np.min(ok)) if ok.size else -1.0
        hi = float(np.max(ok)) if ok.size else 1.0
        pad = max(0.02, 0.05 * (hi - lo))
        ax.hist(ok, bins=np.linspace(lo - pad, hi + pad, 50), color="tab:green" if m == "flight-computer"
                else "tab:blue", alpha=0.85)
        ax.axvline(0, color="k", linewidth=0.8)
        t = result.table[m]
        ax.set_title(f"{m}: mean |err| {t['mean_abs_error_s']:.3f} s, p95 {t['p95_abs_error_s']:.3f} s, "
                     f"mean err {t['mean_error_s']:+.3f} s, none {t['n_no_detection']}", fontsize=9)
        ax.set_ylabel("flights")
        ax.set_xlabel("detection - true apogee (s)")
        ax.grid(alpha=0.3)
    fig.suptitle(f"Timing error per method (each panel its own scale)\n{title}", fontsize=10)
    return save_png(plt, fig, path, dpi=100)


def example_flight(plt, result: RocketStudyResult, path: Path, example_index: int) -> Path:
    """Flight ``example_index`` (re-simulated in this process: deterministic): truth, the barometer,
    every method's estimate and detection, whole record and around apogee."""
    p = result.parameters()
    ex = evaluate_flight(result.settings, example_index, detail=True)
    d = ex["_detail"]
    traj, log, rep = d["trajectory"], d["log"], d["replay"]
    t_b, alt_b, acc_b = d["baseline_inputs"]
    apo = traj.apogee_time_s
    compared = comparison_altitudes(t_b, alt_b, acc_b)
    colors = {"flight-computer": "tab:green", "seed-kalman/seed": "tab:blue", "boxcar/seed": "tab:orange",
              "butterworth/seed": "tab:purple"}
    fig, axes = plt.subplots(3, 1, figsize=(11, 11), gridspec_kw={"height_ratios": [1.1, 1.2, 0.9]})
    full, zoom, vel = axes
    for ax in (full, zoom):
        ax.plot(log.time_s, rep.raw_agl_m, ".", color="0.6", markersize=2, label="barometer (raw, above pad)")
        ax.plot(traj.time_s, traj.altitude_m, color="k", linewidth=1.2, label="truth")
        ax.plot(log.time_s, rep.agl_m, color=colors["flight-computer"], linewidth=1.4,
                label="flight computer (filtered)")
        for m, label in (("seed-kalman/seed", "seed Kalman position"),
                         ("boxcar/seed", f"boxcar {BOXCAR_SECONDS:g} s"),
                         ("butterworth/seed", "Butterworth 1 Hz")):
            ax.plot(t_b, compared[m], color=colors[m], linewidth=1.0, label=label)
    for ax in (full, zoom, vel):
        ax.axvline(apo, color="k", linestyle=":", linewidth=1.2, label="true apogee")
        for m in METHODS:
            x = ex["detections"][m]
            if math.isfinite(x):
                ax.axvline(x, color=colors[m], linestyle="--", linewidth=1.2,
                           label=f"{m} ({x - apo:+.3f} s)")
        ax.grid(alpha=0.3)
        ax.set_xlabel("time since ignition (s)")
    full.set_xlim(min(-2.0, float(log.time_s[0])), float(log.time_s[-1]))
    full.set_ylabel("altitude above pad (m)")
    full.set_title("whole record (the pad before ignition at negative times)")
    lo, hi = apo - 3.0, apo + 3.0
    zoom.set_xlim(lo, hi)
    inside = (traj.time_s >= lo) & (traj.time_s <= hi)
    ztop, zbot = float(np.max(traj.altitude_m[inside])), float(np.min(traj.altitude_m[inside]))
    zoom.set_ylim(zbot - 0.3 * (ztop - zbot) - 5, ztop + 0.15 * (ztop - zbot) + 5)
    zoom.set_ylabel("altitude above pad (m)")
    zoom.set_title("around apogee")
    vel.plot(traj.time_s, traj.velocity_mps, color="k", linewidth=1.2, label="truth (vertical)")
    vel.plot(log.time_s, rep.vel_mps, color=colors["flight-computer"], linewidth=1.2,
             label="flight computer velocity estimate")
    vel.set_xlim(lo, hi)
    vel.set_ylim(-35, 35)
    vel.axhline(0, color="k", linewidth=0.6)
    vel.set_ylabel("vertical velocity (m/s)")
    vel.set_title("velocity around apogee")
    handles, labels = zoom.get_legend_handles_labels()
    zoom.legend(handles, labels, loc="lower center", fontsize=8, ncol=2)
    vel.legend(loc="upper right", fontsize=8)
    dr = ex["draw"]
    fig.suptitle(
        f"{p['name']}, flight {example_index} (seed {p['seed']}): apogee {traj.apogee_m:.0f} m at "
        f"{apo:.2f} s, max Mach {traj.max_mach:.2f}, wind {dr['wind_speed_mps']:.1f} m/s, rail "
        f"{dr['inclination_deg']:.1f} deg, transonic c {ex['transonic_c']:+.3f}", fontsize=10)
    return save_png(plt, fig, path, dpi=100)


def fc_error_vs_draws(plt, result: RocketStudyResult, path: Path, title: str) -> Path:
    """The flight computer's timing error against each flight's drawn parameters."""
    e = result.errors("flight-computer")
    fl = result.flights
    xs = [
        ("max Mach", [f["max_mach"] for f in fl]),
        ("transonic coefficient c (dp = c q w(M))", [f["transonic_c"] for f in fl]),
        ("wind speed (m/s)", [f["draw"]["wind_speed_mps"] for f in fl]),
        ("drag coefficient scale", [f["draw"]["cd_scale"] for f in fl]),
        ("rail inclination (deg)", [f["draw"]["inclination_deg"] for f in fl]),
        ("accelerometer bias (m/s²)", [f["accel_bias_mps2"] for f in fl]),
    ]
    fig, axes = plt.subplots(2, 3, figsize=(13, 7.5), sharey=True)
    for ax, (label, x) in zip(axes.flat, xs, strict=True):
        ax.plot(x, e, "o", markersize=3, color="tab:green")
        ax.axhline(0, color="k", linewidth=0.6)
        ax.set_xlabel(label)
        ax.grid(alpha=0.3)
    for ax in axes[:, 0]:
        ax.set_ylabel("flight computer: drogue - true apogee (s)")
    fig.suptitle(f"Flight computer timing error against the flight's draws\n{title}", fontsize=10)
    return save_png(plt, fig, path, dpi=100)


def write_plots(result: RocketStudyResult, out_dir, example_index: int = 0) -> list[Path]:
    """Error histograms per method, one example flight, and the flight computer's error against
    the flight's parameters; PNGs in ``out_dir``."""
    plt = pyplot()
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    p = result.parameters()
    stem = Path(p["rocket"]).stem
    title = (f"{p['name']}: {p['flights']} flights, seed {p['seed']}, {p['sensor_profile']} at "
             f"{p['rate_hz']:g} Hz")
    return [
        error_histograms(plt, result, out / f"{stem}_error_histograms.png", title),
        example_flight(plt, result, out / f"{stem}_example_flight.png", example_index),
        fc_error_vs_draws(plt, result, out / f"{stem}_fc_error_vs_draws.png", title),
    ]
