"""The seed study's flight model (seed chapter 4), reproduced exactly and vectorised over flights.

"The seed" is the paper this project starts from ("Digital Detection of Rocket Apogee"); the random
seed of a batch is ``seed`` (an int), as everywhere in desktop/.

The seed (``rocket_sim`` in its chapter 4) builds a 1 ms kinematic acceleration profile, integrates
it with a constant-acceleration state-transition matrix, adds Gaussian noise to position, velocity
and acceleration, keeps every 50th 1 ms sample and floor-quantises the amplitudes in steps of 3.
This module follows the seed's *code* (DESIGN.md D7), including its quirks:

- ``t = linspace(0, t_length, t_length*1000)``: the time vector is NOT 1 ms spaced but
  ``t_length / (N - 1)`` (1.0000667 ms for 15 s); every truth sample and measurement is labelled
  with it, so the 50-sample period is 50.0033 ms for a 15 s flight.
- ``t_accmax``, ``hold_a_max`` and ``t_g`` are END times of the rise, hold and decay (0.05, 0.35,
  0.5 s), not durations as the seed's prose says. The rise starts at ``g = -9.81`` at t = 0, so the
  first sample reads free fall.
- Truth: ``prv_states(3,:) = Acc_t``; for i = 1..N-1 the state ``[p; v; a]`` is propagated by
  ``trans_mat = [1 dt dt^2/2; 0 1 dt; 0 0 1]`` and column i of ``state_vecs`` holds the state AFTER
  step i, labelled ``t(i)``. Column N is never written and stays zero (it is never one of the
  every-50th samples for a flight length that is a multiple of 50 ms). Here the loop is replaced by
  its exact recurrence with ``numpy.cumsum`` (equal to the loop up to float rounding, ~1e-11 m).
- The true apogee is ``t(argmax(s_comp))`` on the 1 ms truth.
- Noise standard deviations 5.985 m, 2 m/s, 0.0346 m/s^2 (the seed's table calls them variances,
  its code uses them as standard deviations; so do we). The seed draws noise for every 1 ms sample
  and keeps every 50th; we draw it only for the kept samples, which is the same distribution.
- Quantisation ``floor(x / 3) * 3`` for all three channels, also for acceleration. This matters:
  with sigma = 0.0346 the noise does not dither a 3 m/s^2 step, so the coast reading of the true
  -9.81 m/s^2 is always -12 (a -2.19 m/s^2 bias), and a resting accelerometer (0) reads 0 or -3
  with equal probability.

Flight-CSV convention (DESIGN.md D6): ``accel_mps2`` is specific force, written as the quantised
kinematic acceleration + 9.81 (the seed's g): -2.19 in coast, 9.81 or 6.81 at rest.

Additions beyond the seed (each off in the seed-exact mode):

- A pad period (DESIGN.md D8): ``pad_s`` seconds of samples at rest before ignition (truth 0),
  with the same noise and quantisation plus a slow linear barometric drift that ends at 0 at
  ignition, so that pad calibration is exercised. ``time_s`` then starts at the first pad sample
  and ignition is at ``ignition_time_s = n_pad * period``. ``pad_s = 0`` gives the seed's time
  vector exactly.
- Monte-Carlo parameters drawn per flight (ranges in ``MonteCarloRanges``, documented there and in
  docs/SEED_STUDY.md).

Randomness: flight ``i`` of seed ``S`` uses its own ``numpy.random.default_rng([S, i])`` (a
``SeedSequence`` of the pair), so a flight is bit-for-bit the same whatever the batch it is
simulated in. Each flight draws, in this order: 4 uniforms (peak acceleration, hold end, decay
duration, pad drift; drawn even when the parameters are fixed, so the noise does not depend on the
mode), then the flight noise (3 x n_flight_samples standard normals: position, velocity,
acceleration), then the pad noise (3 x n_pad). The flight's noise therefore does not depend on the
pad length either.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

# The seed's constants.
DT_S = 1e-3                 # truth integration step (the seed's dt)
G_MPS2 = -9.81              # the seed's g (kinematic acceleration in coast)
SEED_PAPER_G0_MPS2 = 9.81   # the paper's g; specific force = kinematic - g: add this to write accel_mps2
DECIMATION = 50             # the seed's t(1:50:end): every 50th 1 ms sample
QUANT_STEP = 3.0            # the seed's floor(x/3)*3, for every channel
SIGMA_ALT_M = 5.985
SIGMA_VEL_MPS = 2.0
SIGMA_ACC_MPS2 = 0.0346

# The seed's default flight (its rocket_sim defaults).
SEED_T_LENGTH_S = 15.0
SEED_RISE_END_S = 0.05      # t_accmax
SEED_HOLD_END_S = 0.35      # hold_a_max
SEED_DECAY_END_S = 0.5      # t_g
SEED_A_PEAK_MPS2 = 160.0


def _ms(x_s) -> np.ndarray:
    """Seconds to whole 1 ms steps, as the seed's round(t * dt^-1)."""
    return np.rint(np.asarray(x_s, dtype=np.float64) * 1000.0).astype(np.int64)


