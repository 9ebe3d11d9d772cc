"""Truth trajectories: RocketPy flights from a rocket TOML, and an analytic drag-free flight.

A `Trajectory` holds numpy arrays on a uniform fine time grid (1 ms by default), time 0 at ignition
(RocketPy) or launch (OpenRocket): altitude above the site, vertical velocity, the specific force
along the rocket's long axis, static pressure and Mach number, plus the flight's events. The sensor
models (desktop/sim/sensor_models.py) turn it into what a board would record.

Specific force along the body axis (`accel_mps2`), the quantity an axial accelerometer measures:
    f = (a_inertial + g z_hat) . b_hat
with b_hat the body axis (nose direction) from RocketPy's attitude quaternion. At rest on the rail it
is g sin(inclination) (+9.78 at 85 deg), it is about +T/m during the burn, and about -D/m (negative)
in coast. Under a parachute RocketPy integrates no attitude; the body axis is then taken as vertical
(nose up), so a steady descent reads +g. Between RocketPy's integrator steps the thrust part T(t)/m(t)
is evaluated exactly on the fine grid (the thrust curve's corners stay sharp) and the remainder
(aerodynamic force / mass) is interpolated linearly, per flight phase (deployments stay sharp).

Static pressure is the ISO 2533 standard atmosphere at the rocket's geopotential height, evaluated
exactly here: RocketPy's own `Environment.pressure` is a spline through a coarse table (21 Pa, 1.8 m,
high at 100 m), which would put a fake bias between true altitude and true pressure.

RocketPy is imported lazily (it costs ~1.2 s), so the OpenRocket importer and the sensor models
work without it.
"""

from __future__ import annotations

import math
import time
import warnings
from dataclasses import dataclass, field, replace

import numpy as np

from desktop.errors import DesktopError
from desktop.io.rocket_file import EngMotor, RocketSpec
from shared.physics import G0_MPS2 as G0

__all__ = [
    "G0",
    "Trajectory",
    "simulate_rocket",
    "drag_free_vertical",
    "isa_pressure",
    "isa_temperature",
    "isa_speed_of_sound",
    "isa_altitude",
    "motor_grain_geometry",
    "TrajectoryError",
]

R_AIR = 287.05287  # J/(kg K), ISO 2533
GAMMA = 1.4
EARTH_RADIUS_M = 6356766.0  # ISO 2533 radius for geopotential height

# ISO 2533 layers up to 32 km: base geopotential height (m), base temperature (K), lapse (K/m),
# base pressure (Pa).
_LAYERS = ((0.0, 288.15, -0.0065, 101325.0), (11000.0, 216.65, 0.0, 22632.0431), (20000.0, 216.65, 0.001,
                                                                                     5474.8786))


class TrajectoryError(DesktopError):
    """A rocket that RocketPy cannot fly sensibly (unstable, does not leave the rail, ...)."""


def _geopotential(h_m):
    return EARTH_RADIUS_M * h_m / (EARTH_RADIUS_M + h_m)


def isa_temperature(h_msl_m):
    """ISO 2533 temperature (K) at geometric altitude above mean sea level (m), up to 32 km."""
    h = _geopotential(np.asarray(h_msl_m, dtype=float))
    out = np.empty_like(h)
    for i, (hb, tb, lapse, _pb) in enumerate(_LAYERS):
        hi = _LAYERS[i + 1][0] if i + 1 < len(_LAYERS) else np.inf
        m = (h < hi) if i == 0 else ((h >= hb) & (h < hi))
        out[m] = tb + lapse * (h[m] - hb)
    return out if out.ndim else float(out)


def isa_pressure(h_msl_m):
    """ISO 2533 static pressure (Pa) at geometric altitude above mean sea level (m), up to 32 km."""
    h = _geopotential(np.asarray(h_msl_m, dtype=float))
    out = np.empty_like(h)
    for i, (hb, tb, lapse, pb) in enumerate(_LAYERS):
        hi = _LAYERS[i + 1][0] if i + 1 < len(_LAYERS) else np.inf
        m = (h < hi) if i == 0 else ((h >= hb) & (h < hi))
        dh = h[m] - hb
        if lapse == 0.0:
            out[m] = pb * np.exp(-G0 * dh / (R_AIR * tb))
        else:
            out[m] = pb * (1.0 + lapse * dh / tb) ** (-G0 / (R_AIR * lapse))
    return out if out.ndim else float(out)


