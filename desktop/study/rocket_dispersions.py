"""The dispersions of a rocket Monte-Carlo: what each flight draws and the dispersed rocket it flies.

Flight i of study seed S draws, from ``numpy.random.default_rng([S, i])`` in a fixed order, the
motor's total impulse and burn time, drag, dry mass, wind, rail inclination and heading, and the
seed of its sensor record: flight i depends only on (S, i). docs/SIMULATION.md explains each range.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class Dispersions:
    """Half-widths of the uniform draws (docs/SIMULATION.md explains each range)."""

    impulse: float = 0.03  # total impulse, fraction
    burn_time: float = 0.03  # burn time, fraction (thrust scaled so the impulse is as drawn)
    cd: float = 0.10  # drag coefficient (every point of the table), fraction
    dry_mass: float = 0.03  # dry mass and inertia, fraction
    max_wind_mps: float = 9.0  # wind speed uniform in 0..max, direction uniform
    inclination_deg: float = 2.0  # rail inclination: nominal +- this (at most 90), heading uniform


DEFAULT_DISPERSIONS = Dispersions()
MAX_WIND_LIMIT_MPS = 30.0  # --max-wind-mps above this is outside what a launch would fly in


@dataclass(frozen=True)
class FlightDraw:
    """The draws of one flight: scale factors of the nominal rocket, wind, rail, record seed."""

    index: int
    impulse_scale: float
    burn_time_scale: float
    cd_scale: float
    dry_mass_scale: float
    wind_speed_mps: float
    wind_from_deg: float
    inclination_deg: float
    heading_deg: float
    record_seed: int

    def as_dict(self) -> dict:
        return dataclasses.asdict(self)


def draw_flight(spec, seed: int, index: int, disp: Dispersions = DEFAULT_DISPERSIONS) -> FlightDraw:
    """The dispersions of flight ``index``: ``default_rng([seed, index])``, always the same draws in
    the same order."""
    rng = np.random.default_rng([int(seed), int(index)])
    u = rng.random(8)
    incl = spec.inclination_deg + (2.0 * u[6] - 1.0) * disp.inclination_deg
    u = [float(x) for x in u]
    return FlightDraw(
        index=int(index),
        impulse_scale=1.0 + (2.0 * u[0] - 1.0) * disp.impulse,
        burn_time_scale=1.0 + (2.0 * u[1] - 1.0) * disp.burn_time,
        cd_scale=1.0 + (2.0 * u[2] - 1.0) * disp.cd,
        dry_mass_scale=1.0 + (2.0 * u[3] - 1.0) * disp.dry_mass,
        wind_speed_mps=u[4] * disp.max_wind_mps,
        wind_from_deg=u[5] * 360.0,
        inclination_deg=min(90.0, float(incl)),
        heading_deg=u[7] * 360.0,
        record_seed=int(rng.integers(0, 2**63 - 1)),
    )


def apply_draw(spec, draw: FlightDraw, main_deploy_m: float | None = None):
    """The dispersed rocket. The thrust curve's times are scaled by the burn-time factor and its
    thrust by impulse/burn-time (propellant mass unchanged); the main parachute, if any, opens where
    the flight computer is configured to fire it (``main_deploy_m``; 0: never, no main)."""
    eng = spec.motor
    b, i = draw.burn_time_scale, draw.impulse_scale
    motor = dataclasses.replace(eng, time_s=tuple(t * b for t in eng.time_s),
                                thrust_n=tuple(f * i / b for f in eng.thrust_n))
    changes = dict(
        motor=motor,
        dry_mass_kg=spec.dry_mass_kg * draw.dry_mass_scale,
        inertia_lateral_kgm2=spec.inertia_lateral_kgm2 * draw.dry_mass_scale,
        inertia_roll_kgm2=spec.inertia_roll_kgm2 * draw.dry_mass_scale,
        wind_speed_mps=draw.wind_speed_mps,
        wind_from_deg=draw.wind_from_deg,
        inclination_deg=draw.inclination_deg,
        heading_deg=draw.heading_deg,
    )
    if spec.cd_table is None:
        changes["cd"] = spec.cd * draw.cd_scale
    else:
        changes["cd_table"] = tuple((m, c * draw.cd_scale) for m, c in spec.cd_table)
    if spec.main is not None and main_deploy_m is not None:
        changes["main"] = (dataclasses.replace(spec.main, deploy_altitude_m=float(main_deploy_m))
                           if main_deploy_m else None)
    return spec.replace(**changes)
