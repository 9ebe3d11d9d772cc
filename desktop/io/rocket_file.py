"""Rocket description files (TOML) and RASP .eng motor files: load and validate (CPython only).

A rocket file is a small TOML document (see examples/rockets/ and docs/SIMULATION.md). Every key is
checked here, in one table (`SCHEMA`): its type, its unit (in its name) and its allowed range.
Unknown keys are rejected. Any problem with the content is one `RocketFileError` (a file that cannot
be read: `InputFileError`, desktop/io/files.py) whose message is one line naming the
file, the key and the allowed range, e.g.

    examples/rockets/x.toml: [body] dry_mass_kg = -1 is out of range (allowed 0.005 to 500 kg)

Geometry convention: lengths along the rocket are measured from the nose tip (`cg_from_nose_m`) or
from the tail (`[fins] offset_from_tail_m`, `[motor] nozzle_from_tail_m`), as named.
"""

from __future__ import annotations

import math
import tomllib as _toml
from dataclasses import dataclass, field
from pathlib import Path

from desktop.errors import DesktopError
from desktop.io.files import read_text

__all__ = [
    "RocketFileError",
    "EngMotor",
    "RocketSpec",
    "load_rocket",
    "read_eng",
    "SCHEMA",
    "NOSE_KINDS",
]

NOSE_KINDS = ("conical", "ogive", "tangent", "lvhaack", "vonkarman", "elliptical", "parabolic")


class RocketFileError(DesktopError):
    """A rocket TOML or .eng file that cannot be used. The message is one line."""


# --------------------------------------------------------------------------------------------------
# Schema: section -> key -> (kind, required, low, high, unit/meaning). kind: "float", "int", "str",
# "table" (list of [x, y] pairs), "choice" (low holds the allowed values).

_F, _I, _S, _T, _C = "float", "int", "str", "table", "choice"

SCHEMA: dict[str, dict[str, tuple]] = {
    "": {
        "name": (_S, True, None, None, "rocket name"),
        "description": (_S, False, None, None, "free text"),
    },
    "motor": {
        "file": (_S, True, None, None, "RASP .eng thrust curve, path relative to the TOML file"),
        "nozzle_from_tail_m": (_F, False, 0.0, 2.0, "m"),
    },
    "body": {
        "radius_m": (_F, True, 0.005, 0.5, "m"),
        "length_m": (_F, True, 0.1, 10.0, "m"),
        "dry_mass_kg": (_F, True, 0.005, 500.0, "kg"),
        "cg_from_nose_m": (_F, True, 0.01, 10.0, "m"),
        "inertia_lateral_kgm2": (_F, False, 1e-6, 1e4, "kg m^2"),
        "inertia_roll_kgm2": (_F, False, 1e-8, 1e3, "kg m^2"),
    },
    "drag": {
        "cd": (_F, False, 0.0, 2.0, ""),
        "cd_table": (_T, False, (0.0, 5.0), (0.0, 3.0), "[[mach, cd], ...]"),
    },
    "nose": {
        "length_m": (_F, True, 0.01, 3.0, "m"),
        "kind": (_C, True, NOSE_KINDS, None, ""),
    },
    "fins": {
        "count": (_I, True, 2, 8, ""),
        "root_chord_m": (_F, True, 0.005, 2.0, "m"),
        "tip_chord_m": (_F, True, 0.0, 2.0, "m"),
        "span_m": (_F, True, 0.005, 1.0, "m"),
        "sweep_m": (_F, False, 0.0, 2.0, "m"),
        "offset_from_tail_m": (_F, False, 0.0, 5.0, "m"),
    },
    "launch": {
        "rail_length_m": (_F, True, 0.3, 20.0, "m"),
        "inclination_deg": (_F, False, 45.0, 90.0, "deg"),
        "heading_deg": (_F, False, 0.0, 360.0, "deg"),
    },
    "site": {
        "elevation_m": (_F, False, -500.0, 5000.0, "m"),
        "wind_speed_mps": (_F, False, 0.0, 30.0, "m/s"),
        "wind_from_deg": (_F, False, 0.0, 360.0, "deg"),
    },
    "drogue": {
        "cd_s_m2": (_F, True, 0.001, 50.0, "m^2"),
        "lag_s": (_F, False, 0.0, 10.0, "s"),
    },
    "main": {
        "cd_s_m2": (_F, True, 0.01, 200.0, "m^2"),
        "deploy_altitude_m": (_F, True, 10.0, 3000.0, "m"),
        "lag_s": (_F, False, 0.0, 10.0, "s"),
    },
    "board": {
        "sensors": (_S, False, None, None, "sensor profile, e.g. 'bmp390+lsm6dso'"),
        "rate_hz": (_F, False, 20.0, 100.0, "Hz"),
        "pad_s": (_F, False, 0.0, 600.0, "s"),
    },
}