def isa_altitude(p_pa):
    """Inverse of isa_pressure: geometric altitude MSL (m) of a static pressure (Pa), troposphere and
    lower stratosphere (above 5.5 kPa)."""
    p = np.asarray(p_pa, dtype=float)
    t0, lapse = _LAYERS[0][1], _LAYERS[0][2]
    h = (t0 / -lapse) * (1.0 - (p / 101325.0) ** (R_AIR * -lapse / G0))
    strat = p < _LAYERS[1][3]
    if np.any(strat):
        h = np.where(strat, 11000.0 + R_AIR * 216.65 / G0 * np.log(_LAYERS[1][3] / p), h)
    geometric = EARTH_RADIUS_M * h / (EARTH_RADIUS_M - h)
    return geometric if geometric.ndim else float(geometric)


def isa_speed_of_sound(h_msl_m):
    return np.sqrt(GAMMA * R_AIR * isa_temperature(h_msl_m))


# --------------------------------------------------------------------------------------------------


@dataclass
class Trajectory:
    """A truth trajectory on a uniform time grid. Time 0 is ignition/launch; altitudes are AGL."""

    time_s: np.ndarray
    altitude_m: np.ndarray
    velocity_mps: np.ndarray  # vertical
    accel_mps2: np.ndarray  # specific force along the body axis, + towards the nose
    pressure_pa: np.ndarray  # static pressure at the rocket
    mach: np.ndarray
    site_altitude_m: float
    ground_pressure_pa: float
    pad_accel_mps2: float  # specific force along the axis at rest on the pad (g sin(inclination))
    apogee_time_s: float
    apogee_m: float
    burnout_time_s: float | None = None
    # Deployment (opening) times: the first recovery device and the main. RocketPy: the trigger (an
    # ideal altimeter's decision, events "*_trigger") + the parachute's lag; OpenRocket: its
    # RECOVERY_DEVICE_DEPLOYMENT events.
    drogue_time_s: float | None = None
    main_time_s: float | None = None
    events: dict[str, float] = field(default_factory=dict)  # all events by name (s)
    rocket: str = ""
    source: str = ""
    derived_columns: tuple[str, ...] = ()
    thrust_n: np.ndarray | None = None
    mass_kg: np.ndarray | None = None

    @property
    def dt_s(self) -> float:
        return float(self.time_s[1] - self.time_s[0])

    @property
    def end_time_s(self) -> float:
        return float(self.time_s[-1])

    @property
    def max_mach(self) -> float:
        return float(np.max(self.mach))

    @property
    def max_velocity_mps(self) -> float:
        return float(np.max(self.velocity_mps))

    @property
    def dynamic_pressure_pa(self) -> np.ndarray:
        """q = rho v^2 / 2 = gamma p M^2 / 2 (ideal gas)."""
        return 0.5 * GAMMA * self.pressure_pa * self.mach**2

    def truncated(self, end_time_s: float) -> Trajectory:
        """A copy ending at end_time_s (for 'a few seconds after main deploy')."""
        n = int(np.searchsorted(self.time_s, end_time_s, side="right"))
        n = max(n, 2)
        arrays = {
            name: getattr(self, name)[:n]
            for name in ("time_s", "altitude_m", "velocity_mps", "accel_mps2", "pressure_pa", "mach")
        }
        for name in ("thrust_n", "mass_kg"):
            a = getattr(self, name)
            arrays[name] = None if a is None else a[:n]
        return replace(self, **arrays)

    def ended_after_main(self, main_deploy_m: float, after_s: float) -> Trajectory:
        """A copy ending ``after_s`` after the descent first reaches ``main_deploy_m`` (m above the
        pad); unchanged with no main (0) or if the descent never gets that low. The rest of the
        descent costs replay time and decides nothing."""
        after = self.time_s > self.apogee_time_s
        below = np.flatnonzero(after & (self.altitude_m <= main_deploy_m))
        if not (below.size and main_deploy_m):
            return self
        return self.truncated(float(self.time_s[below[0]]) + after_s)

    def summary(self) -> str:
        parts = [f"apogee {self.apogee_m:.1f} m AGL at {self.apogee_time_s:.2f} s",
                 f"max Mach {self.max_mach:.2f}", f"max speed up {self.max_velocity_mps:.1f} m/s",
                 f"max specific force {np.max(self.accel_mps2) / G0:.1f} g"]
        if self.burnout_time_s is not None:
            parts.append(f"burnout {self.burnout_time_s:.2f} s")
        if self.drogue_time_s is not None:
            parts.append(f"drogue {self.drogue_time_s:.2f} s")
        if self.main_time_s is not None:
            parts.append(f"main {self.main_time_s:.2f} s")
        return ", ".join(parts)


