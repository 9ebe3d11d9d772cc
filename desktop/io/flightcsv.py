"""The project's flight-CSV format: reader, writer and validation (CPython only).

The format is documented for users in docs/FLIGHT_CSV.md. In short: UTF-8 text; `#` lines are
comments, `# key: value` comments are metadata; one header line; one comma-separated row per sample.
`time_s` (increasing) and `pressure_pa` and/or `altitude_m` are required; `accel_mps2`
(specific force along the long axis, +9.81 at rest nose up) is optional; other columns are kept
uninterpreted in `FlightLog.extra`. An empty cell means "no reading in this sample".

Time is converted once to integer microseconds by exact decimal rounding of the text
(`time_us = round(time_s * 1e6)`, ties to even, no float error: "10.20" -> 10200000). Rows with
the same time are folded into the first of them (an identical row dropped, different readings
merged, the later reading kept where both rows have one) and listed in `FlightLog.duplicate_times`,
so that every consumer can say what it did (`describe_duplicate_times`).

Every problem with a file's content is a `FlightCSVError` whose message is one line:
`<path>:<line>: <problem>` (or `<path>: <problem>` where no line applies); a file that cannot be
read as UTF-8 text at all (missing, a directory, binary) is an `InputFileError` of the same form
(desktop/io/files.py).
"""

from __future__ import annotations

import math
import re
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from decimal import ROUND_HALF_EVEN, Decimal, DecimalException
from pathlib import Path

import numpy as np

from desktop.errors import DesktopError
from desktop.io.files import decode_text, read_bytes
from shared.physics import G0_MPS2

__all__ = [
    "DuplicateTime",
    "FlightCSVError",
    "FlightLog",
    "describe_duplicate_times",
    "read_flight_csv",
    "write_flight_csv",
    "PRESSURE_MAX_PA",
    "ACCEL_MAX_MPS2",
    "ACCEL_EXPECTED",
    "first_implausible_accel",
    "NO_MAIN",
]

#: Pressure above this (Pa) is rejected as implausible (sea level is ~101325 Pa).
PRESSURE_MAX_PA = 200000.0
#: An accelerometer reading beyond this (m/s^2, 2000 g) is rejected as implausible: no part's
#: register reports it (an ADXL375's 16-bit register at 49 mg per count reads at most 1606 g).
ACCEL_MAX_MPS2 = 19613.3
#: What an implausible reading's error message says is expected.
ACCEL_EXPECTED = f"expected at most {ACCEL_MAX_MPS2:.0f}, {ACCEL_MAX_MPS2 / G0_MPS2:.0f} g, either sign"
#: `# main_deploy_m: none`: the rocket has no main parachute (single deployment).
NO_MAIN = "none"

# Column names with a meaning to the reader.
TIME = "time_s"
PRESSURE = "pressure_pa"
ALTITUDE = "altitude_m"
ACCEL = "accel_mps2"
_KNOWN = (TIME, PRESSURE, ALTITUDE, ACCEL)

# A number as the format accepts it: optional sign, digits with optional decimal point, optional
# exponent. Deliberately stricter than float(): no "nan", "inf", "1_000", or non-ASCII digits.
_NUMBER_RE = re.compile(r"[+-]?(?:[0-9]+\.?[0-9]*|\.[0-9]+)(?:[eE][+-]?[0-9]+)?\Z")
# NaN/inf spellings that float() would accept; reported with their own message.
_NONFINITE_RE = re.compile(r"[+-]?(?:nan|inf|infinity)\Z", re.IGNORECASE)
# `# key: value` metadata: an identifier-like key, then a colon followed by a space or the end.
_META_RE = re.compile(r"([A-Za-z_][A-Za-z0-9_.-]*)\s*:(?:\s+(.*)|\s*)\Z", re.DOTALL)
# Keys the writer accepts (the reader lowercases, so the writer insists on lowercase).
_WRITE_KEY_RE = re.compile(r"[a-z_][a-z0-9_.-]*\Z")

