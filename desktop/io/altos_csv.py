"""AltosUI CSV exports (Altus Metrum boards: TeleMetrum, TeleMega, EasyMega, EasyMini, TeleMini) as
flight-CSV columns. The layout and its quirks are documented for users in docs/IMPORT.md.

- Header: the line that starts ``#version,serial,flight`` (or without the ``#``). Columns are found
  by name, the first of each name: an export has two ``altitude`` columns (the barometric altitude,
  then the GPS one), and version 5 writers ran the last basic name into the first IMU name
  (``main_voltageaccel_x``) and listed fewer IMU names than values, so only the names up to the
  igniter voltages are trusted, and rows may hold more cells than the header has names; from
  version 6 every row has one cell per name.
- ``time``: seconds from AltosUI's boost time (negative on the pad). AltosUI writes one row per log
  record of any kind, carrying every other value forward, so several rows share a printed time
  and rows of temperature, voltage and GPS records repeat the last sensor values. The board logs
  its sensors every 10 ms in pad/boost/fast/coast and every 100 ms after apogee, so a row is kept
  only when it is at least 9.5 ms (ascent states) or 95 ms (descent states) after the last kept
  row, and of rows sharing a time the last one (the latest values) is kept.
- ``pressure``: Pa (AltosUI's own comments say mBar; the values are Pa). ``acceleration``: m/s^2
  along the long axis relative to the pad reading (about 0 at rest), so the specific force is
  ``acceleration + g`` (the board stood vertical on the pad). ``state_name``: the board's state.
- 2147483647 is AltosUI's "missing" value: an empty cell.
"""

from pathlib import Path

import numpy as np

from desktop.io.files import read_text
from desktop.io.flightcsv import ACCEL_EXPECTED, FlightCSVError, first_implausible_accel
from shared.physics import G0_MPS2

ALTOS_MISSING = 2147483647.0
#: Minimum spacing of kept rows (s): the board's sensor period less half a tick, by flight phase.
ASCENT_SPACING_S = 0.0095
DESCENT_SPACING_S = 0.095
DESCENT_STATES = ("drogue", "main", "landed")
#: Pressure outside this range (Pa) is not a barometer reading in Pa.
PRESSURE_RANGE_PA = (1000.0, 120000.0)

# Header name -> flight-CSV column (extra columns keep the board's view alongside the readings).
_CARRIED = (
    ("state_name", "altos_state"),
    ("height", "altos_height_m"),
    ("speed", "altos_speed_mps"),
    ("accel_speed", "altos_speed_mps"),
    ("temperature", "temperature_c"),
    ("battery_voltage", "battery_v"),
    ("drogue_voltage", "drogue_sense_v"),
    ("main_voltage", "main_sense_v"),
    ("pyro", "pyro_battery_v"),
    ("igniter_a", "igniter_a_sense_v"),
    ("igniter_b", "igniter_b_sense_v"),
    ("igniter_c", "igniter_c_sense_v"),
    ("igniter_d", "igniter_d_sense_v"),
)
# Version-5 comment keys -> flight-CSV metadata.
_CONFIG_KEYS = {
    "product": "board",
    "serial number": "serial",
    "software version": "firmware",
    "main deploy": "main_deploy_m",
    "apogee delay": "apogee_delay_s",
}


def is_header(line):
    """True for an AltosUI CSV header line."""
    return line.lstrip("#").strip().lower().startswith("version,serial,flight")


def _header_index(names):
    """First column of each name; a version-5 ``main_voltage<next name>`` token counts as main_voltage."""
    index = {}
    for j, name in enumerate(names):
        if name.startswith("main_voltage") and name != "main_voltage":
            name = "main_voltage"
        index.setdefault(name, j)
    return index


def board_family(index, comments):
    """The board from the version-5 ``Product`` comment, else from the columns present."""
    if "board" in comments:
        return comments["board"]
    has_accel = "acceleration" in index
    has_gps = "latitude" in index
    if "igniter_a" in index or "accel_x" in index:
        return "TeleMega" if has_gps else "EasyMega"
    if has_accel:
        return "TeleMetrum" if has_gps else "Altus Metrum board with an accelerometer"
    return "EasyMini or TeleMini (no accelerometer)"


def _number(path, lineno, name, text):
    try:
        value = float(text)
    except ValueError:
        raise FlightCSVError(path, lineno, f"AltosUI column {name!r}: {text!r} is not a number") from None
    return np.nan if value == ALTOS_MISSING or not np.isfinite(value) else value


def kept_rows(time_s, states):
    """Indices of the rows that are the board's sensor samples (see the module docstring)."""
    last_of_time = [i for i in range(len(time_s)) if i + 1 == len(time_s) or time_s[i + 1] != time_s[i]]
    keep = []
    last_t = None
    for i in last_of_time:
        spacing = DESCENT_SPACING_S if states[i] in DESCENT_STATES else ASCENT_SPACING_S
        if last_t is None or time_s[i] - last_t >= spacing:
            keep.append(i)
            last_t = time_s[i]
    return keep