# --------------------------------------------------------------------------------------------------
# Analytic drag-free vertical flight (for tests)


def drag_free_vertical(
    thrust_n: float = 200.0,
    burn_time_s: float = 2.0,
    dry_mass_kg: float = 2.0,
    propellant_kg: float = 0.0,
    site_altitude_m: float = 0.0,
    dt_s: float = 0.001,
    end_time_s: float | None = None,
    g: float = G0,
) -> Trajectory:
    """Vertical flight with constant thrust, no drag: the closed-form solution.

    Mass falls linearly from dry + propellant to dry during the burn (exhaust speed
    ve = thrust * burn / propellant), so v = ve ln(m0/m) - g t and z = ve (t - (m/mdot) ln(m0/m)) - g t^2/2
    (constant mass when propellant_kg = 0). After burnout: free fall. The specific force along the
    axis is T/m during the burn and 0 afterwards (drag-free). Ends at end_time_s (default: apogee + 2 s).
    """
    m0 = dry_mass_kg + propellant_kg
    if thrust_n <= m0 * g:
        raise ValueError("thrust must exceed the initial weight")
    tb = burn_time_s

    def burn_state(t):
        t = np.asarray(t, dtype=float)
        if propellant_kg > 0:
            mdot = propellant_kg / tb
            ve = thrust_n / mdot
            m = m0 - mdot * t
            v = ve * np.log(m0 / m) - g * t
            z = ve * (t - (m / mdot) * np.log(m0 / m)) - 0.5 * g * t**2
        else:
            m = np.full_like(t, m0)
            a = thrust_n / m0 - g
            v = a * t
            z = 0.5 * a * t**2
        return z, v, m

    zb, vb, _ = burn_state(tb)
    zb, vb = float(zb), float(vb)
    t_apogee = tb + vb / g
    apogee = zb + vb**2 / (2 * g)
    if end_time_s is None:
        end_time_s = t_apogee + 2.0
    n = int(round(end_time_s / dt_s)) + 1
    t = np.arange(n) * dt_s
    z = np.empty(n)
    v = np.empty(n)
    f = np.empty(n)
    m = np.empty(n)
    burn = t < tb
    zb_, vb_, mb_ = burn_state(t[burn])
    z[burn], v[burn], m[burn] = zb_, vb_, mb_
    f[burn] = thrust_n / mb_
    c = ~burn
    tc = t[c] - tb
    z[c] = zb + vb * tc - 0.5 * g * tc**2
    v[c] = vb - g * tc
    f[c] = 0.0
    m[c] = dry_mass_kg
    thrust = np.where(burn, thrust_n, 0.0)
    h = site_altitude_m + z
    return Trajectory(
        time_s=t,
        altitude_m=z,
        velocity_mps=v,
        accel_mps2=f,
        pressure_pa=np.asarray(isa_pressure(h)),
        mach=np.abs(v) / isa_speed_of_sound(h),
        site_altitude_m=site_altitude_m,
        ground_pressure_pa=float(isa_pressure(site_altitude_m)),
        pad_accel_mps2=g,
        apogee_time_s=t_apogee,
        apogee_m=apogee,
        burnout_time_s=tb,
        events={"burnout": tb, "apogee": t_apogee},
        rocket="drag-free vertical (analytic)",
        source=f"analytic drag-free vertical flight: thrust {thrust_n:g} N for {tb:g} s, dry "
               f"{dry_mass_kg:g} kg, propellant {propellant_kg:g} kg",
        thrust_n=thrust,
        mass_kg=m,
    )


