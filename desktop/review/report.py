"""The flight review: ``python -m desktop replay FLIGHT --report DIR [--units m|ft]``.

Writes ``DIR/report.png`` (one page: altitude, velocity and acceleration with the events, the
flight computer's states and, when the log holds them, the board's own as coloured bands with a
legend, and the summary) and ``DIR/report.md`` (the same summary as Markdown tables).

Figures (``summary``): apogee (filtered altitude above the pad), maximum speed and its Mach number
(speed of sound of the ISA atmosphere at that altitude), maximum acceleration (the filter's
kinematic estimate, and the accelerometer's largest specific force), burnout, descent rates
under drogue and main (median filtered descent rate from ``SETTLE_S`` after the deployment
to the next event, above 5% of the apogee), flight time (launch to landing). The board's
decisions come from the log's own columns: ``altos_state`` (AltosUI exports: the first row in
each state; AltOS writes state records up to 0.1 s late) or ``board_events`` (this project's
decoded board logs).
"""

import math
from dataclasses import dataclass, field
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from matplotlib.patches import Patch  # noqa: E402

from shared.altitude import pressure_to_alt_mm  # noqa: E402
from shared.flight import EVENT_NAMES, STATE_NAMES  # noqa: E402
from shared.physics import G0_MPS2  # noqa: E402

FT_PER_M = 1 / 0.3048
SETTLE_S = 2.0  # a parachute's opening transient, left out of its descent rate
# Descent rates use only samples above this fraction of the apogee: not the rocket on the ground
# before the landing is declared.
DESCENT_ABOVE_APOGEE_FRACTION = 0.05
# ISA troposphere: sea-level temperature (K), lapse rate (K/m), tropopause temperature (K);
# speed of sound sqrt(gamma R T) with gamma 1.4 and R 287.053 J/(kg K).
ISA_T0_K, ISA_LAPSE_KPM, ISA_T_TROPOPAUSE_K = 288.15, 0.0065, 216.65
GAMMA_R = 1.4 * 287.053
STATE_COLOURS = {"pad": "#dddddd", "boost": "#ffb870", "fast": "#ff7b7b", "coast": "#f2e86d",
                 "drogue": "#8fd98f", "main": "#7cc9f0", "landed": "#b7a6f0"}
OTHER_COLOUR = "#ffffff"  # AltOS states with no counterpart here (startup, idle, invalid)
# The board's decisions compared with ours: (our event, the AltOS states whose first entry is
# that decision; after burnout AltOS goes to fast while still above its speed threshold, else coast).
DECISIONS = (("launch", ("boost",)), ("burnout", ("fast", "coast")), ("drogue", ("drogue",)),
             ("main", ("main",)), ("landed", ("landed",)))
PAGE_IN = (11.69, 8.27)  # A4 landscape
# An igniter channel showing at least this voltage on the first row has an igniter; when its
# voltage falls below this fraction of that, the igniter has burnt open (the charge fired).
IGNITER_CONTINUITY_MIN_V = 1.0
IGNITER_OPEN_FRACTION = 0.5
PAD_SHOWN_S = 3.0  # pad time shown before the launch
RAW_SHOWN_PERCENTILES = (0.5, 99.5)  # raw readings inside these percentiles set the y limits


@dataclass
class Units:
    name: str  # "m" or "ft"
    factor: float  # per metre

    @property
    def speed(self):
        return self.name + "/s"

    @property
    def accel(self):
        return self.name + "/s²"


UNITS = {"m": Units("m", 1.0), "ft": Units("ft", FT_PER_M)}


@dataclass
class Summary:
    rows: list  # (label, value text)
    decisions: list  # (decision, ours "t s" or "-", board "t s" or "-", difference text)
    board_source: str | None
    notes: list = field(default_factory=list)


def speed_of_sound_mps(alt_msl_m):
    """ISA speed of sound at ``alt_msl_m`` (troposphere, then the isothermal stratosphere)."""
    t_k = max(ISA_T0_K - ISA_LAPSE_KPM * alt_msl_m, ISA_T_TROPOPAUSE_K)
    return math.sqrt(GAMMA_R * t_k)


def ground_msl_m(result, log):
    """Altitude of the pad above sea level (ISA, from the barometer), or None without pressure."""
    if log.pressure_pa is None:
        return None
    for i in np.flatnonzero(np.isfinite(log.pressure_pa) & np.isfinite(result.raw_agl_m)):
        alt_m = pressure_to_alt_mm(int(round(log.pressure_pa[i] * 16))) / 1000
        return alt_m - float(result.raw_agl_m[i])
    return None