# Whitespace stripped around cells and names: ASCII only (no Unicode line separators).
_WS = " \t\r\f\v"

# int64-safe bound on |time_us| (about 146 000 years).
_TIME_US_LIMIT = 2**62
_US_PER_S = Decimal(1000000)


class FlightCSVError(DesktopError):
    """A flight CSV that cannot be read. The message is one line naming file, line and problem."""

    def __init__(self, path, line: int | None, problem: str):
        self.path = str(path)
        self.line = line
        self.problem = problem
        where = self.path if line is None else f"{self.path}:{line}"
        super().__init__(f"{where}: {problem}")


@dataclass(frozen=True)
class DuplicateTime:
    """A row whose time equals an earlier row's (to the microsecond), folded into that row."""

    line: int  # the folded row's line
    kept_line: int  # the line of the row it was folded into (the first with that time)
    time_s: str  # the time as written on the folded row
    identical: bool  # same readings in every column: the row was dropped
    differing: tuple[str, ...] = ()  # columns where both rows had different readings: the later kept


def describe_duplicate_times(duplicates: Sequence[DuplicateTime], shown: int = 5) -> str | None:
    """One line saying how the rows with duplicated time stamps were handled, or None."""
    if not duplicates:
        return None

    def lines(ds):
        text = ", ".join(str(d.line) for d in ds[:shown])
        return text + (f" and {len(ds) - shown} more" if len(ds) > shown else "")

    parts = []
    same = [d for d in duplicates if d.identical]
    if same:
        parts.append(f"{len(same)} identical row(s) dropped (line {lines(same)})")
    merged = [d for d in duplicates if not d.identical]
    if merged:
        text = (f"{len(merged)} row(s) with different readings merged into the row before "
                f"(line {lines(merged)})")
        differing = sorted({c for d in merged for c in d.differing})
        if differing:
            text += ", the later reading kept where both had one (" + ", ".join(differing) + ")"
        parts.append(text)
    return "duplicated time stamps: " + "; ".join(parts)


@dataclass
class FlightLog:
    """One flight read from a flight CSV. Arrays have one entry per data row."""

    path: str
    metadata: dict[str, str]
    comments: list[str]
    columns: list[str]
    time_s: np.ndarray
    time_us: np.ndarray
    pressure_pa: np.ndarray | None
    altitude_m: np.ndarray | None
    accel_mps2: np.ndarray | None
    extra: dict[str, np.ndarray]
    line_numbers: np.ndarray
    #: Source line of each metadata key (for error messages).
    metadata_lines: dict[str, int] = field(default_factory=dict, repr=False)
    #: Rows folded into an earlier row with the same time (see DuplicateTime).
    duplicate_times: list[DuplicateTime] = field(default_factory=list)

    def __len__(self) -> int:
        return len(self.time_us)

    @property
    def has_pressure(self) -> bool:
        """True when the file has a `pressure_pa` column with at least one reading."""
        return self.pressure_pa is not None and bool(np.isfinite(self.pressure_pa).any())

    @property
    def has_altitude(self) -> bool:
        """True when the file has an `altitude_m` column with at least one reading."""
        return self.altitude_m is not None and bool(np.isfinite(self.altitude_m).any())

    @property
    def has_accel(self) -> bool:
        """True when the file has an `accel_mps2` column with at least one reading."""
        return self.accel_mps2 is not None and bool(np.isfinite(self.accel_mps2).any())

    def metadata_float(self, key: str, default: float | None = None) -> float | None:
        """The metadata value `key` as a finite float, or `default` when the key is absent.

        Raises FlightCSVError (naming the metadata line) when the value is not a plain number.
        """
        key = key.strip().lower()
        if key not in self.metadata:
            return default
        text = self.metadata[key].strip()
        if not _NUMBER_RE.match(text):
            raise FlightCSVError(
                self.path, self.metadata_lines.get(key), f"metadata '{key}': {text!r} is not a number"
            )
        value = float(text)
        if not math.isfinite(value):
            raise FlightCSVError(
                self.path, self.metadata_lines.get(key), f"metadata '{key}': {text!r} is out of range"
            )
        return value

    def main_deploy_m(self) -> float | None:
        """The deployment plan of the `main_deploy_m` metadata: the main's height in m, 0.0 for
        `none` (no main parachute), or None when the file does not say."""
        if self.metadata.get("main_deploy_m", "").strip().lower() == NO_MAIN:
            return 0.0
        return self.metadata_float("main_deploy_m")