# --------------------------------------------------------------------------------------------------
# RocketPy


def motor_grain_geometry(eng: EngMotor, propellant_density: float = 1750.0) -> dict:
    """Plausible SolidMotor geometry from the .eng header (diameter, length, masses).

    The casing's inner radius is 85 % of the motor radius; propellant fills 80 % of the length in
    grains about 1.3 diameters long (at least one), 3 mm apart; the bore is chosen so that the grains
    hold the .eng propellant mass at `propellant_density` (APCP ~1750 kg/m^3), with the bore kept
    between 20 % and 70 % of the grain radius (density adjusted when it hits a limit). Only the motor's
    inertia and centre of mass depend on this; thrust and mass flow come from the .eng curve.
    """
    r_case = eng.diameter_mm / 2000.0
    length = eng.length_mm / 1000.0
    ro = 0.85 * r_case
    usable = 0.8 * length
    n = max(1, int(round(usable / (1.3 * 2 * r_case))))
    sep = 0.003 if n > 1 else 0.0
    h = (usable - sep * (n - 1)) / n
    vol_per_area = n * math.pi * h
    ri2 = ro**2 - eng.propellant_kg / (propellant_density * vol_per_area)
    ri = math.sqrt(ri2) if ri2 > 0 else 0.0
    ri = min(max(ri, 0.2 * ro), 0.7 * ro)
    density = eng.propellant_kg / (vol_per_area * (ro**2 - ri**2))
    dry = eng.total_kg - eng.propellant_kg
    i_lat = dry * (3 * r_case**2 + length**2) / 12.0
    i_roll = dry * r_case**2
    return dict(
        dry_mass=dry,
        dry_inertia=(i_lat, i_lat, i_roll),
        nozzle_radius=0.6 * ro,
        grain_number=n,
        grain_density=density,
        grain_outer_radius=ro,
        grain_initial_inner_radius=ri,
        grain_initial_height=h,
        grain_separation=sep,
        grains_center_of_mass_position=length / 2.0,
        center_of_dry_mass_position=length / 2.0,
        nozzle_position=0.0,
        throat_radius=0.3 * ro,
        coordinate_system_orientation="nozzle_to_combustion_chamber",
    )


_MOTOR_CACHE: dict = {}
_TIMINGS: dict[str, float] = {}


def _rocketpy():
    t0 = time.perf_counter()
    import rocketpy  # noqa: F401  (lazy: ~1.2 s)

    _TIMINGS.setdefault("import_rocketpy_s", time.perf_counter() - t0)
    return rocketpy


def _motor(eng: EngMotor):
    key = (eng.path, eng.time_s, eng.thrust_n, eng.propellant_kg, eng.total_kg)
    m = _MOTOR_CACHE.get(key)
    if m is None:
        rp = _rocketpy()
        curve = np.column_stack([eng.time_s, eng.thrust_n])
        with np.errstate(all="ignore"):
            m = rp.SolidMotor(thrust_source=curve, burn_time=None, interpolation_method="linear",
                              **motor_grain_geometry(eng))
        _MOTOR_CACHE[key] = m
    return m


def forget_motors_except(eng: EngMotor) -> None:
    """Drop every cached RocketPy motor but the ones of ``eng``'s thrust curve: a dispersed motor
    flies once, and keeping each would grow the cache by one motor per flight."""
    nominal = (eng.time_s, eng.thrust_n)
    for key in [k for k in _MOTOR_CACHE if k[1:3] != nominal]:
        del _MOTOR_CACHE[key]