_REQUIRED_SECTIONS = ("motor", "body", "nose", "fins", "launch")


# --------------------------------------------------------------------------------------------------
# Data classes


@dataclass(frozen=True)
class EngMotor:
    """A RASP .eng thrust curve with its header. `time_s`/`thrust_n` start at (0, 0)."""

    path: str
    designation: str
    diameter_mm: float
    length_mm: float
    delays: str
    propellant_kg: float
    total_kg: float
    manufacturer: str
    time_s: tuple[float, ...]
    thrust_n: tuple[float, ...]
    comments: tuple[str, ...] = ()

    @property
    def burn_time_s(self) -> float:
        return self.time_s[-1]

    @property
    def total_impulse_ns(self) -> float:
        t, f = self.time_s, self.thrust_n
        return sum(0.5 * (f[i] + f[i + 1]) * (t[i + 1] - t[i]) for i in range(len(t) - 1))

    @property
    def average_thrust_n(self) -> float:
        return self.total_impulse_ns / self.burn_time_s

    @property
    def max_thrust_n(self) -> float:
        return max(self.thrust_n)


@dataclass(frozen=True)
class Parachute:
    cd_s_m2: float
    lag_s: float
    deploy_altitude_m: float | None = None  # None: at apogee


@dataclass(frozen=True)
class RocketSpec:
    """A validated rocket description. Units are in the names; angles in degrees."""

    path: str
    name: str
    description: str
    motor: EngMotor
    nozzle_from_tail_m: float
    radius_m: float
    length_m: float
    dry_mass_kg: float
    cg_from_nose_m: float
    inertia_lateral_kgm2: float
    inertia_roll_kgm2: float
    cd: float | None
    cd_table: tuple[tuple[float, float], ...] | None
    nose_length_m: float
    nose_kind: str
    fin_count: int
    fin_root_chord_m: float
    fin_tip_chord_m: float
    fin_span_m: float
    fin_sweep_m: float
    fin_offset_from_tail_m: float
    rail_length_m: float
    inclination_deg: float
    heading_deg: float
    elevation_m: float
    wind_speed_mps: float
    wind_from_deg: float
    drogue: Parachute | None
    main: Parachute | None
    board: dict = field(default_factory=dict)

    @property
    def drag_points(self):
        """Drag as RocketPy accepts it: a constant or a list of (mach, cd)."""
        return self.cd if self.cd_table is None else [list(p) for p in self.cd_table]

    @property
    def wind_u_mps(self) -> float:
        """Wind towards the east (meteorological 'from' direction converted)."""
        return -self.wind_speed_mps * math.sin(math.radians(self.wind_from_deg))

    @property
    def wind_v_mps(self) -> float:
        """Wind towards the north."""
        return -self.wind_speed_mps * math.cos(math.radians(self.wind_from_deg))

    def replace(self, **changes) -> RocketSpec:
        """A copy with some fields changed (no re-validation; for Monte-Carlo variations)."""
        import dataclasses

        return dataclasses.replace(self, **changes)


# --------------------------------------------------------------------------------------------------
# .eng reader


def _fmt(x: float) -> str:
    return f"{x:g}"


