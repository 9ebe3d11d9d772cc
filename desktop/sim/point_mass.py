"""A rocket as a point mass in the vertical plane: thrust, drag, a launch rail and wind.

The flight model of the random-rocket benchmark (tools/bench_family.py): simple enough to draw
thousands of rockets nobody tuned the flight computer to, from a C-class model rocket to a 40 kg
Mach 2.5 flight, physical enough that the sensors read what a board would:

- constant thrust for ``burn_s`` along the body axis, constant mass;
- on the rail (its length 3 m, 6 m from 1 kg) the body axis is the rail's, tilted ``rail_deg``
  from the vertical; off it the body axis follows the air-relative velocity (a stable rocket
  weathercocks into the wind, ``wind_mps`` horizontal and constant);
- drag 0.5 rho V^2 CdA against the air-relative velocity, CdA rising by half from Mach 0.9 to 1.2
  (the transonic drag rise), in the ISA troposphere above a site at ``site_m``;
- the accelerometer's axial specific force is (thrust - drag) / mass, as a body-fixed part reads.

Integrated (semi-implicit Euler) at ``dt_s`` until ``after_apogee_s`` past apogee.
"""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np

from desktop.sim.trajectory import G0, Trajectory, drag_free_vertical, isa_pressure

_RAIL_SHORT_M = 3.0
_RAIL_LONG_M = 6.0
_RAIL_LONG_FROM_KG = 1.0
_T0_K = 288.15
_LAPSE_KPM = 0.0065
_R_AIR = 287.05287
_GAMMA = 1.4
_P0_PA = 101325.0
_ISA_EXPONENT = 5.25588


def point_mass_flight(thrust_n: float, burn_s: float, mass_kg: float, cda_m2: float,
                      rail_deg: float = 0.0, wind_mps: float = 0.0, site_m: float = 0.0,
                      dt_s: float = 0.001, after_apogee_s: float = 6.0) -> Trajectory:
    """The flight of the module docstring. Raises ValueError when the thrust cannot lift the
    rocket off the rail."""
    if thrust_n <= mass_kg * G0 * math.cos(math.radians(rail_deg)):
        raise ValueError("thrust must exceed the weight along the rail")
    rail_m = _RAIL_LONG_M if mass_kg >= _RAIL_LONG_FROM_KG else _RAIL_SHORT_M
    ux, uz = math.sin(math.radians(rail_deg)), math.cos(math.radians(rail_deg))
    t = x = z = vx = vz = 0.0
    ts, zs, vzs, fs, machs = [0.0], [0.0], [0.0], [thrust_n / mass_kg], [0.0]
    apogee_s = apogee_m = None
    while apogee_s is None or t < apogee_s + after_apogee_s:
        temp_k = _T0_K - _LAPSE_KPM * (site_m + z)
        rho = _P0_PA * (temp_k / _T0_K) ** _ISA_EXPONENT / (_R_AIR * temp_k)
        air_x, air_z = vx - wind_mps, vz
        speed = math.hypot(air_x, air_z)
        mach = speed / math.sqrt(_GAMMA * _R_AIR * temp_k)
        thrust = thrust_n if t < burn_s else 0.0
        on_rail = thrust > 0.0 and x * ux + z * uz < rail_m
        if not on_rail and speed > 1.0:
            ux, uz = air_x / speed, air_z / speed
        cda = cda_m2 * (1.0 + 0.5 * min(max((mach - 0.9) / 0.3, 0.0), 1.0))
        drag = 0.5 * rho * speed * speed * cda
        specific = (thrust - drag) / mass_kg
        if on_rail:  # the rail carries the weight across it: motion along the rail only
            along = max(specific - G0 * uz, 0.0)
            vx += along * ux * dt_s
            vz += along * uz * dt_s
        else:
            drag_x = -drag / mass_kg * air_x / speed if speed > 0.0 else 0.0
            drag_z = -drag / mass_kg * air_z / speed if speed > 0.0 else 0.0
            vx += (thrust / mass_kg * ux + drag_x) * dt_s
            vz += (thrust / mass_kg * uz + drag_z - G0) * dt_s
        x += vx * dt_s
        z += vz * dt_s
        t += dt_s
        if apogee_s is None and t > burn_s and vz < 0.0:
            apogee_s, apogee_m = t, z
        ts.append(t)
        zs.append(z)
        vzs.append(vz)
        fs.append(specific)
        machs.append(mach)
        if z < 0.0:
            break
    if apogee_s is None:
        raise ValueError("the flight ends before its apogee")
    z_m = np.array(zs)
    return replace(drag_free_vertical(site_altitude_m=site_m), time_s=np.array(ts), altitude_m=z_m,
                   velocity_mps=np.array(vzs), accel_mps2=np.array(fs),
                   pressure_pa=np.asarray(isa_pressure(site_m + z_m)), mach=np.array(machs),
                   apogee_time_s=apogee_s, apogee_m=apogee_m, burnout_time_s=burn_s,
                   thrust_n=None, mass_kg=None, rocket="point mass", source="desktop.sim.point_mass")
