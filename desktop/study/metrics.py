"""Apogee-timing metrics of a study and their text table (the seed-paper and rocket studies alike)."""

from __future__ import annotations

import math

import numpy as np

METRIC_KEYS = (
    "mean_abs_error_s", "mean_error_s", "median_abs_error_s", "p95_abs_error_s", "max_abs_error_s",
    "mean_abs_velocity_mps", "n_early_1s", "n_no_detection",
)
_HEADERS = ("mean|err| s", "mean err s", "median|err| s", "p95|err| s", "max|err| s",
            "mean|v| m/s", "early>1s", "none")



def metrics(detection_s, true_apogee_s, true_velocity_mps) -> dict:
    """The table's row for one method (NaN detections count as "none" and are left out of the
    error statistics)."""
    det = np.asarray(detection_s, dtype=np.float64)
    err = det - np.asarray(true_apogee_s, dtype=np.float64)
    ok = ~np.isnan(det)
    e = err[ok]
    v = np.abs(np.asarray(true_velocity_mps, dtype=np.float64)[ok])
    nan = float("nan")
    return {
        "mean_abs_error_s": float(np.mean(np.abs(e))) if e.size else nan,
        "mean_error_s": float(np.mean(e)) if e.size else nan,
        "median_abs_error_s": float(np.median(np.abs(e))) if e.size else nan,
        "p95_abs_error_s": float(np.percentile(np.abs(e), 95)) if e.size else nan,
        "max_abs_error_s": float(np.max(np.abs(e))) if e.size else nan,
        "mean_abs_velocity_mps": float(np.mean(v)) if v.size else nan,
        "n_early_1s": int(np.sum(e < -1.0)),
        "n_no_detection": int(np.sum(~ok)),
    }


def format_cell(key: str, v) -> str:
    """One table cell: counts as integers, the signed mean with a sign, "-" for no value."""
    if key.startswith("n_"):
        return f"{v:d}"
    if v is None or not math.isfinite(v):
        return "-"
    if key == "mean_error_s":
        return f"{v:+.3f}"
    if key == "mean_abs_velocity_mps":
        return f"{v:.2f}"
    return f"{v:.3f}"


def table_lines(title: str, table: dict) -> list[str]:
    """The text table: a title line, the header, one row per method (shared with the rocket study)."""
    name_w = max(len("method"), *(len(n) for n in table))
    lines = [title, "  ".join([f"{'method':<{name_w}}"] + [f"{h:>13}" for h in _HEADERS])]
    for name, m in table.items():
        lines.append("  ".join([f"{name:<{name_w}}"] + [f"{format_cell(k, m[k]):>13}" for k in METRIC_KEYS]))
    return lines