def igniters_opened(log):
    """{channel: time s} at which an igniter's continuity voltage (the ``*_sense_v`` columns of an
    import) fell below IGNITER_OPEN_FRACTION of its value in the first row: the charge fired and
    the igniter burnt open."""
    opened = {}
    for name, values in log.extra.items():
        if not name.endswith("_sense_v") or values.dtype.kind != "f" or not np.isfinite(values[0]):
            continue
        if values[0] < IGNITER_CONTINUITY_MIN_V:
            continue  # no igniter on this channel
        low = np.flatnonzero(values < IGNITER_OPEN_FRACTION * values[0])
        if len(low):
            opened[name[: -len("_sense_v")]] = float(log.time_s[low[0]])
    return opened


def board_decisions(log):
    """{decision: time s} the board logged, and where they came from (None: the log holds none)."""
    if "board_events" in log.extra:
        events = log.extra["board_events"].astype(np.int64)
        found = {}
        for bit, name in enumerate(EVENT_NAMES):
            rows = np.flatnonzero(events & (1 << bit))
            if len(rows):
                found[name] = float(log.time_s[rows[0]])
        return found, "the board's logged events (board_events)"
    if "altos_state" in log.extra:
        states = [str(s) for s in log.extra["altos_state"]]
        first = {}
        for i, s in enumerate(states):
            first.setdefault(s, float(log.time_s[i]))
        found = {}
        for ours, altos in DECISIONS:
            entered = [first[s] for s in altos if s in first and first[s] > log.time_s[0]]
            if entered:
                found[ours] = min(entered)
        if "drogue" not in found and "main" in found:  # AltOS went straight to main (low apogee)
            found["drogue"] = found["main"]
        return found, "the AltOS board's logged states (altos_state; written up to 0.1 s late)"
    return {}, None


def _median_descent(result, t_from, t_to):
    t = result.time_s
    above = result.agl_m > DESCENT_ABOVE_APOGEE_FRACTION * np.nanmax(result.agl_m)
    sel = (t >= t_from + SETTLE_S) & (t < t_to) & np.isfinite(result.vel_mps) & above
    return float(np.median(-result.vel_mps[sel])) if sel.sum() >= 3 else None


def summary(result, log, units):
    """The figures of the review, in ``units``."""
    u = units
    t = result.time_s
    ev = {e.event: e for e in reversed(result.events)}  # first of each
    rows = []
    notes = []
    i_apo = int(np.nanargmax(result.agl_m))
    rows.append(("apogee", f"{result.agl_m[i_apo] * u.factor:.1f} {u.name} at {t[i_apo]:.2f} s"))
    i_v = int(np.nanargmax(result.vel_mps))
    vmax = float(result.vel_mps[i_v])
    ground = ground_msl_m(result, log)
    if ground is None:
        ground = 0.0
        notes.append("no pressure column: Mach computed for a pad at sea level")
    mach = vmax / speed_of_sound_mps(ground + float(result.agl_m[i_v]))
    rows.append(("max speed", f"{vmax * u.factor:.1f} {u.speed} (Mach {mach:.2f}) at {t[i_v]:.2f} s"))
    i_a = int(np.nanargmax(result.acc_mps2))
    amax = float(result.acc_mps2[i_a])
    rows.append(("max acceleration",
                 f"{amax * u.factor:.1f} {u.accel} ({amax / G0_MPS2:.1f} g) at {t[i_a]:.2f} s"))
    if log.has_accel:
        fmax = float(np.nanmax(log.accel_mps2))
        rows.append(("max accelerometer",
                     f"{fmax * u.factor:.1f} {u.accel} ({fmax / G0_MPS2:.1f} g) specific force"))
    if "burnout" in ev:
        b = ev["burnout"]
        rows.append(("burnout", f"{b.time_s:.2f} s at {b.altitude_m * u.factor:.1f} {u.name}"))
    lit = [e for e in result.events if e.event == "ignition"]  # a motor lit in coast (staging)
    if lit:
        rows.append(("ignition in coast", ", ".join(
            f"{e.time_s:.2f} s at {e.altitude_m * u.factor:.1f} {u.name}" for e in lit)))
    end = float(t[-1])
    t_main = ev["main"].time_s if "main" in ev else None
    t_landed = ev["landed"].time_s if "landed" in ev else None
    if "drogue" in ev:
        rate = _median_descent(result, ev["drogue"].time_s, t_main or t_landed or end)
        if rate is not None:
            rows.append(("descent under drogue", f"{rate * u.factor:.1f} {u.speed}"))
    if t_main is not None:
        rate = _median_descent(result, t_main, t_landed or end)
        if rate is not None:
            rows.append(("descent under main", f"{rate * u.factor:.1f} {u.speed}"))
    if "launch" in ev:
        t_end = t_landed if t_landed is not None else end
        what = "to landing" if t_landed is not None else "to the end of the log (no landing in it)"
        rows.append(("flight time", f"{t_end - ev['launch'].time_s:.1f} s {what}"))
    for name in ("drogue", "backup_drogue", "main", "backup_main"):
        if name in ev:
            rows.append((f"{name.replace('_', ' ')} fired",
                         f"{ev[name].time_s:.2f} s at {ev[name].altitude_m * u.factor:.1f} {u.name}"))
    board, source = board_decisions(log)
    decisions = []
    if source is not None:
        for ours_name, _altos in DECISIONS:
            ours_t = ev[ours_name].time_s if ours_name in ev else None
            board_t = board.get(ours_name)
            diff = f"{ours_t - board_t:+.2f} s" if ours_t is not None and board_t is not None else "-"
            decisions.append((ours_name, "-" if ours_t is None else f"{ours_t:.2f} s",
                              "-" if board_t is None else f"{board_t:.2f} s", diff))
    opened = igniters_opened(log)
    if opened:
        rows.append(("board's igniters open", ", ".join(f"{name} {t:.2f} s" for name, t in opened.items())))
    return Summary(rows, decisions, source, notes)


