"""Text output of a rocket Monte-Carlo: the table, its markdown form (docs/BENCHMARKS.md), the flight
computer's summary, the pool's speed, and one flight's board record as a flight CSV."""

from __future__ import annotations

from desktop.study.metrics import METRIC_KEYS, format_cell, table_lines
from desktop.study.rocket_flight import StudySettings, simulate_flight
from desktop.study.rocket_results import RocketStudyResult

_MD_HEADERS = ("mean \\|err\\| s", "mean err s", "median \\|err\\| s", "p95 \\|err\\| s", "max \\|err\\| s",
               "mean \\|v\\| m/s", ">1 s early", "none")


def summary_lines(result: RocketStudyResult) -> list[str]:
    s = result.fc_summary
    n = s["n_flights"]
    main = (f"main deployments {s['n_main']}/{n}, truth altitude at the main event - "
            f"{s['main_deploy_m']:g} m: mean {s['main_altitude_error_mean_m']:+.1f} m, mean |err| "
            f"{s['main_altitude_error_mean_abs_m']:.1f} m, max |err| "
            f"{s['main_altitude_error_max_abs_m']:.1f} m" if s["n_main"] else f"main deployments 0/{n}")
    if not s["main_deploy_m"]:
        main += " (no main planned)"
    return [
        f"flight-computer: fired before burnout {s['n_fired_before_burnout']}/{n}; pyro event before "
        f"launch {s['n_pyro_before_launch']}/{n}; {main}; accelerometer clipped on "
        f"{s['n_accel_clipped']}/{n}",
    ]


def format_table(result: RocketStudyResult) -> str:
    p = result.parameters()
    title = (f"{p['name']} ({p['rocket']}): {p['flights']} flights, seed {p['seed']}, "
             f"{p['sensor_profile']} at {p['rate_hz']:g} Hz, pad {p['pad_s']:g} s; "
             "error = detection - true apogee (s)")
    lines = table_lines(title, result.table) + summary_lines(result)
    return "\n".join(lines)


def format_markdown(result: RocketStudyResult) -> str:
    lines = ["| method | " + " | ".join(_MD_HEADERS) + " |", "|---" * (len(_MD_HEADERS) + 1) + "|"]
    for name, m in result.table.items():
        shown = f"**{name}**" if name == "flight-computer" else name
        lines.append(f"| {shown} | " + " | ".join(format_cell(k, m[k]) for k in METRIC_KEYS) + " |")
    return "\n".join(lines)


def speed_line(result: RocketStudyResult) -> str:
    s = result.speed
    pf = s["per_flight_s"]
    return (f"{len(result.flights)} flights on {s['workers']} process(es): {s['wall_s']:.1f} s wall, "
            f"{s['flights_per_minute']:.0f} flights/minute after {s['startup_s']:.1f} s start-up "
            f"({s['flights_per_minute_with_startup']:.0f} including it); per flight: simulation "
            f"{pf['simulate']:.2f} s, replay {pf['replay']:.2f} s, comparison methods "
            f"{pf['comparison']:.2f} s")


def export_flight_csv(settings: StudySettings, index: int, path) -> dict:
    """Write the board record of flight ``index`` (drawn parameters in the metadata)."""
    from desktop.sim.sensor_models import write_record

    draw, traj, record = simulate_flight(settings, index)
    write_record(path, record)
    return {"draw": draw.as_dict(), "true_apogee_s": traj.apogee_time_s, "true_apogee_m": traj.apogee_m}
