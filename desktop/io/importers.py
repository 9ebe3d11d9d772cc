"""Other loggers' exports as flight CSVs: format detection, ``read_flight`` and ``python -m desktop import``.

Formats (docs/IMPORT.md): ``flight-csv`` (the project's own, docs/FLIGHT_CSV.md) and ``altos``
(AltosUI CSV exports of Altus Metrum boards, ``desktop/io/altos_csv.py``). An importer returns the
flight-CSV columns, metadata and comments; ``read_flight`` writes them through the flight-CSV
writer and reads them back with its reader, so an imported flight passes the same validation as
a file written by ``import``.
"""

import tempfile
from pathlib import Path

from desktop.errors import InputFileError
from desktop.io import altos_csv
from desktop.io.files import check_output_file, read_bytes
from desktop.io.flightcsv import FlightCSVError, read_flight_csv, write_flight_csv

FORMATS = ("flight-csv", "altos")
_SNIFF_LINES = 200


def _first_lines(path):
    # leniently decoded: only to recognise a signature; the format's reader checks the text
    return read_bytes(path, "flight file").decode("utf-8-sig", errors="replace").splitlines()[:_SNIFF_LINES]


def detect_format(path):
    """The format of the file at ``path`` (one of FORMATS): an export whose signature is found in
    its first lines, else ``flight-csv`` (whose reader then names any problem precisely)."""
    if any(altos_csv.is_header(line) for line in _first_lines(path)):
        return "altos"
    return "flight-csv"


def convert(path, fmt=None):
    """(columns, metadata, comments) of an export in format ``fmt`` (detected when None)."""
    fmt = fmt or detect_format(path)
    if fmt == "altos":
        return altos_csv.read_altos_csv(path)
    raise ValueError(f"convert: no importer for format {fmt!r}")


def read_flight(path, fmt=None):
    """A FlightLog from a flight CSV or any importable export (format detected when ``fmt`` is None)."""
    fmt = fmt or detect_format(path)
    if fmt == "flight-csv":
        return read_flight_csv(path)
    columns, metadata, comments = convert(path, fmt)
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp) / "imported.csv"
        write_flight_csv(out, columns, metadata=metadata, comments=comments)
        log = read_flight_csv(out)
    log.path = str(path)
    return log


def register(subparsers):
    p = subparsers.add_parser(
        "import", help="convert another logger's export (AltosUI CSV, ...) into a flight CSV",
        description="Convert a flight exported by another flight computer's software into the "
                    "project's flight CSV (docs/FLIGHT_CSV.md): sensor readings in SI units, the "
                    "board's own states and igniter voltages as extra columns. Formats: "
                    "docs/IMPORT.md.")
    p.add_argument("file", help="the export to convert")
    p.add_argument("-o", "--out", required=True, metavar="FLIGHT.csv", help="flight CSV to write")
    p.add_argument("--format", choices=[f for f in FORMATS if f != "flight-csv"],
                   help="the export's format (default: detected)")
    p.set_defaults(func=run)


def run(args):
    check_output_file(args.out, "flight CSV")
    fmt = args.format or detect_format(args.file)
    if fmt == "flight-csv":
        try:
            read_flight_csv(args.file)
        except (FlightCSVError, InputFileError) as exc:
            raise FlightCSVError(args.file, None, "unknown format: not an export docs/IMPORT.md lists, "
                                 f"nor a flight CSV ({exc.problem})") from None
        raise FlightCSVError(args.file, None, "already a flight CSV; nothing to import")
    columns, metadata, comments = convert(args.file, fmt)
    write_flight_csv(args.out, columns, metadata=metadata, comments=comments)
    log = read_flight_csv(args.out)
    states = log.extra.get("altos_state")
    seen = []
    if states is not None:
        for s in states:
            if not seen or seen[-1] != s:
                seen.append(s)
    print(f"{args.file}: {fmt}, board {log.metadata.get('board', '?')}: {len(log)} samples from "
          f"{log.time_s[0]:.2f} s to {log.time_s[-1]:.2f} s written to {args.out}")
    if seen:
        print("  board states: " + " -> ".join(seen))
    print(f"  replay: python -m desktop replay {args.out} --report out/")
    return 0