def _limits(ax, filtered, raw):
    """y limits that show the filtered curve whole and the raw readings but their rare spikes
    (ejection charges, Mach transients) would flatten the flight."""
    values = [filtered[np.isfinite(filtered)]]
    if raw is not None and np.isfinite(raw).any():
        values.append(np.nanpercentile(raw, RAW_SHOWN_PERCENTILES))
    lo, hi = float(min(v.min() for v in values)), float(max(v.max() for v in values))
    margin = 0.06 * (hi - lo) if hi > lo else 1.0
    ax.set_ylim(lo - margin, hi + margin)


def _bands(ax, t, names, y0, height):
    """Coloured spans of consecutive equal ``names`` between y0 and y0 + height (axes fraction)."""
    start = 0
    for i in range(1, len(names) + 1):
        if i == len(names) or names[i] != names[start]:
            t_end = t[i] if i < len(names) else t[-1]
            ax.axvspan(t[start], t_end, ymin=y0, ymax=y0 + height, lw=0,
                       color=STATE_COLOURS.get(names[start], OTHER_COLOUR))
            start = i


def board_states(log):
    """The board's state name per row, or None."""
    if "board_state" in log.extra:
        return [STATE_NAMES[int(s)] for s in log.extra["board_state"]]
    if "altos_state" in log.extra:
        return [str(s) for s in log.extra["altos_state"]]
    return None


def figure(result, log, config, units, summ, title):
    """The one-page review figure (matplotlib Figure)."""
    u = units
    t = result.time_s
    fig = plt.figure(figsize=PAGE_IN)
    grid = fig.add_gridspec(4, 2, width_ratios=(2.3, 1), height_ratios=(0.35, 1.3, 1, 1),
                            left=0.07, right=0.98, top=0.9, bottom=0.08, hspace=0.12, wspace=0.08)
    ax_state = fig.add_subplot(grid[0, 0])
    ax_alt = fig.add_subplot(grid[1, 0], sharex=ax_state)
    ax_vel = fig.add_subplot(grid[2, 0], sharex=ax_state)
    ax_acc = fig.add_subplot(grid[3, 0], sharex=ax_state)
    ax_text = fig.add_subplot(grid[:, 1])
    ours = [STATE_NAMES[int(s)] for s in result.state]
    theirs = board_states(log)
    if theirs is None:
        _bands(ax_state, t, ours, 0.0, 1.0)
        ax_state.set_yticks([0.5], ["ours"])
    else:
        _bands(ax_state, t, ours, 0.5, 0.5)
        _bands(ax_state, t, theirs, 0.0, 0.5)
        ax_state.set_yticks([0.25, 0.75], ["board", "ours"])
    ax_state.set_ylim(0, 1)
    present = [s for s in STATE_COLOURS if s in ours or (theirs is not None and s in theirs)]
    ax_state.legend(handles=[Patch(color=STATE_COLOURS[s], label=s) for s in present], loc="lower left",
                    bbox_to_anchor=(0.0, 1.02), ncol=len(present), fontsize=7.5, frameon=False,
                    borderaxespad=0, handlelength=1.2, columnspacing=0.8)
    ax_alt.plot(t, result.raw_agl_m * u.factor, ".", ms=1.5, color="0.6", label="barometer")
    ax_alt.plot(t, result.agl_m * u.factor, color="C0", lw=1.2, label="filtered altitude")
    ax_alt.axhline(config.values["main_deploy_m"] * u.factor, color="C2", ls=":", lw=1, label="main altitude")
    ax_vel.plot(t, result.vel_mps * u.factor, color="C1", lw=1.2, label="filtered velocity")
    ax_vel.axhline(0, color="0.5", lw=0.8)
    if log.accel_mps2 is not None:
        ax_acc.plot(t, (log.accel_mps2 - G0_MPS2) * u.factor, ".", ms=1.5, color="0.6",
                    label="accelerometer − g")
    ax_acc.plot(t, result.acc_mps2 * u.factor, color="C3", lw=1.2, label="filtered acceleration")
    _limits(ax_alt, result.agl_m * u.factor, result.raw_agl_m * u.factor)
    _limits(ax_acc, result.acc_mps2 * u.factor,
            None if log.accel_mps2 is None else (log.accel_mps2 - G0_MPS2) * u.factor)
    board, _source = board_decisions(log)
    first = {e.event: e for e in reversed(result.events)}
    if "launch" in first:  # a long pad (a board log) would squeeze the flight into a corner
        ax_acc.set_xlim(max(float(t[0]), first["launch"].time_s - PAD_SHOWN_S), float(t[-1]))
    for name, colour in (("drogue", "C4"), ("main", "C2"), ("backup_drogue", "C4"), ("backup_main", "C2")):
        backup = name.startswith("backup")
        for ax in (ax_state, ax_alt, ax_vel, ax_acc):
            if name in first:
                ax.axvline(first[name].time_s, color=colour, lw=1.4, ls=":" if backup else "-",
                           label=f"{name.replace('_', ' ')} fired (ours)" if ax is ax_alt else None)
            if name in board:
                ax.axvline(board[name], color=colour, lw=1.4, ls="--",
                           label=f"{name} (board)" if ax is ax_alt else None)
    ax_alt.set_ylabel(f"altitude above pad ({u.name})")
    ax_vel.set_ylabel(f"velocity ({u.speed})")
    ax_acc.set_ylabel(f"acceleration ({u.accel})")
    ax_acc.set_xlabel("time (s; the log's time axis)")
    for ax in (ax_state, ax_alt, ax_vel):
        ax.tick_params(labelbottom=False)
    for ax in (ax_alt, ax_vel, ax_acc):
        ax.grid(alpha=0.3)
        ax.legend(loc="upper right", fontsize=7, framealpha=0.85)
    _summary_panel(ax_text, summ)
    fig.suptitle(title, fontsize=11)
    return fig


