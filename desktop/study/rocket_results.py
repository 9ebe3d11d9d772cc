"""The results of a rocket Monte-Carlo: each method's timing metrics over the flights, the flight
computer's deployment summary, the study's parameters, and the JSON form of it all."""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from desktop.study import baselines
from desktop.study.metrics import metrics
from desktop.study.rocket_comparison import BOXCAR_SECONDS
from desktop.study.rocket_flight import METHODS, StudySettings


class RocketStudyResult:
    """Per-flight results (in flight order), the table of each method and the flight computer's
    summary; ``speed``: the pool's timings."""

    def __init__(self, settings: StudySettings, flights: list, speed: dict, name: str):
        self.settings = settings
        self.flights = flights
        self.speed = speed
        self.name = name
        apo = np.array([f["true_apogee_s"] for f in flights])
        self.table = {}
        for m in METHODS:
            d = np.array([f["detections"][m] for f in flights], dtype=np.float64)
            v = np.array([f["true_velocity_at_detection"][m] for f in flights], dtype=np.float64)
            self.table[m] = metrics(d, apo, v)
        self.fc_summary = flight_computer_summary(flights, settings.main_deploy_m)

    def errors(self, method: str) -> np.ndarray:
        return np.array([f["detections"][method] - f["true_apogee_s"] for f in self.flights])

    def parameters(self) -> dict:
        s = self.settings
        return {
            "rocket": s.rocket, "name": self.name, "flights": len(self.flights), "seed": s.seed,
            "sensor_profile": s.profile, "rate_hz": s.rate_hz, "pad_s": s.pad_s,
            "main_deploy_m": s.main_deploy_m, "dispersions": dataclasses.asdict(s.dispersions),
            "record_ends_after_main_crossing_s": s.after_main_s,
            "comparison": {
                "boxcar_seconds": BOXCAR_SECONDS,
                "butterworth": {"order": baselines.BUTTER_ORDER, "cutoff_hz": baselines.BUTTER_CUTOFF_HZ},
                "lockout_s_after_launch": baselines.LOCKOUT_S,
                "launch_threshold_mps2": baselines.LAUNCH_THRESHOLD_MPS2,
            },
        }

    def to_json(self, per_flight: bool = True) -> dict:
        out = {
            "seed": self.settings.seed,
            "parameters": self.parameters(),
            "methods": json_ready(self.table),
            "flight_computer": json_ready(self.fc_summary),
            "speed": json_ready(self.speed),
        }
        if per_flight:
            out["flights"] = json_ready(self.flights)
        return out


def json_ready(x):
    """``x`` with numpy numbers as Python's, NaN and infinities as None, ``_``-keys left out."""
    if isinstance(x, dict):
        return {k: json_ready(v) for k, v in x.items() if not k.startswith("_")}
    if isinstance(x, (list, tuple)):
        return [json_ready(v) for v in x]
    if isinstance(x, (float, np.floating)):
        return None if not math.isfinite(float(x)) else float(x)
    if isinstance(x, np.integer):
        return int(x)
    return x


def flight_computer_summary(flights: list, main_deploy_m: float) -> dict:
    """The flight computer's extra rows: firings before burnout, main deployments and their
    altitude error (truth at the main event - the configured altitude), pyro events before launch."""
    fc = [f["flight_computer"] for f in flights]
    main_alt = np.array([x["true_altitude_at_main_m"] for x in fc], dtype=np.float64)
    ok = np.isfinite(main_alt)
    err = main_alt[ok] - main_deploy_m
    nan = math.nan
    return {
        "n_flights": len(flights),
        "n_fired_before_burnout": int(sum(x["fired_before_burnout"] for x in fc)),
        "n_pyro_before_launch": int(sum(x["pyro_before_launch"] for x in fc)),
        "n_main": int(ok.sum()),
        "main_deploy_m": float(main_deploy_m),  # 0: no main
        "main_altitude_error_mean_m": float(np.mean(err)) if err.size else nan,
        "main_altitude_error_mean_abs_m": float(np.mean(np.abs(err))) if err.size else nan,
        "main_altitude_error_max_abs_m": float(np.max(np.abs(err))) if err.size else nan,
        "n_accel_clipped": int(sum(x["accel_clipped"] for x in fc)),
    }
