"""Import the CSV that OpenRocket writes with "Export data" (and write one, for tests and examples).

OpenRocket's export: `#` comment lines (simulation name, "N data points written for M variables"),
a comment line with the column names and units, e.g.

    # Time (s),Altitude (m),Vertical velocity (m/s),Vertical acceleration (m/s²),Mach number (),...

flight-event comments anywhere (`# Event APOGEE occurred at t=12.34 seconds`), then data rows with a
variable time step, altitude above the launch site, time 0 at launch. The field separator may be a
comma, semicolon or tab (an export option); an uncommented header line is accepted too.

Each column's unit is the last parenthesised group of its name and is converted to SI. Columns the
importer uses (time, altitude, vertical velocity and acceleration, total velocity, Mach number, air
pressure and temperature, speed of sound, thrust, drag force, mass, vertical orientation) must have a
known unit; other columns are ignored. Missing quantities are derived and listed in
`Trajectory.derived_columns`:

- static pressure: the standard atmosphere at site altitude + altitude;
- specific force along the axis: (thrust - drag) / mass before the first recovery-device deployment
  (at least g cos(zenith) on the pad) and vertical acceleration + g after it (body axis taken
  vertical under a parachute, as in desktop/sim/trajectory.py); from vertical acceleration + g
  throughout when thrust, drag or mass is missing (body axis assumed vertical);
- vertical velocity from altitude, vertical acceleration from velocity; Mach number from the total
  (or vertical) velocity and the speed of sound.

The result is the same `Trajectory` as desktop/sim/trajectory.py produces, resampled to a uniform fine
grid (altitude by cubic Hermite with the vertical velocity, the rest linearly), keeping the
export's time base. Every problem with the content is one `OpenRocketError` with a one-line
message (a file that cannot be read: `InputFileError`, desktop/io/files.py).
"""

from __future__ import annotations

import math
import re
from pathlib import Path

import numpy as np

from desktop.errors import DesktopError
from desktop.io.files import read_text
from desktop.sim.trajectory import (
    G0,
    Trajectory,
    _hermite,
    isa_altitude,
    isa_pressure,
    isa_speed_of_sound,
)

__all__ = ["OpenRocketError", "read_openrocket", "write_openrocket_export", "UNITS", "QUANTITIES"]


class OpenRocketError(DesktopError):
    """An OpenRocket export that cannot be imported. The message is one line."""


_FAHRENHEIT = (5.0 / 9.0, 273.15 - 32.0 * 5.0 / 9.0)

# unit -> (scale, offset) so that SI = value * scale + offset, per physical kind.
UNITS: dict[str, dict[str, tuple[float, float]]] = {
    "time": {"s": (1.0, 0.0), "ms": (1e-3, 0.0), "min": (60.0, 0.0)},
    "length": {"m": (1.0, 0.0), "km": (1000.0, 0.0), "cm": (0.01, 0.0), "mm": (0.001, 0.0),
               "ft": (0.3048, 0.0), "in": (0.0254, 0.0), "mi": (1609.344, 0.0), "yd": (0.9144, 0.0)},
    "velocity": {"m/s": (1.0, 0.0), "km/h": (1 / 3.6, 0.0), "ft/s": (0.3048, 0.0), "mph": (0.44704, 0.0)},
    "acceleration": {"m/s²": (1.0, 0.0), "m/s^2": (1.0, 0.0), "m/s2": (1.0, 0.0), "ft/s²": (0.3048, 0.0),
                     "ft/s^2": (0.3048, 0.0), "ft/s2": (0.3048, 0.0), "G": (G0, 0.0)},
    "pressure": {"Pa": (1.0, 0.0), "hPa": (100.0, 0.0), "mbar": (100.0, 0.0), "kPa": (1000.0, 0.0),
                 "bar": (1e5, 0.0), "psi": (6894.757293168, 0.0), "inHg": (3386.389, 0.0),
                 "mmHg": (133.322387415, 0.0), "atm": (101325.0, 0.0)},
    "temperature": {"°C": (1.0, 273.15), "degC": (1.0, 273.15), "C": (1.0, 273.15), "K": (1.0, 0.0),
                    "°F": _FAHRENHEIT, "degF": _FAHRENHEIT, "F": _FAHRENHEIT},
    "force": {"N": (1.0, 0.0), "kN": (1000.0, 0.0), "lbf": (4.4482216152605, 0.0),
              "ozf": (0.27801385095378, 0.0)},
    "mass": {"kg": (1.0, 0.0), "g": (0.001, 0.0), "oz": (0.028349523125, 0.0), "lb": (0.45359237, 0.0),
             "lbm": (0.45359237, 0.0)},
    "angle": {"°": (math.pi / 180.0, 0.0), "deg": (math.pi / 180.0, 0.0), "rad": (1.0, 0.0)},
    "none": {"": (1.0, 0.0), "-": (1.0, 0.0)},
}