def _summary_panel(ax, summ):
    ax.axis("off")
    lines = [("Summary", None, "head")] + [(a, b, "row") for a, b in summ.rows]
    if summ.decisions:
        lines += [("", None, "gap"), ("Decisions: ours / board (ours − board)", None, "head")]
        for name, ours_t, board_t, diff in summ.decisions:
            lines.append((name, f"{ours_t} / {board_t} ({diff})" if diff != "-" else f"{ours_t} / {board_t}",
                          "row"))
        lines.append(("board: " + summ.board_source.split(" (")[0], None, "note"))
    for note in summ.notes:
        lines.append((note, None, "note"))
    step = 1.0 / 34
    y = 1.0
    for label, value, kind in lines:
        if kind == "head":
            ax.text(0.0, y, label, fontsize=9, weight="bold", va="top", transform=ax.transAxes)
        elif kind == "row":
            ax.text(0.0, y, label, fontsize=8, va="top", transform=ax.transAxes)
            ax.text(0.0, y - step * 0.9, "   " + value, fontsize=8, va="top", color="0.15",
                    transform=ax.transAxes)
            y -= step * 0.9
        elif kind == "note":
            ax.text(0.0, y, label, fontsize=7, va="top", style="italic", transform=ax.transAxes, wrap=True)
        y -= step


def markdown(summ, log, units, png_name):
    out = [f"# Flight review: {Path(log.path).name}", "", f"![flight review]({png_name})", "",
           f"Units: {units.name}. Source: {log.metadata.get('source', log.path)}"
           + (f"; board: {log.metadata['board']}" if "board" in log.metadata else "") + ".", "",
           "| figure | value |", "|---|---|"]
    out += [f"| {a} | {b} |" for a, b in summ.rows]
    if summ.decisions:
        out += ["", f"Decisions, ours and the board's ({summ.board_source}):", "",
                "| decision | ours | board | ours − board |", "|---|---|---|---|"]
        out += [f"| {a} | {b} | {c} | {d} |" for a, b, c, d in summ.decisions]
    if summ.notes:
        out += [""] + [f"- {n}" for n in summ.notes]
    return "\n".join(out) + "\n"


def write_report(result, log, config, out_dir, units="m"):
    """Write report.png and report.md into ``out_dir``; returns their paths."""
    u = UNITS[units]
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    summ = summary(result, log, u)
    fig = figure(result, log, config, u, summ, f"Flight review: {Path(log.path).name}")
    png = out / "report.png"
    fig.savefig(png, dpi=110)
    plt.close(fig)
    md = out / "report.md"
    md.write_text(markdown(summ, log, u, png.name), encoding="utf-8")
    return png, md