def read_altos_csv(path):
    """Read an AltosUI CSV export. Returns (columns, metadata, comments) for ``write_flight_csv``;
    raises FlightCSVError (one line) on anything it cannot read."""
    spath = str(path)
    text = read_text(path, "AltosUI CSV export")
    lines = text.splitlines()
    comments = {}
    header_at = None
    for lineno, line in enumerate(lines, 1):
        if is_header(line):
            header_at = lineno
            break
        body = line.lstrip("#").strip()
        if line.startswith("#") and ":" in body:
            key, value = body.split(":", 1)
            if key.strip().lower() in _CONFIG_KEYS:
                comments[_CONFIG_KEYS[key.strip().lower()]] = value.strip()
    if header_at is None:
        raise FlightCSVError(spath, None, "no AltosUI header line ('#version,serial,flight,...')")
    names = [n.strip() for n in lines[header_at - 1].lstrip("#").split(",")]
    index = _header_index(names)
    for required in ("time", "state_name", "pressure"):
        if required not in index:
            raise FlightCSVError(spath, header_at, f"AltosUI header has no {required!r} column")
    needed = max(index[n] for n in ("time", "state_name", "pressure", "acceleration") if n in index)

    rows, row_lines = [], []
    for lineno in range(header_at + 1, len(lines) + 1):
        line = lines[lineno - 1]
        if not line.strip() or line.startswith("#"):
            continue
        cells = [c.strip() for c in line.split(",")]
        if cells[0] != "5" and len(cells) != len(names):  # from version 6 the header is exact
            raise FlightCSVError(spath, lineno, f"row has {len(cells)} cells, the header {len(names)} "
                                 "names (an export written with a decimal comma?)")
        if rows and len(cells) != len(rows[0]):
            raise FlightCSVError(spath, lineno, f"row has {len(cells)} cells, the rows before it "
                                 f"{len(rows[0])}")
        if len(cells) <= needed:
            raise FlightCSVError(spath, lineno, f"row has {len(cells)} cells, the header names "
                                 f"{needed + 1} up to the sensor columns")
        rows.append(cells)
        row_lines.append(lineno)
    if not rows:
        raise FlightCSVError(spath, header_at, "no data rows after the AltosUI header")

    j_time = index["time"]
    time_s = np.array([_number(spath, ln, "time", r[j_time]) for r, ln in zip(rows, row_lines, strict=True)])
    for i in range(len(time_s)):
        if np.isnan(time_s[i]):
            raise FlightCSVError(spath, row_lines[i], "AltosUI column 'time' is empty")
        if i and time_s[i] < time_s[i - 1]:
            raise FlightCSVError(spath, row_lines[i], f"time goes back: {time_s[i]} s after "
                                 f"{time_s[i - 1]} s (line {row_lines[i - 1]})")
    states = [r[index["state_name"]] for r in rows]
    keep = kept_rows(time_s, states)

    def column(name):
        j = index[name]
        return np.array([_number(spath, row_lines[i], name, rows[i][j]) for i in keep])

    pressure = column("pressure")
    bad = np.flatnonzero((pressure < PRESSURE_RANGE_PA[0]) | (pressure > PRESSURE_RANGE_PA[1]))
    if bad.size:
        i = keep[int(bad[0])]
        raise FlightCSVError(spath, row_lines[i], f"AltosUI column 'pressure': {rows[i][index['pressure']]} "
                             f"is not a pressure in Pa (expected {PRESSURE_RANGE_PA[0]:.0f}.."
                             f"{PRESSURE_RANGE_PA[1]:.0f})")
    columns = {"time_s": time_s[keep], "pressure_pa": pressure}
    if "acceleration" in index:
        accel = column("acceleration") + G0_MPS2
        bad = first_implausible_accel(accel)
        if bad is not None:
            i = keep[bad]
            text = rows[i][index["acceleration"]].strip()
            raise FlightCSVError(spath, row_lines[i], f"AltosUI column 'acceleration': {text} m/s^2 is "
                                 f"implausible ({ACCEL_EXPECTED})")
        columns["accel_mps2"] = accel
    for name, out in _CARRIED:
        if name == "state_name":
            columns[out] = np.array([states[i] for i in keep], dtype=object)
        elif name in index and out not in columns:
            columns[out] = column(name)
    first = rows[0]
    version = first[0]
    metadata = {
        "source": f"AltosUI CSV export {Path(spath).name} (CSV version {version})",
        "board": board_family(index, comments),
        "altos_serial": first[index["serial"]] if "serial" in index else "?",
        "altos_flight": first[index["flight"]] if "flight" in index else "?",
        "time_origin": "AltosUI boost time (0 at the board's launch detection)",
    }
    for key in ("firmware", "main_deploy_m", "apogee_delay_s"):
        if key in comments:
            metadata[key] = comments[key].split()[0]
    notes = [
        f"imported from an AltosUI CSV export: {len(keep)} of {len(rows)} rows are sensor samples "
        "(the others repeat values of temperature, voltage and GPS records)",
        "accel_mps2 = AltosUI acceleration + 9.80665 (the board stood vertical on the pad)",
    ]
    return columns, metadata, notes