# OpenRocket column name (lower case, without the unit) -> (quantity, kind)
QUANTITIES: dict[str, tuple[str, str]] = {
    "time": ("time", "time"),
    "altitude": ("altitude", "length"),
    "vertical velocity": ("velocity", "velocity"),
    "vertical acceleration": ("vacc", "acceleration"),
    "total velocity": ("speed", "velocity"),
    "mach number": ("mach", "none"),
    "air pressure": ("pressure", "pressure"),
    "air temperature": ("temperature", "temperature"),
    "speed of sound": ("sound", "velocity"),
    "thrust": ("thrust", "force"),
    "drag force": ("drag", "force"),
    "mass": ("mass", "mass"),
    "vertical orientation (zenith)": ("zenith", "angle"),
}

_EVENT_RE = re.compile(r"#\s*Event\s+([A-Za-z_]+)\s+occurred\s+at\s+t\s*=\s*([-+0-9.eE]+)\s*s", re.IGNORECASE)
_NAME_UNIT_RE = re.compile(r"^(.*?)\s*\(([^()]*)\)\s*$")
_ZERO_WIDTH = "\u200b\ufeff\u200c\u200d"


def _split_name(col: str) -> tuple[str, str | None]:
    m = _NAME_UNIT_RE.match(col.strip())
    if not m:
        return col.strip(), None
    unit = m.group(2).strip().strip(_ZERO_WIDTH)
    return m.group(1).strip(), unit


def _number(cell: str) -> float:
    c = cell.strip()
    if c.lower() in ("nan", ""):
        return math.nan
    return float(c)