@dataclass(frozen=True)
class FlightParams:
    """Acceleration-profile parameters of a batch of flights (arrays of shape (n_flights,)).

    End times are in whole milliseconds (the seed's index arithmetic round(t*1000) requires it):
    the rise runs over 1 ms samples [0, rise_end_ms), the hold [rise_end_ms, hold_end_ms), the
    decay [hold_end_ms, decay_end_ms), then g.
    """

    a_peak_mps2: np.ndarray
    rise_end_ms: np.ndarray
    hold_end_ms: np.ndarray
    decay_end_ms: np.ndarray

    def __post_init__(self):
        for name in ("a_peak_mps2", "rise_end_ms", "hold_end_ms", "decay_end_ms"):
            object.__setattr__(self, name, np.atleast_1d(np.asarray(getattr(self, name))))
        n = len(self.a_peak_mps2)
        for name in ("rise_end_ms", "hold_end_ms", "decay_end_ms"):
            arr = getattr(self, name).astype(np.int64)
            if arr.shape != (n,):
                raise ValueError(f"FlightParams: {name} has shape {arr.shape}, expected ({n},)")
            object.__setattr__(self, name, arr)
        object.__setattr__(self, "a_peak_mps2", self.a_peak_mps2.astype(np.float64))
        # linspace segments need at least 2 points (the seed's linspace(g, a_peak, n)).
        if (self.rise_end_ms < 2).any() or (self.hold_end_ms < self.rise_end_ms).any() or (
            self.decay_end_ms - self.hold_end_ms < 2
        ).any():
            raise ValueError("FlightParams: need rise_end >= 2 ms, hold_end >= rise_end, decay >= 2 ms")

    def __len__(self):
        return len(self.a_peak_mps2)

    def take(self, idx) -> FlightParams:
        return FlightParams(self.a_peak_mps2[idx], self.rise_end_ms[idx], self.hold_end_ms[idx],
                            self.decay_end_ms[idx])

    @classmethod
    def paper_default(cls, n: int = 1) -> FlightParams:
        """The paper's default flight, n times."""
        return cls(np.full(n, SEED_A_PEAK_MPS2), np.full(n, _ms(SEED_RISE_END_S)),
                   np.full(n, _ms(SEED_HOLD_END_S)), np.full(n, _ms(SEED_DECAY_END_S)))

    def as_dict(self, i: int) -> dict:
        """Flight i's parameters in seconds (for metadata)."""
        return {
            "a_peak_mps2": float(self.a_peak_mps2[i]),
            "t_accmax_s": int(self.rise_end_ms[i]) / 1000,
            "hold_a_max_s": int(self.hold_end_ms[i]) / 1000,
            "t_g_s": int(self.decay_end_ms[i]) / 1000,
        }


