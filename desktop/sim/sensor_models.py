"""Sensor models: turn a truth `Trajectory` into the record a flight computer would write.

Pipeline (all random draws from one seeded numpy Generator, in a fixed order: same seed, same record):

1. Pad: `pad_s` seconds at rest are prepended (time < 0), with the weather's slow pressure drift
   (a linear trend plus an Ornstein-Uhlenbeck wander) that continues through the flight.
2. Barometer: true static pressure + transonic static-port error (c q w(M), see TRANSONIC) -> static
   port lag (first order, `port_lag_s`) -> the part's oversampling/IIR lag (first order, per part)
   -> conversions at the part's own output data rate -> + constant offset + white noise ->
   quantised to the part's resolution, clipped to its range. The board reads the latest finished
   conversion (so a 50 Hz barometer read at 100 Hz repeats values, as on a real board).
3. Accelerometer along the body axis: true specific force -> the part's low-pass (first order at its
   bandwidth) -> (1 + scale error) a + bias + white noise -> rounded to the LSB -> clipped at full
   scale (+-16 g parts clip at launch of small or hot rockets).
4. Board timing: samples at `rate_hz` (20 to 100 Hz) with timing jitter, occasional dropped samples
   (row missing), occasional stalls (tens to hundreds of ms with no rows, e.g. flash writes), and
   occasional read errors (empty cell for one sensor).

Every part's datasheet figures live in ONE place, the `BARO_PARTS` / `ACCEL_PARTS` tables below;
`BaroPart.rocketpy_kwargs()` / `AccelPart.rocketpy_kwargs()` turn them into the keyword arguments of
RocketPy's `rocketpy.sensors.Barometer` / `Accelerometer`. A sensor profile is "BARO+ACCEL", e.g.
"bmp390+lsm6dso"; "ideal" is a noiseless, lag-free pair for tests. See docs/SIMULATION.md.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from scipy.signal import lfilter

from desktop.errors import DesktopError
from desktop.sim.trajectory import G0, GAMMA, Trajectory, isa_altitude

__all__ = [
    "BaroPart",
    "AccelPart",
    "SensorProfile",
    "BoardConfig",
    "TransonicModel",
    "BoardRecord",
    "BARO_PARTS",
    "ACCEL_PARTS",
    "SensorProfileError",
    "parse_profile",
    "profile_names",
    "make_record",
    "write_record",
    "transonic_window",
    "transonic_discrepancy",
]


class SensorProfileError(DesktopError):
    """An unknown sensor profile name (one-line message listing the known ones)."""


# --------------------------------------------------------------------------------------------------
# Parts: datasheet figures, one place each.


@dataclass(frozen=True)
class BaroPart:
    name: str
    setting: str  # the configuration the figures are for
    noise_pa: float  # white noise at the output, RMS, per conversion
    resolution_pa: float  # output quantisation step
    odr_hz: float  # conversion rate in that configuration
    lag_s: float  # first-order time constant of oversampling + IIR filter
    offset_pa: float  # constant offset drawn uniformly in +-offset_pa (absolute accuracy)
    range_pa: tuple[float, float]
    source: str

    def rocketpy_kwargs(self) -> dict:
        """Keyword arguments for rocketpy.sensors.Barometer (RocketPy's white noise has
        sigma = noise_density * sqrt(sampling_rate)). The per-flight offset is not included."""
        return dict(
            sampling_rate=self.odr_hz,
            measurement_range=self.range_pa[1],
            resolution=self.resolution_pa,
            noise_density=self.noise_pa / math.sqrt(self.odr_hz) if self.odr_hz else 0.0,
            noise_variance=1.0,
            name=self.name,
        )


@dataclass(frozen=True)
class AccelPart:
    name: str
    setting: str
    full_scale_mps2: float  # clipping level, +-
    resolution_mps2: float  # LSB
    noise_rms_mps2: float  # white noise RMS at `bandwidth_hz`
    bandwidth_hz: float  # low-pass bandwidth of the configuration (first-order model)
    odr_hz: float
    offset_mps2: float  # zero-g offset drawn uniformly in +-offset_mps2
    scale_error: float  # sensitivity tolerance (fraction); drawn normal, sigma = tol/2, clipped to +-tol
    source: str

    @property
    def lag_s(self) -> float:
        return 0.0 if math.isinf(self.bandwidth_hz) else 1.0 / (2.0 * math.pi * self.bandwidth_hz)

    def rocketpy_kwargs(self) -> dict:
        """Keyword arguments for rocketpy.sensors.Accelerometer (one axis figures for all three)."""
        return dict(
            sampling_rate=self.odr_hz,
            measurement_range=self.full_scale_mps2,
            resolution=self.resolution_mps2,
            noise_density=self.noise_rms_mps2 / math.sqrt(self.odr_hz) if self.odr_hz else 0.0,
            noise_variance=1.0,
            name=self.name,
        )


_MG = G0 / 1000.0  # one milli-g in m/s^2
_SEA_LEVEL_M_PER_PA = 0.0832  # |dh/dp| at 101325 Pa (reference/micropython-and-sensors.md 5.1)

BARO_PARTS: dict[str, BaroPart] = {
    "bmp388": BaroPart(
        name="bmp388",
        setting="pressure x8, temperature x1, IIR coefficient 3, ODR 50 Hz (Bosch 'Drone' use case)",
        noise_pa=0.11 / _SEA_LEVEL_M_PER_PA,  # 11 cm RMS in that use case -> 1.32 Pa
        resolution_pa=0.33,  # 19-bit ADC at x8 (BMP3 oversampling table)
        odr_hz=50.0,
        lag_s=0.075,  # IIR c=3 at 50 Hz: tau = 0.02 / ln(4/3) = 70 ms, + ~5 ms conversion window
        offset_pa=50.0,  # absolute accuracy +-0.5 hPa
        range_pa=(30000.0, 125000.0),
        source="Bosch BST-BMP388-DS001 Table 10 (use cases), oversampling table, key specs",
    ),
    "bmp390": BaroPart(
        name="bmp390",
        setting="pressure x8, temperature x1, IIR coefficient 3, ODR 50 Hz",
        noise_pa=0.11 / _SEA_LEVEL_M_PER_PA,  # taken equal to the BMP388 at the same setting (assumption)
        resolution_pa=0.33,
        odr_hz=50.0,
        lag_s=0.075,
        offset_pa=50.0,  # absolute accuracy +-0.5 hPa; relative accuracy +-3 Pa
        range_pa=(30000.0, 125000.0),
        source="Bosch BST-BMP390-DS002 key specs (0.016 Pa resolution, +-3 Pa relative accuracy); noise at "
               "this setting assumed equal to the BMP388's 'Drone' figure",
    ),
    "ms5611": BaroPart(
        name="ms5611",
        setting="OSR 4096 (8.22 ms conversion), pressure and temperature alternated: ~50 Hz pressure",
        noise_pa=1.2,  # RMS resolution at OSR 4096 (0.012 mbar)
        resolution_pa=1.0,  # the compensated output is in 0.01 mbar
        odr_hz=50.0,
        lag_s=0.005,  # no IIR; the 8.22 ms integration window acts as a ~4 ms lag
        offset_pa=150.0,  # absolute accuracy +-1.5 mbar at 25 degC
        range_pa=(1000.0, 120000.0),
        source="TE MEAS MS5611-01BA03 (RMS resolution 6.5/4.2/2.7/1.8/1.2 Pa at OSR 256..4096)",
    ),
    "ideal": BaroPart(
        name="ideal", setting="no noise, no lag, 1 mPa steps, 1 kHz", noise_pa=0.0, resolution_pa=0.001,
        odr_hz=1000.0, lag_s=0.0, offset_pa=0.0, range_pa=(0.0, 200000.0), source="test profile",
    ),
}

ACCEL_PARTS: dict[str, AccelPart] = {
    "adxl375": AccelPart(
        name="adxl375",
        setting="+-200 g, ODR 400 Hz (bandwidth 200 Hz)",
        full_scale_mps2=200.0 * G0,
        resolution_mps2=49.0 * _MG,  # 20.5 LSB/g typ
        noise_rms_mps2=5.0 * _MG * math.sqrt(200.0),  # ~5 mg/sqrt(Hz) (verify) over 200 Hz = 71 mg
        bandwidth_hz=200.0,
        odr_hz=400.0,
        offset_mps2=400.0 * _MG,  # 0 g offset, typ (large; calibrate on the pad)
        scale_error=0.10,  # sensitivity 18.4..22.6 LSB/g around 20.5
        source="Analog Devices ADXL375 Rev. B (sensitivity 18.4/20.5/22.6 LSB/g, 49 mg/LSB)",
    ),
    "mpu6050": AccelPart(
        name="mpu6050",
        setting="+-16 g (2048 LSB/g), DLPF_CFG 3 (44 Hz)",
        full_scale_mps2=32767 / 2048 * G0,
        resolution_mps2=G0 / 2048.0,
        noise_rms_mps2=400e-6 * G0 * math.sqrt(44.0),  # 400 ug/sqrt(Hz)
        bandwidth_hz=44.0,
        odr_hz=1000.0,
        offset_mps2=80.0 * _MG,  # zero-g offset Z +-80 mg (X/Y +-50 mg)
        scale_error=0.03,  # initial sensitivity tolerance +-3 %
        source="InvenSense PS-MPU-6000A-00 rev 3.4 (accelerometer table)",
    ),
    "lsm6dso": AccelPart(
        name="lsm6dso",
        setting="+-16 g (0.488 mg/LSB), ODR 416 Hz, LPF1 (ODR/2)",
        full_scale_mps2=32767 * 0.488 * _MG,
        resolution_mps2=0.488 * _MG,
        noise_rms_mps2=3.0 * _MG,  # RMS noise at +-16 g
        bandwidth_hz=208.0,
        odr_hz=416.0,
        offset_mps2=20.0 * _MG,  # zero-g offset typ (verify)
        scale_error=0.02,  # assumption (the reference gives no figure)
        source="ST DS12140 rev 2 (sensitivity 0.061/0.122/0.244/0.488 mg/LSB, RMS noise 1.8/2.0/2.4/3.0 mg)",
    ),
    "ideal": AccelPart(
        name="ideal", setting="no noise, no lag, 1 mm/s^2 steps, no clipping", full_scale_mps2=math.inf,
        resolution_mps2=0.001, noise_rms_mps2=0.0, bandwidth_hz=math.inf, odr_hz=1000.0, offset_mps2=0.0,
        scale_error=0.0, source="test profile",
    ),
}


@dataclass(frozen=True)
class SensorProfile:
    baro: BaroPart
    accel: AccelPart

    @property
    def name(self) -> str:
        return f"{self.baro.name}+{self.accel.name}"


def profile_names() -> list[str]:
    return [f"{b}+{a}" for b in BARO_PARTS if b != "ideal" for a in ACCEL_PARTS if a != "ideal"] + ["ideal"]


def parse_profile(name: str) -> SensorProfile:
    """'bmp390+lsm6dso' -> SensorProfile; 'ideal' -> ideal+ideal. SensorProfileError if unknown."""
    text = (name or "").strip().lower()
    if text == "ideal":
        return SensorProfile(BARO_PARTS["ideal"], ACCEL_PARTS["ideal"])
    parts = text.split("+")
    if len(parts) == 2 and parts[0] in BARO_PARTS and parts[1] in ACCEL_PARTS:
        return SensorProfile(BARO_PARTS[parts[0]], ACCEL_PARTS[parts[1]])
    raise SensorProfileError(
        f"unknown sensor profile {name!r}: use BARO+ACCEL with BARO one of {', '.join(BARO_PARTS)} and ACCEL "
        f"one of {', '.join(ACCEL_PARTS)} (e.g. bmp390+lsm6dso), or 'ideal'"
    )


# --------------------------------------------------------------------------------------------------
# Transonic static-pressure error


@dataclass(frozen=True)
class TransonicModel:
    """Static-port error dp = c * q * w(M) (q dynamic pressure, w a smooth window in Mach).

    c > 0 reads a higher pressure (lower altitude: the 'Mach dip' of 341-005), c < 0 the opposite.
    Unless `c` is fixed, each record draws sign +-1 (equal odds) and |c| uniformly in `c_range`.
    The window rises smoothly from `mach_on` to `mach_full`, stays 1 up to `mach_fade` and falls to 0
    at `mach_off`. The default range and window come from the 341-005 analysis (docs/SIMULATION.md).
    """

    c: float | None = None
    c_range: tuple[float, float] = (0.005, 0.05)
    mach_on: float = 0.9
    mach_full: float = 1.0
    mach_fade: float = 1.2
    mach_off: float = 1.3


def _smoothstep(x):
    x = np.clip(x, 0.0, 1.0)
    return x * x * (3.0 - 2.0 * x)


def transonic_window(mach, te: TransonicModel = TransonicModel()):
    m = np.asarray(mach, dtype=float)
    rise = _smoothstep((m - te.mach_on) / (te.mach_full - te.mach_on))
    fall = 1.0 - _smoothstep((m - te.mach_fade) / (te.mach_off - te.mach_fade))
    return rise * fall


# --------------------------------------------------------------------------------------------------
# Board


@dataclass(frozen=True)
class BoardConfig:
    """Board-level parameters (not tied to a part). Ranges in docs/SIMULATION.md."""

    rate_hz: float = 100.0
    pad_s: float = 20.0
    jitter_s: float = 0.0003  # RMS timing jitter, clipped to +-0.4 period
    drop_probability: float = 0.001  # per sample: the row is missing
    stall_rate_hz: float = 0.005  # expected stalls per second (flash writes, GC)
    stall_s: tuple[float, float] = (0.02, 0.15)  # stall length, uniform
    read_error_probability: float = 0.0005  # per sample and sensor: empty cell
    port_lag_s: float = 0.02  # static-port / av-bay first-order lag
    drift_pa_per_s: tuple[float, float] = (-0.03, 0.03)  # weather trend (+-1.1 hPa/h), uniform
    wander_pa: float = 1.5  # OU wander RMS (gusts, ambient fluctuation)
    wander_tau_s: float = 20.0
    transonic: TransonicModel = field(default_factory=TransonicModel)

    def validate(self) -> None:
        if not 20.0 <= self.rate_hz <= 100.0:
            raise ValueError(f"board rate {self.rate_hz:g} Hz is out of range (allowed 20 to 100 Hz)")
        if not 0.0 <= self.pad_s <= 600.0:
            raise ValueError(f"pad time {self.pad_s:g} s is out of range (allowed 0 to 600 s)")


IDEAL_BOARD = BoardConfig(jitter_s=0.0, drop_probability=0.0, stall_rate_hz=0.0, read_error_probability=0.0,
                          port_lag_s=0.0, drift_pa_per_s=(0.0, 0.0), wander_pa=0.0,
                          transonic=TransonicModel(c=0.0))


@dataclass
class BoardRecord:
    """What the board recorded (+ truth columns), ready for write_flight_csv."""

    columns: dict[str, np.ndarray]
    metadata: dict[str, object]
    comments: list[str]
    trajectory: Trajectory
    parameters: dict[str, float]

    @property
    def time_s(self) -> np.ndarray:
        return self.columns["time_s"]

    @property
    def pressure_pa(self) -> np.ndarray:
        return self.columns["pressure_pa"]

    @property
    def accel_mps2(self) -> np.ndarray:
        return self.columns["accel_mps2"]


def _lag(x: np.ndarray, dt: float, tau: float) -> np.ndarray:
    """Exact first-order lag of a sampled signal, starting in steady state at x[0]."""
    if tau <= 0.0 or len(x) < 2:
        return x
    a = math.exp(-dt / tau)
    y, _ = lfilter([1.0 - a], [1.0, -a], x, zi=[a * x[0]])
    return y


def _ou(rng: np.random.Generator, n: int, dt: float, sigma: float, tau: float) -> np.ndarray:
    """Ornstein-Uhlenbeck samples (stationary, RMS sigma, correlation time tau) on a uniform grid."""
    if n == 0 or sigma <= 0.0:
        return np.zeros(n)
    a = math.exp(-dt / tau)
    e = rng.standard_normal(n) * sigma * math.sqrt(1.0 - a * a)
    e[0] = rng.standard_normal() * sigma
    y, _ = lfilter([1.0], [1.0, -a], e, zi=[0.0])
    return y


def _sample_times(rng, t_start, t_end, board: BoardConfig):
    period = 1.0 / board.rate_hz
    phase = rng.uniform(0.0, period)
    n = int(math.floor((t_end - t_start - phase) / period)) + 1
    t = t_start + phase + np.arange(n) * period
    if board.jitter_s > 0:
        t = t + np.clip(rng.normal(0.0, board.jitter_s, n), -0.4 * period, 0.4 * period)
    keep = np.ones(n, dtype=bool)
    if board.drop_probability > 0:
        keep &= rng.random(n) >= board.drop_probability
    duration = t_end - t_start
    n_stalls = rng.poisson(board.stall_rate_hz * duration) if board.stall_rate_hz > 0 else 0
    for _ in range(n_stalls):
        s0 = rng.uniform(t_start, t_end)
        s1 = s0 + rng.uniform(*board.stall_s)
        keep &= ~((t >= s0) & (t < s1))
    t = t[keep]
    return t[(t >= t_start) & (t <= t_end)]


def make_record(
    traj: Trajectory,
    profile: str | SensorProfile = "bmp390+lsm6dso",
    seed: int = 0,
    board: BoardConfig | None = None,
) -> BoardRecord:
    """The board record of a trajectory: see the module docstring. Deterministic in `seed`."""
    sp = parse_profile(profile) if isinstance(profile, str) else profile
    board = board or BoardConfig()
    board.validate()
    rng = np.random.default_rng(seed)
    baro, acc = sp.baro, sp.accel

    # Per-record parameters: always the same draws in the same order, used or not.
    te = board.transonic
    u_c, u_sign, u_offset, u_bias, n_scale, u_drift = rng.random(), rng.random(), rng.random(), \
        rng.random(), rng.standard_normal(), rng.random()
    if te.c is None:
        c = (1.0 if u_sign < 0.5 else -1.0) * (te.c_range[0] + u_c * (te.c_range[1] - te.c_range[0]))
    else:
        c = float(te.c)
    baro_offset = (2.0 * u_offset - 1.0) * baro.offset_pa
    accel_bias = (2.0 * u_bias - 1.0) * acc.offset_mps2
    accel_scale = float(np.clip(n_scale * acc.scale_error / 2.0, -acc.scale_error, acc.scale_error))
    lo, hi = board.drift_pa_per_s
    drift_rate = lo + u_drift * (hi - lo)

    t_start = -board.pad_s
    t_end = traj.end_time_s
    t_board = _sample_times(rng, t_start, t_end, board)
    n = len(t_board)

    # Barometer: true + transonic -> port lag -> sensor lag, on the fine grid (t >= 0).
    dt = traj.dt_s
    tf = traj.time_s
    q = 0.5 * GAMMA * traj.pressure_pa * traj.mach**2
    p_fine = traj.pressure_pa + c * q * transonic_window(traj.mach, te)
    p_fine = _lag(_lag(p_fine, dt, board.port_lag_s), dt, baro.lag_s)
    conv_period = 1.0 / baro.odr_hz
    conv_phase = rng.uniform(0.0, conv_period)
    n_conv = int(math.floor((t_end - t_start + 1.0) / conv_period)) + 2
    t_conv = t_start - 1.0 + conv_phase + np.arange(n_conv) * conv_period
    p_conv = np.interp(t_conv, tf, p_fine, left=p_fine[0])
    weather = drift_rate * t_conv + _ou(rng, n_conv, conv_period, board.wander_pa, board.wander_tau_s)
    p_conv = p_conv + weather + baro_offset + rng.normal(0.0, 1.0, n_conv) * baro.noise_pa
    p_conv = np.round(p_conv / baro.resolution_pa) * baro.resolution_pa
    p_conv = np.clip(p_conv, *baro.range_pa)
    j = np.searchsorted(t_conv, t_board, side="right") - 1
    pressure = p_conv[np.clip(j, 0, n_conv - 1)]

    # Accelerometer: low-pass -> scale, bias, noise -> LSB -> clip.
    a_fine = _lag(traj.accel_mps2, dt, acc.lag_s)
    a_true = np.interp(t_board, tf, a_fine, left=traj.pad_accel_mps2)
    a = a_true * (1.0 + accel_scale) + accel_bias + rng.normal(0.0, 1.0, n) * acc.noise_rms_mps2
    a = np.round(a / acc.resolution_mps2) * acc.resolution_mps2
    if math.isfinite(acc.full_scale_mps2):
        top = math.floor(acc.full_scale_mps2 / acc.resolution_mps2) * acc.resolution_mps2
        a = np.clip(a, -top - acc.resolution_mps2, top)

    # Read errors: empty cells.
    if board.read_error_probability > 0:
        pressure = np.where(rng.random(n) < board.read_error_probability, np.nan, pressure)
        a = np.where(rng.random(n) < board.read_error_probability, np.nan, a)

    true_alt = np.interp(t_board, tf, traj.altitude_m, left=0.0)
    true_vel = np.interp(t_board, tf, traj.velocity_mps, left=0.0)
    ground_true = float(traj.ground_pressure_pa + np.interp(0.0, t_conv, weather))
    columns = {
        "time_s": t_board,
        "pressure_pa": pressure,
        "accel_mps2": a,
        "true_altitude_m": true_alt,
        "true_velocity_mps": true_vel,
    }
    params = {
        "transonic_c": c,
        "baro_offset_pa": baro_offset,
        "accel_bias_mps2": accel_bias,
        "accel_scale_error": accel_scale,
        "pressure_drift_pa_per_s": drift_rate,
    }

    def r(x, nd=3):
        return None if x is None else round(float(x), nd)

    metadata = {
        "rocket": traj.rocket,
        "source": traj.source,
        "sensor_profile": sp.name,
        "seed": int(seed),
        "true_apogee_time_s": r(traj.apogee_time_s, 4),
        "true_apogee_m": r(traj.apogee_m, 3),
        "ground_pressure_pa": r(ground_true + baro_offset, 2),
        "true_ground_pressure_pa": r(ground_true, 2),
        "site_altitude_m": r(traj.site_altitude_m, 2),
        "derived_columns": ", ".join(traj.derived_columns) if traj.derived_columns else "none",
        "board_rate_hz": r(board.rate_hz, 3),
        # the delay the board should compensate: static port + part filter + half a conversion
        "baro_lag_ms": int(round((board.port_lag_s + baro.lag_s + 0.5 / baro.odr_hz) * 1000)),
        # every part profile is a modern barometer with well under a metre of noise
        "baro_noise": "low" if baro.noise_pa < 20.0 else "standard",
        "accel_range_g": r(acc.full_scale_mps2 / G0, 1) if math.isfinite(acc.full_scale_mps2) else None,
        "pad_s": r(board.pad_s, 3),
        "true_max_mach": r(traj.max_mach, 3),
        "true_burnout_time_s": r(traj.burnout_time_s, 4),
        "true_drogue_time_s": r(traj.drogue_time_s, 4),
        "true_main_time_s": r(traj.main_time_s, 4),
        "transonic_c": r(c, 4),
        "baro_offset_pa": r(baro_offset, 2),
        "accel_bias_mps2": r(accel_bias, 4),
        "accel_scale_error": r(accel_scale, 5),
    }
    metadata = {k: v for k, v in metadata.items() if v is not None and v != ""}
    comments = [
        "Simulated flight record (desktop/sim/sensor_models.py): sensor columns as the board would log them",
        f"baro {baro.name} ({baro.setting}); accel {acc.name} ({acc.setting})",
        "true_altitude_m is above the site; true_velocity_mps is vertical; time 0 is ignition or launch",
        "ground_pressure_pa is the pad pressure as this board's barometer reads it at launch",
    ]
    return BoardRecord(columns=columns, metadata=metadata, comments=comments, trajectory=traj,
                       parameters=params)


def write_record(path, record: BoardRecord) -> None:
    from desktop.io.flightcsv import write_flight_csv

    write_flight_csv(path, record.columns, metadata=record.metadata, comments=record.comments)


# --------------------------------------------------------------------------------------------------
# Transonic analysis of a real flight (2012-09-29-serial-341-flight-005)


def transonic_discrepancy(log, pad_end_s: float = -0.07, t_max_s: float = 8.0,
                          step_s: float = 0.1) -> dict:
    """Baro-vs-accelerometer altitude discrepancy of a recorded flight (a FlightLog).

    The accelerometer (specific force along the axis, +g at rest) minus its mean pad reading is
    integrated twice from launch (vertical flight assumed); the barometer is converted with the
    standard atmosphere relative to the mean pad pressure. Returns rows (t, v, Mach, h_acc, h_baro, dh,
    dp = pressure error equivalent, q, dp/q) every step_s up to t_max_s, and the summary numbers used
    in docs/SIMULATION.md: the jump of dp across Mach 1 (from 0.1 s before the first sample at Mach
    >= 1 to 5 samples after it) and the peak dp at Mach >= 0.9, each also divided by q.
    """
    t = log.time_s
    p = log.pressure_pa
    a = log.accel_mps2
    pad = (t <= pad_end_s) & np.isfinite(p) & np.isfinite(a)
    p0 = float(np.mean(p[pad]))
    a0 = float(np.mean(a[pad]))
    m = (t > pad_end_s) & (t <= t_max_s) & np.isfinite(p) & np.isfinite(a)
    tt, pp, ak = t[m], p[m], a[m] - a0
    v = np.concatenate([[0.0], np.cumsum(0.5 * (ak[1:] + ak[:-1]) * np.diff(tt))])
    h = np.concatenate([[0.0], np.cumsum(0.5 * (v[1:] + v[:-1]) * np.diff(tt))])
    site = float(isa_altitude(p0))
    hb = isa_altitude(pp) - site
    from desktop.sim.trajectory import isa_pressure, isa_speed_of_sound, isa_temperature

    rho = isa_pressure(site + h) / (287.05287 * isa_temperature(site + h))
    mach = v / isa_speed_of_sound(site + h)
    q = 0.5 * rho * v**2
    dh = hb - h
    dp = -dh * rho * G0
    rows = []
    for ts in np.arange(0.0, t_max_s + 1e-9, step_s):
        i = int(np.argmin(np.abs(tt - ts)))
        rows.append(dict(t=float(tt[i]), v=float(v[i]), mach=float(mach[i]), h_acc=float(h[i]),
                         h_baro=float(hb[i]), dh=float(dh[i]), dp=float(dp[i]), q=float(q[i]),
                         c=float(dp[i] / q[i]) if q[i] > 2000 else math.nan))
    sup = mach >= 1.0
    first_sup = int(np.argmax(sup)) if sup.any() else None
    summary = dict(pad_pressure_pa=p0, pad_accel_mps2=a0, site_isa_m=site, max_velocity_mps=float(v.max()),
                   max_mach=float(mach.max()))
    if first_sup is not None:
        k = first_sup
        k0 = int(np.searchsorted(tt, tt[k] - 0.1))
        summary.update(
            mach1_time_s=float(tt[k]),
            jump_dp_pa=float(dp[k + 5] - dp[k0]) if k + 5 < len(dp) else math.nan,
            jump_c=float((dp[k + 5] - dp[k0]) / q[k]) if k + 5 < len(dp) else math.nan,
        )
    win = (mach >= 0.9)
    if win.any():
        i = int(np.argmax(np.where(win, dp, -np.inf)))
        summary.update(peak_dp_pa=float(dp[i]), peak_dp_time_s=float(tt[i]), peak_c=float(dp[i] / q[i]),
                       peak_mach=float(mach[i]))
    return dict(rows=rows, summary=summary)