# --------------------------------------------------------------------------------------------------
# Reader


def _decode(path: str, data: bytes) -> str:
    text = decode_text(path, data, "flight CSV")
    cr = text.replace("\r\n", "\n\n").find("\r")
    if cr >= 0:
        line = text.count("\n", 0, cr) + 1  # CRLF replaced by 2 chars: offsets are unchanged
        raise FlightCSVError(path, line, "carriage return inside a line (only LF or CRLF line ends)")
    return text


def _time_to_us(path: str, lineno: int, text: str) -> int:
    """Exact decimal seconds -> integer microseconds, rounding half to even (like round())."""
    try:
        d = Decimal(text)
    except (DecimalException, ValueError):  # pragma: no cover - the caller checked the syntax
        raise FlightCSVError(path, lineno, f"column '{TIME}': {text!r} is not a number") from None
    # adjusted() is the decimal exponent of the leading digit: reject huge values before int().
    us = 0 if d.is_zero() else None
    if us is None and d.adjusted() < 13:
        us = int((d * _US_PER_S).to_integral_value(rounding=ROUND_HALF_EVEN))
    if us is None or not -_TIME_US_LIMIT < us < _TIME_US_LIMIT:
        raise FlightCSVError(path, lineno, f"column '{TIME}': {text!r} is out of range")
    return us


def _bad_number(path: str, lineno: int, name: str, text: str) -> FlightCSVError:
    if _NONFINITE_RE.match(text):
        return FlightCSVError(
            path, lineno, f"column {name!r}: {text!r} is not allowed (leave the cell empty for no reading)"
        )
    return FlightCSVError(path, lineno, f"column {name!r}: {text!r} is not a number")


def _numeric_column(path: str, name: str, cells: list[str], lines: list[int]) -> np.ndarray:
    """Parse a required-numeric column; empty cells become NaN."""
    out = np.empty(len(cells), dtype=np.float64)
    match = _NUMBER_RE.match
    nan = math.nan
    for i, c in enumerate(cells):
        if not c:
            out[i] = nan
            continue
        if not match(c):
            raise _bad_number(path, lines[i], name, c)
        v = float(c)
        if v in (math.inf, -math.inf):
            raise FlightCSVError(path, lines[i], f"column {name!r}: {c!r} is out of range")
        out[i] = v
    return out


def _extra_column(path: str, name: str, cells: list[str], lines: list[int]) -> np.ndarray:
    """An uninterpreted column: float64 if every non-empty cell is a number, else str objects."""
    match = _NUMBER_RE.match
    text_cells = [i for i, c in enumerate(cells) if c and not match(c)]
    if not text_cells:
        return _numeric_column(path, name, cells, lines)
    if all(_NONFINITE_RE.match(cells[i]) for i in text_cells):
        # A numeric column with NaN/inf spelled out: the same rule as the sensor columns.
        i = text_cells[0]
        raise _bad_number(path, lines[i], name, cells[i])
    arr = np.empty(len(cells), dtype=object)
    arr[:] = cells
    return arr


