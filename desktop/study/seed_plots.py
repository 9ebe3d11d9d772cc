"""Figures of the seed-paper study: the paper's Figures 5.1, 5.2 and 2.2-2.4, and error histograms.

Each figure is one function that takes what it draws and returns the PNG path it wrote;
``write_plots`` draws them all for a study result.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from desktop.figures import pyplot, save_png
from desktop.sim import seed_model as sm
from desktop.sim.seed_model import SEED_PAPER_G0_MPS2
from desktop.study import baselines

_ZOOM_HALF_WIDTH_S = 2.5  # the "around apogee" panel spans apogee +- this
_ZOOM_MARGIN_M = 3.0      # altitude margin above and below the zoomed curves
_HIST_LIMIT_S = 5.0       # histogram errors beyond +-this are clipped into the end bins
_HIST_BINS = 60


@dataclass
class _SeedFlight:
    """The paper's default flight (no pad), flight 0 of the random seed: what the single-flight
    figures draw."""

    time_s: np.ndarray
    altitude_m: np.ndarray
    truth_time_s: np.ndarray
    truth_altitude_m: np.ndarray
    apogee_s: float
    apogee_m: float
    armed: np.ndarray

    def detections(self, y, v=None):
        """(seed-rule, velocity-rule) detection times of one filtered altitude (and velocity)."""
        y = np.atleast_2d(y)
        d_seed = baselines.detect_seed_rule(self.time_s, y, self.armed)[0]
        vel = baselines.first_difference(y) if v is None else np.atleast_2d(v)
        d_vel = baselines.detect_velocity_rule(self.time_s, vel, self.armed)[0]
        return d_seed, d_vel

    def error_label(self, x):
        return "none" if not np.isfinite(x) else f"{x - self.apogee_s:+.2f} s"


def _seed_flight(random_seed: int):
    """The paper's default flight as a one-flight batch, and what the single-flight figures need."""
    batch = sm.simulate_paper_flight(seed=random_seed, flight_index=0, pad_s=0.0)
    t_ms = sm.seed_time_vector(batch.t_length_s)
    s_ms, _, _ = sm.integrate_truth(sm.acceleration_profile(batch.params, len(t_ms)))
    flight = _SeedFlight(batch.time_s, batch.altitude_m[0], t_ms[:-1], s_ms[0, :-1],
                         float(batch.true_apogee_time_s[0]), float(batch.true_apogee_m[0]),
                         baselines.armed_mask(batch.time_s, batch.accel_mps2))
    return flight, batch


def _mark(ax, x, color, label, style="--"):
    if np.isfinite(x):
        ax.axvline(x, color=color, linestyle=style, linewidth=1.3, label=label)


def _flight_figure(plt, title):
    fig, axes = plt.subplots(1, 2, figsize=(13, 5.6), gridspec_kw={"width_ratios": [1.3, 1]})
    fig.suptitle(title, fontsize=12)
    return fig, axes


def _finish_flight_figure(plt, fig, axes, flight: _SeedFlight, path: Path) -> Path:
    full, zoom = axes
    full.set_title("whole flight")
    zoom.set_title("around apogee")
    lo, hi = flight.apogee_s - _ZOOM_HALF_WIDTH_S, flight.apogee_s + _ZOOM_HALF_WIDTH_S
    zoom.set_xlim(lo, hi)
    ys = []
    for line in zoom.get_lines():
        x, y = (np.asarray(a, dtype=np.float64) for a in line.get_data())
        if x.size > 2:
            ys.append(y[(x >= lo) & (x <= hi)])
    ys = np.concatenate(ys)
    zoom.set_ylim(float(np.min(ys)) - _ZOOM_MARGIN_M, float(np.max(ys)) + _ZOOM_MARGIN_M)
    for ax in axes:
        ax.set_xlabel("time since ignition (s)")
        ax.set_ylabel("altitude (m)")
        ax.grid(alpha=0.3)
    handles, labels = full.get_legend_handles_labels()
    fig.legend(handles, labels, loc="lower center", ncol=4, fontsize=9, frameon=False)
    return save_png(plt, fig, path, dpi=110, rect=(0, 0.1, 1, 1))


