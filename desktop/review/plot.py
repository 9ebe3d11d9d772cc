"""Plot of a replay: altitude (raw and filtered), velocity, acceleration, state bands, firings."""

import numpy as np

from desktop.figures import pyplot, save_png
from shared.flight import STATE_NAMES

_STATE_COLOURS = ("#eeeeee", "#ffd6a5", "#ffadad", "#fdffb6", "#caffbf", "#9bf6ff", "#bdb2ff")


def plot_replay(result, log, config, path):
    """Write a PNG of ``result`` (desktop.review.replay.ReplayResult) for flight ``log`` to ``path``."""
    plt = pyplot()
    t = result.time_s
    fig, axes = plt.subplots(3, 1, figsize=(11, 9), sharex=True)
    ax_alt, ax_vel, ax_acc = axes
    ax_alt.plot(t, result.raw_agl_m, ".", ms=2, color="0.6", label="barometer (raw)")
    ax_alt.plot(t, result.agl_m, color="C0", label="Kalman altitude")
    if config.values["main_deploy_m"]:
        ax_alt.axhline(config.values["main_deploy_m"], color="C2", ls=":", lw=1, label="main altitude")
    if "true_altitude_m" in log.extra:
        ax_alt.plot(t, log.extra["true_altitude_m"], color="k", lw=1, ls="--", label="truth")
    ax_vel.plot(t, result.vel_mps, color="C1", label="Kalman velocity")
    if "true_velocity_mps" in log.extra:
        ax_vel.plot(t, log.extra["true_velocity_mps"], color="k", lw=1, ls="--", label="truth")
    ax_vel.axhline(0, color="0.5", lw=0.8)
    if log.accel_mps2 is not None:
        ax_acc.plot(t, log.accel_mps2, ".", ms=2, color="0.6", label="accelerometer (specific force)")
    ax_acc.plot(t, result.acc_mps2, color="C3", label="Kalman acceleration (kinematic)")
    # state bands
    changes = np.flatnonzero(np.diff(result.state)) + 1
    bounds = np.concatenate([[0], changes, [len(t) - 1]])
    for a, b in zip(bounds[:-1], bounds[1:], strict=True):
        s = int(result.state[a])
        for ax in axes:
            ax.axvspan(t[a], t[b], color=_STATE_COLOURS[s], alpha=0.5, lw=0)
        ax_alt.text(t[a], 1.0, STATE_NAMES[s], transform=ax_alt.get_xaxis_transform(), va="bottom",
                    fontsize=8)
    for ev in result.events:
        if ev.event in ("drogue", "main", "backup_drogue", "backup_main"):
            for ax in axes:  # a backup channel dotted, in its primary's colour
                ax.axvline(ev.time_s, color="C2" if ev.event.endswith("main") else "C4", lw=1.5,
                           ls=":" if ev.event.startswith("backup") else "-")
            # a backup's label below its point: it fires close after its primary
            ax_alt.annotate("%s %.2f s" % (ev.event.replace("_", " "), ev.time_s), (ev.time_s, ev.altitude_m),
                            xytext=(5, -15 if ev.event.startswith("backup") else 5),
                            textcoords="offset points", fontsize=9)
    ax_alt.set_ylabel("altitude above pad (m)")
    ax_vel.set_ylabel("vertical velocity (m/s)")
    ax_acc.set_ylabel("acceleration (m/s²)")
    ax_acc.set_xlabel("time (s, file time base)")
    for ax in axes:
        ax.legend(loc="upper right", fontsize=8)
        ax.grid(alpha=0.3)
    fig.suptitle("Replay of %s through the flight computer" % log.path)
    save_png(plt, fig, path, dpi=110)
