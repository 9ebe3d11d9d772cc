"""Output of the seed paper's study (``python -m desktop montecarlo``): its text table and one
flight of the study written as a flight CSV. The figures: desktop/study/seed_plots.py."""

from __future__ import annotations

from desktop.sim import seed_model as sm
from desktop.study.metrics import table_lines
from desktop.study.seed_study import StudyResult, simulate_flights


def format_table(result: StudyResult) -> str:
    """The study's table: a title line with its parameters, one row per method."""
    p = result.parameters
    title = (f"{p['flights']} flights, seed {p['seed']}, params {p['params']}, pad {p['pad_s']:g} s, "
             f"flight {p['t_length_s']:g} s; error = detection - true apogee (s)")
    return "\n".join(table_lines(title, result.table))


def export_csv(path, mode: str, seed: int, flight_index: int, pad_s: float) -> sm.FlightBatch:
    """Write flight ``flight_index`` of the study (same seed, mode and pad) as a flight CSV."""
    from desktop.io.flightcsv import write_flight_csv

    batch = simulate_flights(mode, seed, [flight_index], pad_s)
    columns, meta = sm.flight_csv_columns(batch, 0)
    meta["params"] = mode
    comments = (
        "Simulated with the seed paper study's flight model (desktop/sim/seed_model.py), "
        "python -m desktop montecarlo",
        "accel_mps2 is specific force: the floor-quantised kinematic acceleration + 9.81",
    )
    write_flight_csv(path, columns, meta, comments)
    return batch