def first_implausible_accel(accel_mps2):
    """Index of the first accelerometer reading beyond ``ACCEL_MAX_MPS2`` of either sign (empty
    cells, NaN, are not readings), or None; None for no column."""
    if accel_mps2 is None:
        return None
    bad = np.flatnonzero(np.abs(np.asarray(accel_mps2, dtype=float)) > ACCEL_MAX_MPS2)
    return int(bad[0]) if bad.size else None


def read_flight_csv(path) -> FlightLog:
    """Read and validate a flight CSV. Raises FlightCSVError (one line, with line number) on any
    problem with the file; never drops a row silently (rows with a duplicated time are folded
    and listed in ``duplicate_times``)."""
    spath = str(path)
    data = read_bytes(path, "flight CSV")
    if not data:
        raise FlightCSVError(spath, None, "file is empty (no header line)")
    text = _decode(spath, data)
    lines = text.split("\n")

    metadata: dict[str, str] = {}
    metadata_lines: dict[str, int] = {}
    comments: list[str] = []

    def comment(lineno: int, line: str) -> None:
        body = line[1:]
        if body.startswith(" "):
            body = body[1:]
        body = body.rstrip()
        m = _META_RE.match(body.strip())
        if m is None:
            comments.append(body)
            return
        key = m.group(1).lower()
        if key in metadata:
            raise FlightCSVError(
                spath, lineno, f"metadata key '{key}' repeated (first on line {metadata_lines[key]})"
            )
        metadata[key] = (m.group(2) or "").strip()
        metadata_lines[key] = lineno

    # Header: the first line that is neither blank nor a comment.
    header_lineno = 0
    columns: list[str] = []
    idx = 0
    n_lines = len(lines)
    while idx < n_lines:
        line = lines[idx].rstrip("\r")
        idx += 1
        stripped = line.strip(_WS)
        if not stripped:
            continue
        if stripped.startswith("#"):
            comment(idx, stripped)
            continue
        header_lineno = idx
        columns = [c.strip(_WS) for c in line.split(",")]
        break
    if not header_lineno:
        raise FlightCSVError(spath, None, "no header line (the file holds only comments or blank lines)")

    for j, name in enumerate(columns):
        if not name:
            raise FlightCSVError(spath, header_lineno, f"header: column {j + 1} has an empty name")
    seen: dict[str, int] = {}
    for j, name in enumerate(columns):
        if name in seen:
            raise FlightCSVError(
                spath, header_lineno, f"header: duplicate column name {name!r} (columns {seen[name] + 1} "
                f"and {j + 1})"
            )
        seen[name] = j
    if TIME not in seen:
        shown = ", ".join(repr(c) for c in columns[:8]) + (", ..." if len(columns) > 8 else "")
        raise FlightCSVError(
            spath, header_lineno,
            f"header has no '{TIME}' column (found {shown}); is the header line missing?",
        )
    if PRESSURE not in seen and ALTITUDE not in seen:
        raise FlightCSVError(
            spath, header_lineno, f"header needs a '{PRESSURE}' or '{ALTITUDE}' column (found "
            + ", ".join(repr(c) for c in columns) + ")"
        )

    # Data rows, collected column-major as stripped strings.
    ncol = len(columns)
    cols: list[list[str]] = [[] for _ in range(ncol)]
    row_lines: list[int] = []
    blank_at = 0  # first blank line since the last row (an error if more rows follow)
    while idx < n_lines:
        line = lines[idx]
        idx += 1
        if line.endswith("\r"):
            line = line[:-1]
        if not line.strip(_WS):
            if not blank_at:
                blank_at = idx
            continue
        if line.lstrip(_WS).startswith("#"):
            comment(idx, line.strip(_WS))
            continue
        if blank_at:
            raise FlightCSVError(
                spath, blank_at, "blank line inside the data (only trailing blank lines are allowed)"
            )
        cells = line.split(",")
        if len(cells) != ncol:
            raise FlightCSVError(
                spath, idx, f"row has {len(cells)} cells, the header has {ncol} columns"
            )
        for j in range(ncol):
            cols[j].append(cells[j].strip(_WS))
        row_lines.append(idx)

    if not row_lines:
        raise FlightCSVError(spath, header_lineno, "no data rows after the header")

    # Time: exact integer microseconds, increasing; rows with an equal time are folded.
    tcells = cols[seen[TIME]]
    time_us_list = []
    match = _NUMBER_RE.match
    prev_us = None
    kept: list[int] = []
    duplicates: list[DuplicateTime] = []
    for i, c in enumerate(tcells):
        lineno = row_lines[i]
        if not c:
            raise FlightCSVError(spath, lineno, f"column '{TIME}' is empty (every row needs a time)")
        if not match(c):
            raise _bad_number(spath, lineno, TIME, c)
        us = _time_to_us(spath, lineno, c)
        if prev_us is not None and us < prev_us:
            raise FlightCSVError(
                spath, lineno, f"time goes backwards: {c} s after {tcells[i - 1]} s "
                f"(line {row_lines[i - 1]})"
            )
        if us == prev_us:
            duplicates.append(_fold_row(cols, columns, seen[TIME], kept[-1], i, row_lines, c))
            continue
        prev_us = us
        kept.append(i)
        time_us_list.append(us)
    if duplicates:
        cols = [[col[i] for i in kept] for col in cols]
        row_lines = [row_lines[i] for i in kept]
        tcells = cols[seen[TIME]]
    time_us = np.array(time_us_list, dtype=np.int64)
    time_s = np.array([float(c) for c in tcells], dtype=np.float64)
    line_numbers = np.array(row_lines, dtype=np.int64)

    sensors: dict[str, np.ndarray | None] = {}
    for name in (PRESSURE, ALTITUDE, ACCEL):
        sensors[name] = (
            _numeric_column(spath, name, cols[seen[name]], row_lines) if name in seen else None
        )

    p = sensors[PRESSURE]
    if p is not None:
        bad = np.flatnonzero(~((p > 0.0) & (p <= PRESSURE_MAX_PA)) & ~np.isnan(p))
        if bad.size:
            i = int(bad[0])
            raise FlightCSVError(
                spath, row_lines[i], f"column '{PRESSURE}': {cols[seen[PRESSURE]][i]} Pa is implausible "
                f"(expected 0 < p <= {PRESSURE_MAX_PA:.0f})"
            )
    i = first_implausible_accel(sensors[ACCEL])
    if i is not None:
        raise FlightCSVError(
            spath, row_lines[i],
            f"column '{ACCEL}': {cols[seen[ACCEL]][i]} m/s^2 is implausible ({ACCEL_EXPECTED})",
        )
    if not any(a is not None and np.isfinite(a).any() for a in (p, sensors[ALTITUDE])):
        present = " and ".join(f"'{n}'" for n in (PRESSURE, ALTITUDE) if n in seen)
        raise FlightCSVError(spath, header_lineno, f"column {present} has no readings (every cell is empty)")

    extra = {
        name: _extra_column(spath, name, cols[j], row_lines)
        for j, name in enumerate(columns)
        if name not in _KNOWN
    }

    return FlightLog(
        path=spath,
        metadata=metadata,
        comments=comments,
        columns=columns,
        time_s=time_s,
        time_us=time_us,
        pressure_pa=sensors[PRESSURE],
        altitude_m=sensors[ALTITUDE],
        accel_mps2=sensors[ACCEL],
        extra=extra,
        line_numbers=line_numbers,
        metadata_lines=metadata_lines,
        duplicate_times=duplicates,
    )