def _raw_and_truth(ax, flight: _SeedFlight, faint_truth=False):
    ax.plot(flight.time_s, flight.altitude_m, ".", color="0.6", markersize=3, label="raw (noisy, quantised)")
    ax.plot(flight.truth_time_s, flight.truth_altitude_m, color="k", linewidth=1.0 if faint_truth else 1.2,
            alpha=0.6 if faint_truth else 1.0, label="truth (1 ms)")


def figure_5_1(plt, flight: _SeedFlight, kalman_alt, kalman_vel, boxcar_alt, random_seed: int,
               path: Path) -> Path:
    """Truth, raw, boxcar and the paper's Kalman filter, with their seed-rule detections."""
    fig, axes = _flight_figure(plt, f"Fig. 5.1: seed default flight (seed {random_seed}): Kalman vs boxcar "
                                    f"(true apogee {flight.apogee_s:.2f} s, {flight.apogee_m:.1f} m)")
    d_k = flight.detections(kalman_alt, kalman_vel)[0]
    d_b = flight.detections(boxcar_alt)[0]
    for ax in axes:
        _raw_and_truth(ax, flight)
        ax.plot(flight.time_s, boxcar_alt, color="tab:orange",
                label=f"boxcar ({baselines.BOXCAR_WINDOW} samples)")
        ax.plot(flight.time_s, kalman_alt, color="tab:blue", label="seed Kalman position")
        _mark(ax, flight.apogee_s, "k", "true apogee", ":")
        _mark(ax, d_k, "tab:blue", f"Kalman, seed rule ({flight.error_label(d_k)})")
        _mark(ax, d_b, "tab:orange", f"boxcar, seed rule ({flight.error_label(d_b)})")
    return _finish_flight_figure(plt, fig, axes, flight, path)


def figure_2_x(plt, flight: _SeedFlight, fig_no: str, kind: str, filtered_alt, random_seed: int,
               path: Path) -> Path:
    """Figures 2.2-2.4: raw altitude against one conventional filter, with both rules' detections."""
    settings = {
        "boxcar": f"{baselines.BOXCAR_WINDOW}-sample moving average",
        "butterworth": f"Butterworth order {baselines.BUTTER_ORDER}, {baselines.BUTTER_CUTOFF_HZ:g} Hz",
        "elliptic": f"elliptic order {baselines.ELLIP_ORDER}, {baselines.ELLIP_RP_DB:g} dB / "
                    f"{baselines.ELLIP_RS_DB:g} dB, {baselines.ELLIP_CUTOFF_HZ:g} Hz",
    }
    colors = {"boxcar": "tab:orange", "butterworth": "tab:green", "elliptic": "tab:purple"}
    d_seed, d_vel = flight.detections(filtered_alt)
    fig, axes = _flight_figure(plt, f"Fig. {fig_no}: raw altitude vs {settings[kind]} "
                                    f"(seed default flight, seed {random_seed})")
    for ax in axes:
        _raw_and_truth(ax, flight, faint_truth=True)
        ax.plot(flight.time_s, filtered_alt, color=colors[kind], linewidth=1.6, label=f"{kind} output")
        _mark(ax, flight.apogee_s, "k", "true apogee", ":")
        _mark(ax, d_seed, "tab:red", f"seed rule ({flight.error_label(d_seed)})")
        _mark(ax, d_vel, "tab:blue", f"velocity rule ({flight.error_label(d_vel)})", "-.")
    return _finish_flight_figure(plt, fig, axes, flight, path)