@dataclass(frozen=True)
class MonteCarloRanges:
    """Ranges of the randomised flights (uniform; the seed gives none).

    Centred on the seed's measured I-motor flight (160 m/s^2 peak, burnout 0.5 s, 63 m/s, 220 m):
    peak acceleration +-~40 % (100-220 m/s^2, about 10-22 g), hold end 0.25-0.60 s and decay
    duration 0.10-0.30 s (burnout 0.35-0.90 s), rise end fixed at the seed's 0.05 s. That spans
    burnout speeds of about 27-158 m/s, apogees of about 40-1360 m (drag-free, as the seed's model)
    at 3.2-17 s: a small low-power hop to a large high-power flight, all subsonic.
    ``pad_drift_mps`` bounds the pad's slow barometric drift (uniform +-, m/s; 0.02 m/s is a
    warming sensor drifting 1.2 m a minute).
    """

    a_peak_mps2: tuple[float, float] = (100.0, 220.0)
    hold_end_s: tuple[float, float] = (0.25, 0.60)
    decay_s: tuple[float, float] = (0.10, 0.30)
    rise_end_s: float = SEED_RISE_END_S
    pad_drift_mps: float = 0.02
    #: Every flight runs at least this long after its true apogee.
    after_apogee_s: float = 3.0

    def params_from_uniforms(self, u: np.ndarray) -> FlightParams:
        """Map uniforms u (n, >=3) in [0, 1) to parameters (times rounded to whole ms)."""
        lo, hi = self.a_peak_mps2
        a_peak = lo + (hi - lo) * u[:, 0]
        lo, hi = _ms(self.hold_end_s)
        hold = lo + np.floor((hi - lo + 1) * u[:, 1]).astype(np.int64)
        lo, hi = _ms(self.decay_s)
        decay = lo + np.floor((hi - lo + 1) * u[:, 2]).astype(np.int64)
        rise = np.full(len(u), _ms(self.rise_end_s))
        return FlightParams(a_peak, rise, hold, hold + decay)

    def worst_case(self) -> FlightParams:
        """The latest-apogee corner of the ranges (apogee time grows with each parameter)."""
        return FlightParams(np.array([self.a_peak_mps2[1]]), np.array([_ms(self.rise_end_s)]),
                            np.array([_ms(self.hold_end_s[1])]),
                            np.array([_ms(self.hold_end_s[1]) + _ms(self.decay_s[1])]))

    def flight_length_s(self) -> float:
        """Common flight length (whole seconds): the shortest whose last sample is at least
        ``after_apogee_s`` after the worst case's true apogee.

        One length for every draw because the detectors take one time vector for a batch (and the
        seed's linspace spacing depends on the length); computed from the ranges, not from the
        batch, so that a flight does not depend on the batch it is simulated in.
        """
        length = 1.0
        while True:
            apo_t, _ = true_apogee(self.worst_case(), length)
            t = seed_time_vector(length)
            last = t[(len(t) - 1) // DECIMATION * DECIMATION]
            if last >= apo_t[0] + self.after_apogee_s:
                return length
            length = float(max(length + 1.0, math.ceil(apo_t[0] + self.after_apogee_s)))


DEFAULT_RANGES = MonteCarloRanges()


# --------------------------------------------------------------------------------------------------
# Truth (1 ms)


def seed_time_vector(t_length_s: float) -> np.ndarray:
    """The seed's ``t = linspace(0, t_length, t_length*(1/dt))`` (not exactly 1 ms spaced)."""
    n = n_ms_samples(t_length_s)
    return np.linspace(0.0, float(t_length_s), n)


def n_ms_samples(t_length_s: float) -> int:
    n = round(float(t_length_s) * 1000)
    if abs(n - float(t_length_s) * 1000) > 1e-6 or n < 2:
        raise ValueError(f"t_length_s must be a whole number of milliseconds >= 2 ms (got {t_length_s})")
    return n


def acceleration_profile(params: FlightParams, n_ms: int) -> np.ndarray:
    """The seed's ``Acc_t`` for each flight: shape (n_flights, n_ms), m/s^2 (kinematic)."""
    g = G_MPS2
    j = np.arange(n_ms, dtype=np.float64)[None, :]
    n1 = params.rise_end_ms[:, None].astype(np.float64)
    n2 = params.hold_end_ms[:, None].astype(np.float64)
    n3 = params.decay_end_ms[:, None].astype(np.float64)
    ap = params.a_peak_mps2[:, None]
    # linspace(g, a_peak, n1)[j] and linspace(a_peak, g, n3 - n2)[j - n2]
    rise = g + (ap - g) * (j / (n1 - 1.0))
    decay = ap + (g - ap) * ((j - n2) / (n3 - n2 - 1.0))
    acc = np.where(j < n1, rise, np.where(j < n2, ap, np.where(j < n3, decay, g)))
    # numpy's linspace sets the last point exactly to the stop value; so do we (and so does MATLAB).
    return acc


def integrate_truth(acc: np.ndarray):
    """The seed's state-transition loop on ``Acc_t`` (n_flights, N), as an exact recurrence.

    Returns ``(s_comp, v_comp, a_comp)``, each (n_flights, N): column i (0-based) is the state after
    i + 1 steps of ``trans_mat`` (the seed's column i + 1), the last column zero as in the seed.
    """
    dt = DT_S
    v_after = np.cumsum(dt * acc, axis=1)                     # v_{i+1} = v_i + dt a_i
    incr = (0.5 * dt * dt) * acc                              # p_{i+1} = p_i + dt v_i + dt^2/2 a_i
    incr[:, 1:] += dt * v_after[:, :-1]
    s_after = np.cumsum(incr, axis=1)
    a_comp = acc.copy()
    for arr in (s_after, v_after, a_comp):
        arr[:, -1] = 0.0                                      # state_vecs(:, N) is never written
    return s_after, v_after, a_comp


def truth_at(params: FlightParams, t_length_s: float, idx_ms: np.ndarray):
    """The 1 ms truth at 0-based 1 ms indices ``idx_ms`` and its apogee, per flight, without
    building the (n_flights, N) arrays.

    Each flight's boost (up to its ``decay_end_ms``) is integrated by ``integrate_truth``'s cumsum
    recurrence; after it the acceleration is the constant g, where the seed's recurrence
    ``p += dt v + dt^2/2 g; v += dt g`` has the exact solution, k steps after (p0, v0),
    ``v = v0 + k dt g``, ``p = p0 + k dt v0 + k^2 dt^2 g / 2``. The apogee is the argmax of the
    boost part or of that parabola over the integers (checked at floor and ceil of its vertex).
    Equal to ``integrate_truth`` on the full arrays to float rounding (tests check 1e-9 m and the
    same argmax).

    Returns ``(s, v, a)`` each (n_flights, len(idx_ms)), the apogee index (n_flights,) and the
    apogee altitude (n_flights,).
    """
    n_ms = n_ms_samples(t_length_s)
    idx_ms = np.asarray(idx_ms, dtype=np.int64)
    n = len(params)
    n_b = int(params.decay_end_ms.max())
    if n_b > n_ms - 1:
        raise ValueError("the flight is shorter than its boost")
    acc_b = acceleration_profile(params, n_b)
    dt, g = DT_S, G_MPS2
    v_b = np.cumsum(dt * acc_b, axis=1)
    incr = (0.5 * dt * dt) * acc_b
    incr[:, 1:] += dt * v_b[:, :-1]
    s_b = np.cumsum(incr, axis=1)
    # Each flight's coast starts after its own boost (not the batch's longest), so that a flight's
    # truth is bit for bit the same in any batch.
    base = (params.decay_end_ms - 1)[:, None]                # last sample of the decay (= g)
    rows = np.arange(n)
    p0 = s_b[rows, base[:, 0]][:, None]
    v0 = v_b[rows, base[:, 0]][:, None]

    def coast(k):
        kf = k.astype(np.float64)
        return p0 + kf * dt * v0 + kf * kf * (dt * dt * g / 2.0), v0 + kf * (dt * g)

    in_boost = idx_ms[None, :] <= base
    s_c, v_c = coast(np.maximum(idx_ms[None, :] - base, 0))
    bi = np.minimum(idx_ms, n_b - 1)
    s = np.where(in_boost, s_b[:, bi], s_c)
    v = np.where(in_boost, v_b[:, bi], v_c)
    a = np.where(in_boost, acc_b[:, bi], g)
    last = idx_ms == n_ms - 1                                 # the seed's unwritten last column
    s[:, last] = v[:, last] = a[:, last] = 0.0

    # Apogee: the boost's maximum, or the coast parabola's integer maximum (k in [0, N - 2 - base]).
    kmax = (n_ms - 2 - base)[:, 0]
    kv = np.floor(v0[:, 0] / (-g * dt))
    cand = np.clip(np.stack([kv - 1, kv, kv + 1, kv + 2], axis=1), 0, kmax[:, None]).astype(np.int64)
    s_cand, _ = coast(cand)
    j = np.argmax(s_cand, axis=1)
    apo_idx = base[:, 0] + cand[rows, j]
    apo_m = s_cand[rows, j]
    s_bm = np.where(np.arange(n_b)[None, :] <= base, s_b, -np.inf)
    jb = np.argmax(s_bm, axis=1)
    boost_wins = s_bm[rows, jb] >= apo_m
    apo_idx = np.where(boost_wins, jb, apo_idx)
    apo_m = np.where(boost_wins, s_bm[rows, jb], apo_m)
    return s, v, a, apo_idx, apo_m


def true_apogee(params: FlightParams, t_length_s: float):
    """(apogee time on the seed's time vector, apogee altitude) per flight, from the 1 ms truth."""
    t = seed_time_vector(t_length_s)
    _, _, _, idx, apo_m = truth_at(params, t_length_s, np.array([0]))
    return t[idx], apo_m


def true_velocity_ms_index(params: FlightParams, idx: np.ndarray, n_ms: int) -> np.ndarray:
    """The seed's 1 ms truth velocity ``v_comp`` at 0-based 1 ms indices ``idx`` (same shape as
    ``params``, or broadcastable (..., n_flights)), in closed form (the prefix sum of ``Acc_t``):
    equal to ``integrate_truth`` to float rounding without building the (n, N) arrays.

    Indices are clipped to [0, N - 2] (the seed's last column is an unwritten zero)."""
    g = G_MPS2
    m = np.clip(np.asarray(idx, dtype=np.float64), 0, n_ms - 2) + 1.0   # number of summed terms
    n1 = params.rise_end_ms.astype(np.float64)
    n2 = params.hold_end_ms.astype(np.float64)
    n3 = params.decay_end_ms.astype(np.float64)
    ap = params.a_peak_mps2

    def lin_sum(k, n, start, stop):
        # sum of the first k points of linspace(start, stop, n), k clipped to [0, n]
        k = np.clip(k, 0.0, n)
        return k * start + (stop - start) / (n - 1.0) * k * (k - 1.0) / 2.0

    total = lin_sum(m, n1, g, ap)
    total = total + np.clip(m - n1, 0.0, n2 - n1) * ap
    total = total + lin_sum(m - n2, n3 - n2, ap, g)
    total = total + np.clip(m - n3, 0.0, None) * g
    return DT_S * total


# --------------------------------------------------------------------------------------------------
# Measurements


def quantise(x: np.ndarray) -> np.ndarray:
    """The seed's amplitude quantisation ``floor(x / 3) * 3``."""
    return np.floor(x / QUANT_STEP) * QUANT_STEP


@dataclass
class FlightBatch:
    """Simulated flights sharing one time vector. 2-D arrays are (n_flights, n_samples)."""

    time_s: np.ndarray              # (n_samples,), starts at 0 (the first pad sample, if any)
    altitude_m: np.ndarray          # noisy, quantised position (the seed's s_n_q)
    velocity_mps: np.ndarray        # noisy, quantised velocity (the seed's v_n_q; unused by filters)
    accel_mps2: np.ndarray          # specific force: quantised kinematic (the seed's a_n_q) + 9.81
    true_altitude_m: np.ndarray     # 1 ms truth at the sample times (0 on the pad)
    true_velocity_mps: np.ndarray
    true_accel_mps2: np.ndarray     # kinematic
    true_apogee_time_s: np.ndarray  # (n_flights,) t(argmax 1 ms truth) + ignition_time_s
    true_apogee_m: np.ndarray
    params: FlightParams
    flight_index: np.ndarray        # (n_flights,)
    seed: int
    t_length_s: float
    pad_s: float                    # requested pad length
    n_pad: int                      # pad samples actually prepended
    ignition_time_s: float          # time_s of the seed's t = 0
    pad_drift_mps: np.ndarray       # (n_flights,) barometric drift rate on the pad
    #: Optional (keep_unquantised=True): noisy values before quantisation at the sample times.
    unquantised: dict | None = field(default=None, repr=False)

    @property
    def n_flights(self) -> int:
        return self.altitude_m.shape[0]

    @property
    def ms_spacing_s(self) -> float:
        """Spacing of the seed's 1 ms time vector, t_length / (N - 1)."""
        n = n_ms_samples(self.t_length_s)
        return self.t_length_s / (n - 1)

    @property
    def accel_kinematic_mps2(self) -> np.ndarray:
        """Quantised kinematic acceleration (the seed's a_n_q), recovered exactly (multiples of 3)."""
        return np.rint((self.accel_mps2 - SEED_PAPER_G0_MPS2) / QUANT_STEP) * QUANT_STEP

    def true_velocity_at(self, times_s) -> np.ndarray:
        """|The 1 ms truth velocity| is what the study reports; this gives the signed value at
        ``times_s`` (shape (..., n_flights)): the 1 ms sample nearest each time, 0 before ignition,
        NaN where the time is NaN."""
        times = np.asarray(times_s, dtype=np.float64)
        n_ms = n_ms_samples(self.t_length_s)
        rel = times - self.ignition_time_s
        idx = np.rint(np.nan_to_num(rel, nan=0.0) / self.ms_spacing_s)
        v = true_velocity_ms_index(self.params, idx, n_ms)
        v = np.where(rel < -0.5 * self.ms_spacing_s, 0.0, v)
        return np.where(np.isnan(times), np.nan, v)

    def take(self, idx) -> FlightBatch:
        """A sub-batch (the same flights, bit for bit)."""
        idx = np.atleast_1d(idx)
        return FlightBatch(
            time_s=self.time_s, altitude_m=self.altitude_m[idx], velocity_mps=self.velocity_mps[idx],
            accel_mps2=self.accel_mps2[idx], true_altitude_m=self.true_altitude_m[idx],
            true_velocity_mps=self.true_velocity_mps[idx], true_accel_mps2=self.true_accel_mps2[idx],
            true_apogee_time_s=self.true_apogee_time_s[idx], true_apogee_m=self.true_apogee_m[idx],
            params=self.params.take(idx), flight_index=self.flight_index[idx], seed=self.seed,
            t_length_s=self.t_length_s, pad_s=self.pad_s, n_pad=self.n_pad,
            ignition_time_s=self.ignition_time_s, pad_drift_mps=self.pad_drift_mps[idx],
            unquantised=None if self.unquantised is None
            else {k: v[idx] for k, v in self.unquantised.items()},
        )


def _flight_draws(seed: int, flight_indices, n_flight: int, n_pad: int):
    """Per-flight generator draws: (uniforms (n, 4), flight noise (n, 3, n_flight),
    pad noise (n, 3, n_pad))."""
    n = len(flight_indices)
    u = np.empty((n, 4))
    noise = np.empty((n, 3, n_flight))
    pad_noise = np.empty((n, 3, n_pad))
    for r, i in enumerate(flight_indices):
        rng = np.random.default_rng([int(seed), int(i)])
        u[r] = rng.random(4)
        noise[r] = rng.standard_normal((3, n_flight))
        if n_pad:
            pad_noise[r] = rng.standard_normal((3, n_pad))
    return u, noise, pad_noise


def simulate(
    seed: int,
    flight_indices,
    *,
    params: FlightParams | None = None,
    ranges: MonteCarloRanges = DEFAULT_RANGES,
    t_length_s: float | None = None,
    pad_s: float = 0.0,
    chunk: int = 128,
    keep_unquantised: bool = False,
    progress=None,
) -> FlightBatch:
    """Simulate flights ``flight_indices`` of seed ``seed``.

    ``params``: fixed parameters (one per flight, or a single flight's broadcast), e.g.
    ``FlightParams.paper_default()``; None draws them from ``ranges``. ``t_length_s``: the seed's
    t_length; default 15 s with fixed parameters, ``ranges.flight_length_s()`` with drawn ones.
    ``pad_s``: seconds at rest before ignition (0: the seed exactly). ``chunk`` bounds the memory of
    the 1 ms truth (chunk x N floats). ``progress``: optional callable(n_done) for a progress bar.
    """
    flight_indices = np.atleast_1d(np.asarray(flight_indices, dtype=np.int64))
    n = len(flight_indices)
    if t_length_s is None:
        t_length_s = SEED_T_LENGTH_S if params is not None else ranges.flight_length_s()
    t_length_s = float(t_length_s)
    t_ms = seed_time_vector(t_length_s)
    n_ms = len(t_ms)
    spacing = t_length_s / (n_ms - 1)
    sample_ms = np.arange(0, n_ms, DECIMATION)          # the seed's 1:50:end
    if sample_ms[-1] == n_ms - 1:
        raise ValueError("t_length_s puts a sample on the seed's unwritten last column; "
                         "use a multiple of 50 ms")
    n_flight = len(sample_ms)
    period = DECIMATION * spacing
    if pad_s < 0:
        raise ValueError("pad_s must be >= 0")
    n_pad = int(round(pad_s / period))
    ignition = n_pad * period
    time_s = np.concatenate([np.arange(n_pad) * period, ignition + t_ms[sample_ms]])
    if n_pad == 0:
        time_s = t_ms[sample_ms].copy()                   # bit for bit the seed's t_q
    n_samples = n_pad + n_flight

    shape = (n, n_samples)
    out = {k: np.zeros(shape) for k in ("alt", "vel", "acc", "talt", "tvel", "tacc")}
    unq = {k: np.zeros(shape) for k in ("altitude_m", "velocity_mps", "accel_kinematic_mps2")} \
        if keep_unquantised else None
    apo_t = np.empty(n)
    apo_m = np.empty(n)
    drift = np.empty(n)
    all_params = []
    sigmas = np.array([SIGMA_ALT_M, SIGMA_VEL_MPS, SIGMA_ACC_MPS2])[None, :, None]
    pad_t_rel = (np.arange(n_pad) - n_pad) * period       # seconds before ignition (< 0)

    for c0 in range(0, n, chunk):
        c1 = min(n, c0 + chunk)
        u, noise, pad_noise = _flight_draws(seed, flight_indices[c0:c1], n_flight, n_pad)
        if params is None:
            p = ranges.params_from_uniforms(u)
        else:
            p = params if len(params) == n else params.take(np.zeros(n, dtype=np.int64))
            p = p.take(np.arange(c0, c1))
        all_params.append(p)
        drift[c0:c1] = ranges.pad_drift_mps * (2.0 * u[:, 3] - 1.0)

        s, v, a, k, apo_m[c0:c1] = truth_at(p, t_length_s, sample_ms)
        apo_t[c0:c1] = ignition + t_ms[k]
        truth = np.stack([s, v, a], axis=1)
        noisy = truth + sigmas * noise                               # (m, 3, n_flight)
        fl = slice(n_pad, None)
        out["talt"][c0:c1, fl], out["tvel"][c0:c1, fl], out["tacc"][c0:c1, fl] = truth.transpose(1, 0, 2)
        q = quantise(noisy)
        out["alt"][c0:c1, fl], out["vel"][c0:c1, fl], out["acc"][c0:c1, fl] = q.transpose(1, 0, 2)
        if n_pad:
            pad = sigmas * pad_noise
            pad[:, 0, :] += drift[c0:c1, None] * pad_t_rel[None, :]
            qp = quantise(pad)
            pl = slice(0, n_pad)
            out["alt"][c0:c1, pl], out["vel"][c0:c1, pl], out["acc"][c0:c1, pl] = qp.transpose(1, 0, 2)
        if unq is not None:
            for j, key in enumerate(unq):
                unq[key][c0:c1, fl] = noisy[:, j, :]
                if n_pad:
                    unq[key][c0:c1, :n_pad] = pad[:, j, :]
        if progress is not None:
            progress(c1 - c0)

    cat = FlightParams(*(np.concatenate([getattr(p, f) for p in all_params])
                         for f in ("a_peak_mps2", "rise_end_ms", "hold_end_ms", "decay_end_ms")))
    return FlightBatch(
        time_s=time_s, altitude_m=out["alt"], velocity_mps=out["vel"],
        accel_mps2=out["acc"] + SEED_PAPER_G0_MPS2,
        true_altitude_m=out["talt"], true_velocity_mps=out["tvel"], true_accel_mps2=out["tacc"],
        true_apogee_time_s=apo_t, true_apogee_m=apo_m, params=cat, flight_index=flight_indices,
        seed=int(seed), t_length_s=t_length_s, pad_s=float(pad_s), n_pad=n_pad,
        ignition_time_s=float(ignition), pad_drift_mps=drift, unquantised=unq,
    )


def simulate_monte_carlo(n_flights: int, seed: int, pad_s: float = 2.0, first: int = 0, **kw) -> FlightBatch:
    """Flights first .. first + n_flights - 1 with parameters drawn from ``DEFAULT_RANGES``."""
    return simulate(seed, np.arange(first, first + n_flights), pad_s=pad_s, **kw)


def simulate_paper_flight(seed: int = 0, flight_index: int = 0, pad_s: float = 0.0, **kw) -> FlightBatch:
    """The paper's default flight (15 s, 160 m/s^2, 0.05/0.35/0.5 s), one noise realisation."""
    return simulate(seed, [flight_index], params=FlightParams.paper_default(), pad_s=pad_s, **kw)


def flight_csv_columns(batch: FlightBatch, r: int = 0) -> tuple[dict, dict]:
    """(columns, metadata) of flight row ``r`` of ``batch`` for ``flightcsv.write_flight_csv``."""
    columns = {
        "time_s": batch.time_s,
        "altitude_m": batch.altitude_m[r],
        "accel_mps2": batch.accel_mps2[r],
        "true_altitude_m": batch.true_altitude_m[r],
        "true_velocity_mps": batch.true_velocity_mps[r],
    }
    meta = {
        "source": "desktop.sim.seed_model (seed chapter 4 flight model)",
        "seed": int(batch.seed),
        "flight_index": int(batch.flight_index[r]),
        "true_apogee_time_s": float(batch.true_apogee_time_s[r]),
        "true_apogee_m": float(batch.true_apogee_m[r]),
        "ignition_time_s": float(batch.ignition_time_s),
        "pad_s": float(batch.n_pad * DECIMATION * batch.ms_spacing_s),
        "t_length_s": float(batch.t_length_s),
        **batch.params.as_dict(r),
    }
    if batch.n_pad:
        meta["pad_drift_mps"] = float(batch.pad_drift_mps[r])
    return columns, meta