def _fold_row(cols, columns, time_col, k, i, row_lines, time_text) -> DuplicateTime:
    """Fold row ``i`` into row ``k`` (same time): an empty cell takes the other row's reading,
    two different readings keep the later (row i's)."""
    differing = []
    identical = True
    for j, col in enumerate(cols):
        if j == time_col or col[i] == col[k] or (
                _NUMBER_RE.match(col[i]) and _NUMBER_RE.match(col[k]) and float(col[i]) == float(col[k])):
            continue
        identical = False
        if col[i] and col[k]:
            differing.append(columns[j])
        if col[i]:
            col[k] = col[i]
    return DuplicateTime(line=row_lines[i], kept_line=row_lines[k], time_s=time_text,
                         identical=identical, differing=tuple(differing))


# --------------------------------------------------------------------------------------------------
# Writer

#: Fixed decimals per known column; other numeric columns use '.6g' (integers written exactly).
_DECIMALS = {PRESSURE: 2, ALTITUDE: 3, "true_altitude_m": 3, ACCEL: 4}


def _format_time(us: int) -> str:
    sign = "-" if us < 0 else ""
    whole, frac = divmod(abs(us), 1000000)
    digits = f"{frac:06d}".rstrip("0")
    if len(digits) < 2:
        digits = digits.ljust(2, "0")
    return f"{sign}{whole}.{digits}"