def read_openrocket(path, site_altitude_m: float | None = None, dt_s: float = 0.001) -> Trajectory:
    """Import an OpenRocket CSV export as a Trajectory; OpenRocketError or InputFileError (one line)."""
    p = Path(path)
    # OpenRocket on Windows writes its exports in the ANSI code page when they are not UTF-8
    text = read_text(p, "OpenRocket export", fallback_encoding="cp1252")
    lines = text.splitlines()

    events: list[tuple[str, float]] = []
    header_cols: list[str] | None = None
    header_line = 0
    sep = ","
    rows: list[list[float]] = []
    row_lines: list[int] = []
    candidate: tuple[int, str] | None = None  # last non-event comment line before the data

    def parse_header(lineno: int, body: str):
        nonlocal header_cols, header_line, sep
        for s in ("\t", ";", ","):
            if s in body:
                sep = s
                break
        cols = [c.strip() for c in body.split(sep)]
        header_cols, header_line = cols, lineno

    for lineno, raw in enumerate(lines, 1):
        line = raw.strip()
        if not line:
            continue
        if line.startswith("#"):
            m = _EVENT_RE.match(line)
            if m:
                try:
                    events.append((m.group(1).upper(), float(m.group(2))))
                except ValueError:
                    raise OpenRocketError(f"{p}:{lineno}: bad event time in {line!r}") from None
                continue
            if header_cols is None:
                body = line[1:].strip()
                if body:
                    candidate = (lineno, body)
            continue
        if header_cols is None:
            first = re.split(r"[,;\t]", line)[0].strip()
            try:
                _number(first)
                numeric = True
            except ValueError:
                numeric = False
            if numeric:
                if candidate is None:
                    raise OpenRocketError(
                        f"{p}:{lineno}: data before any column-name line (expected a comment line like "
                        f"'# Time (s),Altitude (m),...')"
                    )
                parse_header(*candidate)
            else:
                parse_header(lineno, line)
                continue
        cells = line.split(sep)
        if len(cells) != len(header_cols):
            raise OpenRocketError(
                f"{p}:{lineno}: row has {len(cells)} fields, the column-name line {header_line} has "
                f"{len(header_cols)}"
            )
        try:
            if sep != ",":
                cells = [c.replace(",", ".") for c in cells]
            rows.append([_number(c) for c in cells])
        except ValueError:
            bad = next(c for c in cells if not _is_number(c))
            raise OpenRocketError(f"{p}:{lineno}: {bad.strip()!r} is not a number") from None
        row_lines.append(lineno)

    if header_cols is None:
        raise OpenRocketError(f"{p}: no column-name line and no data (is this an OpenRocket CSV export?)")
    if len(rows) < 2:
        raise OpenRocketError(f"{p}: fewer than 2 data rows")

    # Columns: recognised quantities with known units.
    cols: dict[str, np.ndarray] = {}
    arr = np.array(rows, dtype=float)
    for j, name in enumerate(header_cols):
        base, unit = _split_name(name)
        key = base.lower()
        if key not in QUANTITIES:
            continue
        qty, kind = QUANTITIES[key]
        if unit is None:
            raise OpenRocketError(f"{p}:{header_line}: column {name!r} has no unit in parentheses")
        table = UNITS[kind]
        if unit not in table:
            raise OpenRocketError(
                f"{p}:{header_line}: column {name!r}: unknown unit {unit!r} (known: "
                f"{', '.join(u or '()' for u in table)})"
            )
        scale, offset = table[unit]
        if qty in cols:
            raise OpenRocketError(f"{p}:{header_line}: column {base!r} appears twice")
        cols[qty] = arr[:, j] * scale + offset
    missing = [n for n in ("time", "altitude") if n not in cols]
    if missing:
        raise OpenRocketError(
            f"{p}:{header_line}: the export needs 'Time' and 'Altitude' columns (missing: "
            f"{', '.join(missing)}; found {', '.join(header_cols[:6])}"
            f"{', ...' if len(header_cols) > 6 else ''})"
        )
    t = cols["time"]
    if not np.all(np.isfinite(t)):
        i = int(np.argmax(~np.isfinite(t)))
        raise OpenRocketError(f"{p}:{row_lines[i]}: time is missing")
    back = np.flatnonzero(np.diff(t) < 0)
    if back.size:
        i = int(back[0]) + 1
        raise OpenRocketError(f"{p}:{row_lines[i]}: time goes backwards ({t[i]:g} s after {t[i - 1]:g} s)")
    # OpenRocket repeats a time at some events: keep the last row of each time.
    keep = np.concatenate([np.diff(t) > 0, [True]])
    for k in cols:
        cols[k] = cols[k][keep]
    t = cols["time"]
    if len(t) < 2:
        raise OpenRocketError(f"{p}: fewer than 2 distinct times")
    return _to_trajectory(p, cols, events, site_altitude_m, dt_s)


def _is_number(c: str) -> bool:
    try:
        _number(c)
        return True
    except ValueError:
        return False


def _fill(x: np.ndarray, t: np.ndarray) -> np.ndarray | None:
    """Interpolate over NaN cells; None when the column has no value at all."""
    ok = np.isfinite(x)
    if not ok.any():
        return None
    if ok.all():
        return x
    return np.interp(t, t[ok], x[ok])