def build_rocketpy(spec: RocketSpec, parachute_rate_hz: float = 20.0):
    """(Environment, Rocket) for a spec. Fast after the first call (the motor is cached)."""
    rp = _rocketpy()
    env = rp.Environment(gravity=G0, latitude=0.0, longitude=0.0, elevation=spec.elevation_m)
    env.set_atmospheric_model(type="custom_atmosphere", wind_u=spec.wind_u_mps, wind_v=spec.wind_v_mps)
    motor = _motor(spec.motor)
    L = spec.length_m
    with np.errstate(all="ignore"):
        rocket = rp.Rocket(
            radius=spec.radius_m,
            mass=spec.dry_mass_kg,
            inertia=(spec.inertia_lateral_kgm2, spec.inertia_lateral_kgm2, spec.inertia_roll_kgm2),
            power_off_drag=spec.drag_points,
            power_on_drag=spec.drag_points,
            center_of_mass_without_motor=L - spec.cg_from_nose_m,  # origin at the tail, +z to the nose
            coordinate_system_orientation="tail_to_nose",
        )
        rocket.add_motor(motor, position=spec.nozzle_from_tail_m)
        rocket.add_nose(length=spec.nose_length_m, kind=spec.nose_kind, position=L)
        rocket.add_trapezoidal_fins(
            n=spec.fin_count,
            root_chord=spec.fin_root_chord_m,
            tip_chord=spec.fin_tip_chord_m,
            span=spec.fin_span_m,
            position=spec.fin_offset_from_tail_m + spec.fin_root_chord_m,
            sweep_length=spec.fin_sweep_m,
        )
        if spec.drogue is not None:
            rocket.add_parachute("drogue", cd_s=spec.drogue.cd_s_m2, trigger="apogee",
                                 sampling_rate=parachute_rate_hz, lag=spec.drogue.lag_s)
        if spec.main is not None:
            rocket.add_parachute("main", cd_s=spec.main.cd_s_m2, trigger=spec.main.deploy_altitude_m,
                                 sampling_rate=parachute_rate_hz, lag=spec.main.lag_s)
    return env, rocket


def static_margin(spec: RocketSpec) -> float:
    """Static margin (calibres) at ignition, from RocketPy's Barrowman model."""
    _env, rocket = build_rocketpy(spec)
    return float(rocket.static_margin(0))


def _hermite(t, t0, t1, y0, y1, d0, d1):
    h = t1 - t0
    s = (t - t0) / h
    s2, s3 = s * s, s * s * s
    return ((2 * s3 - 3 * s2 + 1) * y0 + (s3 - 2 * s2 + s) * h * d0 + (-2 * s3 + 3 * s2) * y1
            + (s3 - s2) * h * d1)