def read_eng(path) -> EngMotor:
    """Read a RASP .eng file. Raises RocketFileError or InputFileError (one line)."""
    p = Path(path)
    # motor files are ASCII in practice; other bytes (comments from Windows tools) are replaced
    text = read_text(p, "motor file", fallback_encoding="cp1252")
    comments: list[str] = []
    header = None
    points: list[tuple[float, float]] = []
    for lineno, raw in enumerate(text.splitlines(), 1):
        line = raw.strip()
        if not line:
            continue
        if line.startswith(";"):
            comments.append(line[1:].strip())
            continue
        if header is None:
            parts = line.split()
            if len(parts) < 7:
                raise RocketFileError(
                    f"{p}:{lineno}: .eng header needs 7 fields 'designation diameter_mm length_mm delays "
                    f"propellant_kg total_kg manufacturer', found {len(parts)}"
                )
            try:
                dia, length, prop, total = (float(parts[1]), float(parts[2]), float(parts[4]),
                                            float(parts[5]))
            except ValueError:
                raise RocketFileError(f"{p}:{lineno}: .eng header has a non-numeric size or mass") from None
            if not (5 <= dia <= 400 and 20 <= length <= 5000):
                raise RocketFileError(
                    f"{p}:{lineno}: .eng diameter {dia:g} mm / length {length:g} mm out of range "
                    "(5 to 400 mm, 20 to 5000 mm)"
                )
            if not (0 < prop < total <= 500):
                raise RocketFileError(
                    f"{p}:{lineno}: .eng masses need 0 < propellant ({prop:g} kg) < total ({total:g} kg) "
                    "<= 500"
                )
            header = (parts[0], dia, length, parts[3], prop, total, " ".join(parts[6:]))
            continue
        parts = line.split()
        if len(parts) != 2:
            raise RocketFileError(f"{p}:{lineno}: thrust point needs 'time_s thrust_N', found {line!r}")
        try:
            t, f = float(parts[0]), float(parts[1])
        except ValueError:
            raise RocketFileError(f"{p}:{lineno}: thrust point {line!r} is not two numbers") from None
        if not (math.isfinite(t) and math.isfinite(f)) or f < 0 or t < 0:
            raise RocketFileError(f"{p}:{lineno}: thrust point {line!r} must be finite, t >= 0, thrust >= 0")
        if points and t <= points[-1][0]:
            raise RocketFileError(f"{p}:{lineno}: thrust point times must increase ({t:g} after "
                                  f"{points[-1][0]:g})")
        points.append((t, f))
    if header is None:
        raise RocketFileError(f"{p}: no .eng header line (is this a RASP .eng file?)")
    if len(points) < 2:
        raise RocketFileError(f"{p}: .eng file has fewer than 2 thrust points")
    if points[-1][1] != 0.0:
        raise RocketFileError(f"{p}: .eng thrust curve must end at zero thrust (last point {points[-1]})")
    if points[0][0] > 0.0:
        points.insert(0, (0.0, 0.0))
    elif points[0][1] != 0.0:  # a curve starting at t=0 with thrust: keep it
        pass
    motor = EngMotor(
        path=str(p),
        designation=header[0],
        diameter_mm=header[1],
        length_mm=header[2],
        delays=header[3],
        propellant_kg=header[4],
        total_kg=header[5],
        manufacturer=header[6],
        time_s=tuple(t for t, _ in points),
        thrust_n=tuple(f for _, f in points),
        comments=tuple(comments),
    )
    if motor.total_impulse_ns <= 0:
        raise RocketFileError(f"{p}: thrust curve has no impulse")
    return motor


# --------------------------------------------------------------------------------------------------
# TOML loader


def _where(section: str, key: str) -> str:
    return f"[{section}] {key}" if section else key


def _range_text(low, high, unit) -> str:
    u = f" {unit}" if unit else ""
    return f"allowed {_fmt(low)} to {_fmt(high)}{u}"