def _to_trajectory(p: Path, cols, events, site_altitude_m, dt_s) -> Trajectory:
    t = cols["time"]
    for k in list(cols):
        if k != "time":
            v = _fill(cols[k], t)
            if v is None:
                del cols[k]
            else:
                cols[k] = v
    if "altitude" not in cols:
        raise OpenRocketError(f"{p}: the Altitude column has no values")
    derived: list[str] = []
    alt = cols["altitude"]
    ev: dict[str, float] = {}
    deployments = []
    for name, te in events:
        key = name.lower()
        if key == "recovery_device_deployment":
            deployments.append(te)
        ev.setdefault(key, te)
    deployments.sort()

    # Site altitude and ground pressure.
    if site_altitude_m is None:
        if "pressure" in cols:
            site_altitude_m = float(isa_altitude(cols["pressure"][0])) - float(alt[0])
            derived.append("site_altitude_m(from the first air pressure)")
        else:
            site_altitude_m = 0.0
            derived.append("site_altitude_m(assumed 0: give --site-altitude)")

    # Vertical velocity and acceleration.
    if "velocity" not in cols:
        cols["velocity"] = np.gradient(alt, t)
        derived.append("true_velocity_mps(from altitude)")
    if "vacc" not in cols:
        cols["vacc"] = np.gradient(cols["velocity"], t)
        derived.append("vertical acceleration(from velocity)")

    # Uniform grid in the export's time base.
    t0, t1 = float(t[0]), float(t[-1])
    n = int(math.floor((t1 - t0) / dt_s + 1e-9)) + 1
    tf = t0 + np.arange(n) * dt_s
    seg = np.clip(np.searchsorted(t, tf, side="right") - 1, 0, len(t) - 2)
    altf = _hermite(tf, t[seg], t[seg + 1], alt[seg], alt[seg + 1], cols["velocity"][seg],
                    cols["velocity"][seg + 1])
    velf = np.interp(tf, t, cols["velocity"])
    vaccf = np.interp(tf, t, cols["vacc"])

    if "pressure" in cols:
        pf = np.interp(tf, t, cols["pressure"])
    else:
        pf = np.asarray(isa_pressure(site_altitude_m + altf))
        derived.append("pressure_pa(standard atmosphere)")

    zen0 = float(cols["zenith"][0]) if "zenith" in cols else 0.0
    pad_accel = G0 * math.cos(zen0)
    first_deploy = deployments[0] if deployments else None
    after = (tf >= first_deploy) if first_deploy is not None else np.zeros(n, dtype=bool)
    thrust_f = mass_f = None
    if all(k in cols for k in ("thrust", "drag", "mass")):
        thrust_f = np.interp(tf, t, cols["thrust"])
        mass_f = np.interp(tf, t, cols["mass"])
        if np.any(mass_f <= 0):
            raise OpenRocketError(f"{p}: the Mass column has a zero or negative value")
        sf = (thrust_f - np.interp(tf, t, cols["drag"])) / mass_f
        sf = np.where(after, vaccf + G0, sf)
        derived.append("accel_mps2(from thrust, drag and mass; vertical acceleration + g after deployment)")
    else:
        sf = vaccf + G0
        derived.append("accel_mps2(from vertical acceleration + g: body axis assumed vertical)")
    # On the pad, before lift-off: at least the weight along the axis.
    liftoff = ev.get("liftoff")
    if liftoff is None:
        moving = np.flatnonzero((altf > 0.01) | (np.abs(velf) > 0.01))
        liftoff = float(tf[moving[0]]) if moving.size else t0
    pad = tf < liftoff
    sf = np.where(pad, np.maximum(sf, pad_accel), sf)

    if "mach" in cols:
        machf = np.interp(tf, t, cols["mach"])
    else:
        if "sound" in cols:
            a = np.interp(tf, t, cols["sound"])
        elif "temperature" in cols:
            a = np.sqrt(1.4 * 287.05287 * np.interp(tf, t, cols["temperature"]))
        else:
            a = isa_speed_of_sound(site_altitude_m + altf)
        if "speed" in cols:
            machf = np.interp(tf, t, cols["speed"]) / a
            derived.append("mach(from total velocity)")
        else:
            machf = np.abs(velf) / a
            derived.append("mach(from vertical velocity)")

    if "apogee" in ev:
        t_ap = ev["apogee"]
    else:
        t_ap = float(tf[int(np.argmax(altf))])
    i_ap = int(np.argmax(altf))
    apogee_m = float(altf[i_ap])
    burnout = ev.get("burnout")
    ground_p = float(pf[0]) if "pressure" in cols else float(isa_pressure(site_altitude_m))
    return Trajectory(
        time_s=tf,
        altitude_m=altf,
        velocity_mps=velf,
        accel_mps2=sf,
        pressure_pa=pf,
        mach=machf,
        site_altitude_m=float(site_altitude_m),
        ground_pressure_pa=ground_p,
        pad_accel_mps2=pad_accel,
        apogee_time_s=float(t_ap),
        apogee_m=apogee_m,
        burnout_time_s=burnout,
        drogue_time_s=deployments[0] if deployments else None,
        main_time_s=deployments[1] if len(deployments) > 1 else None,
        events=ev,
        rocket=p.stem,
        source=f"OpenRocket export {p}",
        derived_columns=tuple(derived),
        thrust_n=thrust_f,
        mass_kg=mass_f,
    )