def figure_5_2(plt, result, path: Path) -> Path:
    """Per-flight absolute error: the paper's Kalman filter, the boxcar and this flight computer."""
    fig, ax = plt.subplots(figsize=(11, 5))
    idx = result.flight_index
    marker_size = 4 if len(idx) <= 500 else 1.5
    series = (("boxcar/seed", "tab:orange", f"boxcar ({baselines.BOXCAR_WINDOW} samples), seed rule"),
              ("seed-kalman/seed", "tab:blue", "seed Kalman, seed rule"),
              ("flight-computer", "tab:green", "this flight computer (shared/)"))
    for name, color, label in series:
        if name not in result.detections:
            continue
        err = np.abs(result.detections[name] - result.true_apogee_s)
        ax.plot(idx, err, "o", color=color, markersize=marker_size,
                label=f"{label}: mean {np.nanmean(err):.3f} s")
        ax.axhline(np.nanmean(err), color=color, linewidth=1)
    ax.set_xlabel("flight index")
    ax.set_ylabel("|detection - true apogee| (s)")
    p = result.parameters
    ax.set_title(f"Fig. 5.2: absolute error in apogee detection, {p['flights']} flights "
                 f"({p['params']}, seed {p['seed']}, pad {p['pad_s']:g} s)")
    ax.grid(alpha=0.3)
    ax.legend(loc="upper right")
    return save_png(plt, fig, path, dpi=110)


def error_histograms(plt, result, path: Path) -> Path:
    """One panel per method, common bins; errors beyond +-5 s are clipped into the end bins."""
    names = list(result.detections)
    errs = {n: result.detections[n] - result.true_apogee_s for n in names}
    finite = np.concatenate([e[np.isfinite(e)] for e in errs.values()]) if names else np.array([0.0])
    lo = max(-_HIST_LIMIT_S, float(np.floor(np.min(finite) * 4) / 4)) if finite.size else -1.0
    hi = min(_HIST_LIMIT_S, float(np.ceil(np.max(finite) * 4) / 4)) if finite.size else 1.0
    if hi - lo < 0.5:
        lo, hi = lo - 0.25, hi + 0.25
    bins = np.linspace(lo, hi, _HIST_BINS + 1)
    ncol = 2
    nrow = math.ceil(len(names) / ncol)
    fig, axes = plt.subplots(nrow, ncol, figsize=(12, 2.6 * nrow + 0.8), sharex=True, squeeze=False)
    for ax, name in zip(axes.flat, names, strict=False):
        ok = errs[name][np.isfinite(errs[name])]
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
    p = result.parameters
    fig.suptitle(f"Timing error per method ({p['flights']} flights, {p['params']}, seed {p['seed']}, "
                 f"pad {p['pad_s']:g} s)")
    return save_png(plt, fig, path, dpi=100)


def write_plots(result, out_dir, random_seed: int) -> list[Path]:
    """The paper's Figures 5.1, 5.2, 2.2-2.4 and one error histogram per method, as PNGs in out_dir."""
    plt = pyplot()
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    flight, batch = _seed_flight(random_seed)
    fs_hz = 1.0 / baselines.sample_period_s(batch.time_s)
    kalman_alt, kalman_vel, _ = baselines.seed_kalman(batch.altitude_m, batch.accel_mps2 - SEED_PAPER_G0_MPS2)
    filtered = {
        "boxcar": baselines.boxcar(batch.altitude_m)[0],
        "butterworth": baselines.butterworth(batch.altitude_m, fs_hz)[0],
        "elliptic": baselines.elliptic(batch.altitude_m, fs_hz)[0],
    }
    written = [figure_5_1(plt, flight, kalman_alt[0], kalman_vel[0], filtered["boxcar"], random_seed,
                          out / "fig5_1_kalman_vs_boxcar.png")]
    for fig_no, kind in (("2.2", "boxcar"), ("2.3", "butterworth"), ("2.4", "elliptic")):
        written.append(figure_2_x(plt, flight, fig_no, kind, filtered[kind], random_seed,
                                  out / f"fig{fig_no.replace('.', '_')}_{kind}.png"))
    written.append(figure_5_2(plt, result, out / "fig5_2_abs_error.png"))
    written.append(error_histograms(plt, result, out / "error_histograms.png"))
    return written