def _check_value(path, section, key, value, spec):
    kind, _req, low, high, unit = spec
    where = _where(section, key)
    if kind == _S:
        if not isinstance(value, str) or not value.strip():
            raise RocketFileError(f"{path}: {where} must be a non-empty string ({unit})")
        return value.strip()
    if kind == _C:
        if not isinstance(value, str) or value.replace(" ", "").replace("_", "").lower() not in low:
            raise RocketFileError(f"{path}: {where} = {value!r} is not allowed (allowed: {', '.join(low)})")
        return value.replace(" ", "").replace("_", "").lower()
    if kind in (_F, _I):
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            raise RocketFileError(
                f"{path}: {where} = {value!r} must be a number ({_range_text(low, high, unit)})"
            )
        if kind == _I and not isinstance(value, int):
            raise RocketFileError(
                f"{path}: {where} = {value!r} must be an integer ({_range_text(low, high, unit)})"
            )
        if not math.isfinite(float(value)) or not (low <= value <= high):
            raise RocketFileError(
                f"{path}: {where} = {value!r} is out of range ({_range_text(low, high, unit)})"
            )
        return int(value) if kind == _I else float(value)
    if kind == _T:
        (mlo, mhi), (clo, chi) = low, high
        msg = (f"{path}: {where} must be a list of at least 2 [mach, cd] pairs with mach increasing "
               f"from {_fmt(mlo)} to {_fmt(mhi)} and cd {_fmt(clo)} to {_fmt(chi)}")
        if not isinstance(value, list) or len(value) < 2:
            raise RocketFileError(msg)
        out = []
        for item in value:
            if (not isinstance(item, list) or len(item) != 2
                    or any(isinstance(v, bool) or not isinstance(v, (int, float)) for v in item)):
                raise RocketFileError(msg + f" (bad entry {item!r})")
            m, c = float(item[0]), float(item[1])
            if not (mlo <= m <= mhi and clo <= c <= chi) or (out and m <= out[-1][0]):
                raise RocketFileError(msg + f" (bad entry {item!r})")
            out.append((m, c))
        return tuple(out)
    raise AssertionError(kind)  # pragma: no cover


def _section(path, doc, section) -> dict:
    schema = SCHEMA[section]
    if section:
        raw = doc.get(section)
        if raw is None:
            return {}
        if not isinstance(raw, dict):
            raise RocketFileError(f"{path}: [{section}] must be a table")
    else:
        raw = {k: v for k, v in doc.items() if not isinstance(v, dict)}
    out = {}
    for key, value in raw.items():
        if key not in schema:
            allowed = ", ".join(schema)
            raise RocketFileError(f"{path}: unknown key {_where(section, key)} (allowed: {allowed})")
        out[key] = _check_value(path, section, key, value, schema[key])
    for key, spec in schema.items():
        if spec[1] and key not in out:
            kind, _req, low, high, unit = spec
            if kind in (_F, _I):
                extra = f" ({_range_text(low, high, unit)})"
            elif kind == _C:
                extra = f" (one of: {', '.join(low)})"
            else:
                extra = f" ({unit})"
            raise RocketFileError(f"{path}: missing key {_where(section, key)}{extra}")
    return out