def simulate_rocket(
    spec: RocketSpec,
    dt_s: float = 0.001,
    after_main_s: float | None = None,
    parachute_rate_hz: float = 20.0,
    min_static_margin: float = 0.5,
    rtol: float = 1e-6,
    dof: int = 6,
) -> Trajectory:
    """Fly a rocket with RocketPy (6 DOF ascent, 3 DOF under parachutes) and resample the result.

    dof=3 uses RocketPy's point-mass mode (with its weathercocking model of the body axis): 3 to 6
    times faster up to about 88 deg inclination, apogee within about 1 % in calm air, but much slower
    near vertical (RocketPy 1.13's weathercocking turns stiff there); see docs/SIMULATION.md.

    after_main_s: end the trajectory this long after the main opens (None: fly to the ground).
    RocketPy's descent is cheap (few integrator steps under a parachute); cutting the trajectory
    mostly saves the fine-grid and record size.
    Raises TrajectoryError for a rocket that is unstable or does not leave the rail.
    """
    if dof == 3 and spec.drogue is None:
        # measured: the J360 example without its drogue ran for more than 10 minutes
        raise TrajectoryError(
            f"{spec.path}: 3 DOF needs a [drogue]: without one RocketPy's point mass falls nose-down "
            "from apogee, where its weathercocking model turns stiff (minutes to hours); use 6 DOF"
        )
    timing = {}
    t0 = time.perf_counter()
    rp = _rocketpy()
    env, rocket = build_rocketpy(spec, parachute_rate_hz)
    timing["build_s"] = time.perf_counter() - t0
    margin = float(rocket.static_margin(0))
    if margin < min_static_margin:
        raise TrajectoryError(
            f"{spec.path}: rocket is unstable: static margin {margin:.2f} calibres at ignition (need >= "
            f"{min_static_margin:g}); move [body] cg_from_nose_m forward or enlarge the fins"
        )
    t1 = time.perf_counter()
    with warnings.catch_warnings(), np.errstate(all="ignore"):
        warnings.simplefilter("ignore")
        flight = rp.Flight(
            rocket=rocket,
            environment=env,
            rail_length=spec.rail_length_m,
            inclination=spec.inclination_deg,
            heading=spec.heading_deg,
            max_time=900.0,
            rtol=rtol,
            simulation_mode={6: "6 DOF", 3: "3 DOF"}[dof],
        )
    timing["flight_s"] = time.perf_counter() - t1
    t2 = time.perf_counter()
    if not flight.out_of_rail_time:
        raise TrajectoryError(
            f"{spec.path}: the rocket does not leave the rail (thrust too low for its mass)"
        )
    t_stop = None
    if after_main_s is not None:
        for t_ev, chute in flight.parachute_events:
            if chute.name == "main":
                t_stop = float(t_ev) + chute.lag + after_main_s
    traj = _resample_flight(flight, spec, rocket, dt_s, t_stop)
    timing["resample_s"] = time.perf_counter() - t2
    _TIMINGS.update({k: _TIMINGS.get(k, 0.0) + v for k, v in timing.items()})
    _TIMINGS["flights"] = _TIMINGS.get("flights", 0) + 1
    return traj


def timings() -> dict[str, float]:
    """Accumulated time per stage in this process (import, build, RocketPy flight, resampling)."""
    return dict(_TIMINGS)