def _is_missing(x) -> bool:
    if x is None:
        return True
    try:
        return isinstance(x, (float, np.floating)) and math.isnan(x)
    except TypeError:  # pragma: no cover
        return False


def _format_fixed(x: float, decimals: int) -> str:
    s = f"{x:.{decimals}f}"
    if s.startswith("-") and not s.strip("-0."):
        s = s[1:]  # no "-0.00"
    return s


def _format_general(x) -> str:
    if isinstance(x, (int, np.integer)) and not isinstance(x, (bool, np.bool_)):
        return str(int(x))
    xf = float(x)
    if xf.is_integer() and abs(xf) < 2**53:
        return str(int(xf))
    return format(xf, ".6g")


def write_flight_csv(
    path,
    columns: Mapping[str, object],
    metadata: Mapping[str, object] | None = None,
    comments: Sequence[str] = (),
) -> None:
    """Write a flight CSV that read_flight_csv() reads back to the written precision.

    `columns` maps column name to values in header order; `time_s` must be first. Float NaN and
    None become empty cells. Formatting: time_s to the microsecond (at least 2 decimals),
    pressure_pa 2 decimals, altitude_m/true_altitude_m 3, accel_mps2 4, other numbers '.6g'
    (integers exactly), strings as is (no commas, newlines or leading '#').

    Raises ValueError for data the reader would reject (missing/unsorted time, no barometric
    column, ragged columns, bad names or strings).
    """
    names = list(columns)
    if not names or names[0] != TIME:
        raise ValueError(f"write_flight_csv: '{TIME}' must be the first column (got {names[:3]})")
    if PRESSURE not in columns and ALTITUDE not in columns:
        raise ValueError(f"write_flight_csv: need a '{PRESSURE}' or '{ALTITUDE}' column")
    for name in names:
        if not isinstance(name, str) or not name or name != name.strip(_WS) or any(
            ch in name for ch in ",\n\r#"
        ):
            raise ValueError(f"write_flight_csv: bad column name {name!r}")

    values = {}
    n = None
    for name in names:
        v = columns[name]
        arr = np.asarray(v) if not isinstance(v, np.ndarray) else v
        if arr.ndim != 1:
            raise ValueError(f"write_flight_csv: column '{name}' must be one-dimensional")
        if n is None:
            n = len(arr)
        elif len(arr) != n:
            raise ValueError(f"write_flight_csv: column '{name}' has {len(arr)} values, '{TIME}' has {n}")
        values[name] = arr
    if not n:
        raise ValueError("write_flight_csv: no rows to write")

    # Time to integer microseconds; strictly increasing after rounding.
    t = np.asarray(values[TIME], dtype=np.float64)
    if not np.isfinite(t).all():
        raise ValueError(f"write_flight_csv: '{TIME}' has a missing or non-finite value")
    time_us = [round(float(x) * 1e6) for x in t]
    for i in range(1, n):
        if time_us[i] <= time_us[i - 1]:
            raise ValueError(
                f"write_flight_csv: '{TIME}' not strictly increasing at row {i} "
                f"({_format_time(time_us[i - 1])} then {_format_time(time_us[i])} after rounding to 1 us)"
            )

    # Format every column to a list of cell strings.
    formatted: list[list[str]] = [[_format_time(us) for us in time_us]]
    for name in names[1:]:
        arr = values[name]
        cells: list[str] = []
        decimals = _DECIMALS.get(name)
        if arr.dtype.kind == "f" and np.isinf(arr).any():
            raise ValueError(f"write_flight_csv: column '{name}' has an infinite value")
        if name == PRESSURE and arr.dtype.kind in "fiu":
            p = arr.astype(np.float64)
            if ((p <= 0) | (p > PRESSURE_MAX_PA)).any():
                raise ValueError(
                    f"write_flight_csv: '{PRESSURE}' outside 0 < p <= {PRESSURE_MAX_PA:.0f} Pa"
                )
        if name == ACCEL and arr.dtype.kind in "fiu" and first_implausible_accel(arr) is not None:
            raise ValueError(f"write_flight_csv: '{ACCEL}' beyond +-{ACCEL_MAX_MPS2:.0f} m/s^2")
        if arr.dtype.kind == "f":
            if decimals is None:
                cells = ["" if math.isnan(x) else _format_general(x) for x in arr.tolist()]
            else:
                cells = ["" if math.isnan(x) else _format_fixed(x, decimals) for x in arr.tolist()]
        elif arr.dtype.kind in "iu":
            cells = [
                _format_fixed(x, decimals) if decimals is not None else str(x) for x in arr.tolist()
            ]
        else:
            for x in arr.tolist():
                if _is_missing(x):
                    cells.append("")
                elif isinstance(x, (str, bytes)):
                    s = x.decode("utf-8") if isinstance(x, bytes) else x
                    if any(ch in s for ch in ",\n\r") or s != s.strip(_WS) or s.startswith("#"):
                        raise ValueError(
                            f"write_flight_csv: column '{name}': string {s!r} has a comma, newline, "
                            "surrounding whitespace or leading '#'"
                        )
                    cells.append(s)
                elif isinstance(x, (bool, np.bool_)):
                    cells.append(str(int(x)))
                elif isinstance(x, (int, float, np.integer, np.floating)):
                    if not math.isfinite(float(x)):
                        raise ValueError(f"write_flight_csv: column '{name}': {x!r} is not finite")
                    cells.append(_format_fixed(float(x), decimals) if decimals is not None
                                 else _format_general(x))
                else:
                    raise ValueError(f"write_flight_csv: column '{name}': cannot write {x!r}")
        formatted.append(cells)

    out: list[str] = []
    for c in comments:
        c = str(c)
        if "\n" in c or "\r" in c:
            raise ValueError(f"write_flight_csv: comment {c!r} has a newline")
        if _META_RE.match(c.strip()):
            raise ValueError(
                f"write_flight_csv: comment {c!r} would read back as metadata; pass it in `metadata`"
            )
        out.append(f"# {c}".rstrip())
    for key, value in (metadata or {}).items():
        if not isinstance(key, str) or not _WRITE_KEY_RE.match(key):
            raise ValueError(f"write_flight_csv: bad metadata key {key!r} (lowercase identifier)")
        if isinstance(value, (float, np.floating)):
            s = repr(float(value))
        elif isinstance(value, np.integer):
            s = str(int(value))
        else:
            s = str(value)
        if "\n" in s or "\r" in s:
            raise ValueError(f"write_flight_csv: metadata '{key}' has a newline")
        out.append(f"# {key}: {s}".rstrip())
    out.append(",".join(names))
    out.extend(",".join(row) for row in zip(*formatted, strict=True))
    Path(path).write_text("\n".join(out) + "\n", encoding="utf-8", newline="\n")