# --------------------------------------------------------------------------------------------------
# Writer (OpenRocket's format) for examples and round-trip tests


def _default_steps(traj: Trajectory) -> np.ndarray:
    """Variable step like OpenRocket: 5 ms through the burn, 20 ms to 2 s after the first deployment,
    100 ms after that."""
    t_end = traj.end_time_s
    burn = (traj.burnout_time_s or 0.0) + 0.2
    dep = (traj.drogue_time_s if traj.drogue_time_s is not None else traj.apogee_time_s) + 2.0
    parts = [np.arange(0.0, min(burn, t_end), 0.005), np.arange(min(burn, t_end), min(dep, t_end), 0.02),
             np.arange(min(dep, t_end), t_end, 0.1), [t_end]]
    t = np.unique(np.round(np.concatenate(parts), 6))
    return t[(t >= traj.time_s[0]) & (t <= t_end)]


def write_openrocket_export(traj: Trajectory, path, times=None, comment: str = "",
                            imperial: bool = False) -> None:
    """Write a trajectory in OpenRocket's "Export data" CSV format (variable time step).

    Columns: Time, Altitude, Vertical velocity, Vertical acceleration, Mach number, Air pressure,
    Thrust, Drag force, Mass, Vertical orientation (zenith) (metric, or imperial units with
    imperial=True; the zenith angle only on the pad, NaN after lift-off). "Drag force" is
    thrust - mass * (specific force along the axis), i.e. every axial force but thrust, so that the
    importer recovers the specific force; on the pad it is 0, under a parachute the drag magnitude.
    Events (LAUNCH, IGNITION, LIFTOFF, LAUNCHROD, BURNOUT, APOGEE, RECOVERY_DEVICE_DEPLOYMENT at the
    parachutes' opening times, GROUND_HIT) are written as OpenRocket writes them, before the first row
    at or after their time.
    """
    if traj.thrust_n is None or traj.mass_kg is None:
        raise ValueError("write_openrocket_export needs a trajectory with thrust_n and mass_kg")
    ts = _default_steps(traj) if times is None else np.asarray(times, dtype=float)
    tf = traj.time_s

    def at(x):
        return np.interp(ts, tf, x)

    alt, vel, sf = at(traj.altitude_m), at(traj.velocity_mps), at(traj.accel_mps2)
    vacc = at(np.gradient(traj.velocity_mps, tf))
    thrust, mass = at(traj.thrust_n), at(traj.mass_kg)
    drag = thrust - mass * sf
    moving = np.flatnonzero(traj.altitude_m > 1e-4)
    liftoff = float(tf[max(moving[0] - 1, 0)]) if moving.size else 0.0
    drag = np.where(ts < liftoff, 0.0, drag)
    first_dep = traj.drogue_time_s
    if first_dep is not None:
        drag = np.where(ts >= first_dep, np.abs(mass * sf), drag)
    mach, pres = at(traj.mach), at(traj.pressure_pa)
    # Orientation is known only on the pad (the trajectory has no attitude): NaN afterwards.
    zenith = np.where(ts < liftoff, np.degrees(np.arccos(min(1.0, traj.pad_accel_mps2 / G0))), np.nan)
    if imperial:
        names = ["Time (s)", "Altitude (ft)", "Vertical velocity (ft/s)", "Vertical acceleration (ft/s²)",
                 "Mach number ()", "Air pressure (psi)", "Thrust (lbf)", "Drag force (lbf)", "Mass (oz)",
                 "Vertical orientation (zenith) (°)"]
        scales = [1.0, 1 / 0.3048, 1 / 0.3048, 1 / 0.3048, 1.0, 1 / 6894.757293168, 1 / 4.4482216152605,
                  1 / 4.4482216152605, 1 / 0.028349523125, 1.0]
    else:
        names = ["Time (s)", "Altitude (m)", "Vertical velocity (m/s)", "Vertical acceleration (m/s²)",
                 "Mach number ()", "Air pressure (mbar)", "Thrust (N)", "Drag force (N)", "Mass (g)",
                 "Vertical orientation (zenith) (°)"]
        scales = [1.0, 1.0, 1.0, 1.0, 1.0, 0.01, 1.0, 1.0, 1000.0, 1.0]
    data = [ts, alt, vel, vacc, mach, pres, thrust, drag, mass, zenith]
    evs = [("LAUNCH", 0.0), ("IGNITION", 0.0)]
    e = traj.events
    evs.append(("LIFTOFF", liftoff))
    if "rail_exit" in e:
        evs.append(("LAUNCHROD", e["rail_exit"]))
    if traj.burnout_time_s is not None:
        evs.append(("BURNOUT", traj.burnout_time_s))
    evs.append(("APOGEE", traj.apogee_time_s))
    for tdep in (traj.drogue_time_s, traj.main_time_s):
        if tdep is not None:
            evs.append(("RECOVERY_DEVICE_DEPLOYMENT", tdep))
    if "landing" in e and e["landing"] <= traj.end_time_s + 1e-9:
        evs.append(("GROUND_HIT", e["landing"]))
    evs.sort(key=lambda x: x[1])

    title = traj.rocket or "Simulation"
    out = [f"# {title} (written by desktop/io/openrocket.py in OpenRocket's export format)"]
    if comment:
        out.append(f"# {comment}")
    out.append(f"# {len(ts)} data points written for {len(names)} variables.")
    out.append("#")
    out.append("# " + ",".join(names))
    k = 0
    for i, ti in enumerate(ts):
        while k < len(evs) and evs[k][1] <= ti + 1e-12:
            out.append(f"# Event {evs[k][0]} occurred at t={evs[k][1]:.6g} seconds")
            k += 1
        out.append(",".join("NaN" if d[i] != d[i] else f"{d[i] * s:.7g}"
                            for d, s in zip(data, scales, strict=True)))
    while k < len(evs):
        out.append(f"# Event {evs[k][0]} occurred at t={evs[k][1]:.6g} seconds")
        k += 1
    Path(path).write_text("\n".join(out) + "\n", encoding="utf-8")