def _resample_flight(flight, spec: RocketSpec, rocket, dt_s: float, t_stop: float | None) -> Trajectory:
    sol = np.asarray(flight.solution, dtype=float)
    # Remove duplicated times (keep the last state); phase boundaries are solver points.
    keep = np.concatenate([np.diff(sol[:, 0]) > 0, [True]])
    sol = sol[keep]
    ts = sol[:, 0]
    t_final = float(ts[-1])
    landed = len(flight.impact_state) > 1
    if t_stop is not None and t_stop < t_final:
        # Keep the solver points up to the first one at or after t_stop (for interpolation).
        last = int(np.searchsorted(ts, t_stop)) + 1
        sol, ts = sol[:last], ts[:last]
        t_final = float(t_stop)
        landed = False
    g = G0
    elev = spec.elevation_m
    wind = np.array([spec.wind_u_mps, spec.wind_v_mps, 0.0])
    eng = spec.motor
    sin_incl = math.sin(math.radians(spec.inclination_deg))
    g_axial = g * sin_incl

    phases = [p for p in flight.flight_phases]
    segments = []  # (t_start, t_end, kind, rows, accel(Nx3), sf(N))
    for k, phase in enumerate(phases):
        if phase.derivative is None or k + 1 >= len(phases):
            continue
        ta, tb = float(phase.t), float(min(phases[k + 1].t, t_final))
        if tb <= ta:
            continue
        tb_rows = float(min(phases[k + 1].t, ts[-1]))
        for cb in phase.callbacks:
            cb(flight)
        rows = np.flatnonzero((ts >= ta - 1e-12) & (ts <= tb_rows + 1e-12))
        if len(rows) < 2:
            continue
        name = phase.derivative.__name__
        acc = np.empty((len(rows), 3))
        with np.errstate(all="ignore"):
            for j, r in enumerate(rows):
                acc[j] = phase.derivative(ts[r], sol[r, 1:])[3:6]
        if name == "u_dot_parachute":
            axis = np.tile([0.0, 0.0, 1.0], (len(rows), 1))
            kind = "parachute"
        else:
            e0, e1, e2, e3 = sol[rows, 7], sol[rows, 8], sol[rows, 9], sol[rows, 10]
            axis = np.column_stack(
                [2 * (e1 * e3 + e0 * e2), 2 * (e2 * e3 - e0 * e1), 1 - 2 * (e1**2 + e2**2)]
            )
            kind = "rail" if name.startswith("udot_rail") else "free"
        sf = (acc[:, 0] * axis[:, 0] + acc[:, 1] * axis[:, 1] + (acc[:, 2] + g) * axis[:, 2])
        segments.append((ta, tb, kind, rows, acc, sf))

    n = int(math.floor(t_final / dt_s)) + 1
    t = np.arange(n) * dt_s
    z = np.empty(n)
    vel = np.empty((n, 3))
    f = np.empty(n)
    burn_end = eng.time_s[-1]
    thrust = np.interp(t, eng.time_s, eng.thrust_n, right=0.0)
    burn_idx = np.flatnonzero(t <= burn_end)
    mass = np.full(n, float(rocket.total_mass(burn_end + 1.0)))
    with np.errstate(all="ignore"):
        mass[burn_idx] = np.asarray(rocket.total_mass.get_value(t[burn_idx]), dtype=float)
    t_over_m = thrust / mass
    for si, (ta, tb, kind, rows, acc, sf) in enumerate(segments):
        last = si == len(segments) - 1
        idx = np.flatnonzero((t >= ta) & ((t <= tb) if last else (t < tb)))
        if len(idx) == 0:
            continue
        tr = ts[rows]
        seg = np.searchsorted(tr, t[idx], side="right") - 1
        seg = np.clip(seg, 0, len(tr) - 2)
        i0, i1 = rows[seg], rows[seg + 1]
        tt = t[idx]
        z[idx] = _hermite(tt, ts[i0], ts[i1], sol[i0, 3], sol[i1, 3], sol[i0, 6], sol[i1, 6])
        for c in range(3):
            vel[idx, c] = _hermite(tt, ts[i0], ts[i1], sol[i0, 4 + c], sol[i1, 4 + c], acc[seg, c],
                                   acc[seg + 1, c])
        # Thrust part exact, the rest interpolated.
        tm_nodes = np.interp(tr, t, t_over_m)
        resid = sf - tm_nodes
        if kind == "rail":
            resid = np.minimum(resid, 0.0)
        r_fine = np.interp(tt, tr, resid)
        ff = t_over_m[idx] + r_fine
        if kind == "rail":
            ff = np.maximum(ff, g_axial)
        f[idx] = ff
    alt_msl = z
    airspeed = np.linalg.norm(vel - wind, axis=1)
    mach = airspeed / isa_speed_of_sound(alt_msl)
    pressure = np.asarray(isa_pressure(alt_msl))

    events: dict[str, float] = {"ignition": 0.0, "rail_exit": float(flight.out_of_rail_time),
                                "burnout": float(burn_end)}
    apogee_time = float(flight.apogee_time)
    apogee_m = float(flight.apogee) - elev
    events["apogee"] = apogee_time
    drogue_t = main_t = None
    for t_ev, chute in flight.parachute_events:
        events[f"{chute.name}_trigger"] = float(t_ev)
        events[f"{chute.name}_open"] = float(t_ev + chute.lag)
        if chute.name == "drogue":
            drogue_t = float(t_ev + chute.lag)
        elif chute.name == "main":
            main_t = float(t_ev + chute.lag)
    if landed:
        events["landing"] = t_final
    return Trajectory(
        time_s=t,
        altitude_m=z - elev,
        velocity_mps=vel[:, 2].copy(),
        accel_mps2=f,
        pressure_pa=pressure,
        mach=mach,
        site_altitude_m=elev,
        ground_pressure_pa=float(isa_pressure(elev)),
        pad_accel_mps2=g_axial,
        apogee_time_s=apogee_time,
        apogee_m=apogee_m,
        burnout_time_s=float(burn_end),
        drogue_time_s=drogue_t,
        main_time_s=main_t,
        events=events,
        rocket=spec.name,
        source=f"RocketPy trajectory of {spec.path} (motor {eng.designation})",
        thrust_n=thrust,
        mass_kg=mass,
    )