def load_rocket(path) -> RocketSpec:
    """Load and validate a rocket TOML file (and its motor). Raises RocketFileError or
    InputFileError (one line)."""
    p = Path(path)
    text = read_text(p, "rocket file")
    try:
        doc = _toml.loads(text)
    except _toml.TOMLDecodeError as e:
        raise RocketFileError(f"{p}: TOML syntax error: {str(e).splitlines()[0]}") from None

    for name, value in doc.items():
        if isinstance(value, dict) and name not in SCHEMA:
            raise RocketFileError(
                f"{p}: unknown section [{name}] (allowed: {', '.join(s for s in SCHEMA if s)})"
            )
    for name in _REQUIRED_SECTIONS:
        if name not in doc:
            raise RocketFileError(f"{p}: missing section [{name}]")
    top = _section(p, doc, "")
    sec = {name: _section(p, doc, name) for name in SCHEMA if name}

    body, nose, fins, drag = sec["body"], sec["nose"], sec["fins"], sec["drag"]
    if ("cd" in drag) == ("cd_table" in drag):
        raise RocketFileError(
            f"{p}: [drag] needs exactly one of cd (constant, allowed 0 to 2) or cd_table ([[mach, cd], ...])"
        )
    length = body["length_m"]
    radius = body["radius_m"]
    if not body["cg_from_nose_m"] < length:
        raise RocketFileError(
            f"{p}: [body] cg_from_nose_m = {_fmt(body['cg_from_nose_m'])} must be less than [body] "
            f"length_m = {_fmt(length)}"
        )
    if not nose["length_m"] < length:
        raise RocketFileError(
            f"{p}: [nose] length_m = {_fmt(nose['length_m'])} must be less than [body] length_m = "
            f"{_fmt(length)}"
        )
    offset = fins.get("offset_from_tail_m", 0.0)
    if fins["tip_chord_m"] > fins["root_chord_m"]:
        raise RocketFileError(
            f"{p}: [fins] tip_chord_m = {_fmt(fins['tip_chord_m'])} must not exceed root_chord_m = "
            f"{_fmt(fins['root_chord_m'])}"
        )
    if offset + fins["root_chord_m"] > length - nose["length_m"]:
        raise RocketFileError(
            f"{p}: [fins] root_chord_m + offset_from_tail_m = {_fmt(offset + fins['root_chord_m'])} m "
            f"must fit on the body behind the nose ({_fmt(length - nose['length_m'])} m)"
        )
    sweep = fins.get("sweep_m", fins["root_chord_m"] - fins["tip_chord_m"])

    motor_path = (p.parent / sec["motor"]["file"]).resolve()
    motor = read_eng(motor_path)
    nozzle = sec["motor"].get("nozzle_from_tail_m", 0.0)
    if motor.diameter_mm > 2000.0 * radius + 1e-9:
        raise RocketFileError(
            f"{p}: [motor] {motor.designation} is {_fmt(motor.diameter_mm)} mm wide; it does not fit in "
            f"[body] radius_m = {_fmt(radius)} ({_fmt(2000 * radius)} mm diameter)"
        )
    if nozzle + motor.length_mm / 1000.0 > length - nose["length_m"] + 1e-9:
        raise RocketFileError(
            f"{p}: [motor] {motor.designation} ({_fmt(motor.length_mm)} mm) + nozzle_from_tail_m does not "
            f"fit in the body behind the nose ({_fmt(1000 * (length - nose['length_m']))} mm)"
        )

    mass = body["dry_mass_kg"]
    i_lat = body.get("inertia_lateral_kgm2", mass * length**2 / 12.0)
    i_roll = body.get("inertia_roll_kgm2", mass * radius**2)

    drogue = sec["drogue"]
    main = sec["main"]
    site = sec["site"]
    launch = sec["launch"]
    board = dict(sec["board"])
    if "sensors" in board:
        board["sensors"] = board["sensors"].lower()

    return RocketSpec(
        path=str(p),
        name=top["name"],
        description=top.get("description", ""),
        motor=motor,
        nozzle_from_tail_m=nozzle,
        radius_m=radius,
        length_m=length,
        dry_mass_kg=mass,
        cg_from_nose_m=body["cg_from_nose_m"],
        inertia_lateral_kgm2=i_lat,
        inertia_roll_kgm2=i_roll,
        cd=drag.get("cd"),
        cd_table=drag.get("cd_table"),
        nose_length_m=nose["length_m"],
        nose_kind=nose["kind"],
        fin_count=fins["count"],
        fin_root_chord_m=fins["root_chord_m"],
        fin_tip_chord_m=fins["tip_chord_m"],
        fin_span_m=fins["span_m"],
        fin_sweep_m=sweep,
        fin_offset_from_tail_m=offset,
        rail_length_m=launch["rail_length_m"],
        inclination_deg=launch.get("inclination_deg", 90.0),
        heading_deg=launch.get("heading_deg", 0.0),
        elevation_m=site.get("elevation_m", 0.0),
        wind_speed_mps=site.get("wind_speed_mps", 0.0),
        wind_from_deg=site.get("wind_from_deg", 0.0),
        drogue=Parachute(drogue["cd_s_m2"], drogue.get("lag_s", 1.0)) if drogue else None,
        main=(Parachute(main["cd_s_m2"], main.get("lag_s", 1.0), main["deploy_altitude_m"])
              if main else None),
        board=board,
    )
