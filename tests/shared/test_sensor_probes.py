"""Sensor failures outside the fault model (docs/FAULTS.md), probed on the three rockets of
tests/support/fault_flight.py and kept as a regression net: a part stuck at a value, a
part reset in flight to another range, a barometer frozen for 2 s, both sensors reading garbage
for 0.2 s, a lagging or coarsely quantised barometer, an accelerometer read at 10 Hz; single
glitches of either sensor from the pad on, a loop that stalls or whose time steps jitter, an
accelerometer that vibrates or whose bias steps, a barometer read at 5 to 20 Hz, repeating old
readings or drifting at 3 m/s. None may
fire the drogue more than 0.5 s before apogee, and every one must fire one (the backup timer set
as docs/CONFIG.md tells users, nominal apogee + 3 s). Each probe that fired early or not at all
when it was first flown is a rule in docs/DESIGN.md with its own test; docs/BENCHMARKS.md lists
the probes and what is still open.
"""

import numpy as np
import pytest

from tests.shared.test_arbitration import EARLY_LIMIT_S, MACH14_ROCKET, flight, run_with_readings
from tests.support.fault_flight import MACH_ROCKET, SUBSONIC_ROCKET

ROCKETS = {"mach1.0": SUBSONIC_ROCKET, "mach1.65": MACH14_ROCKET, "mach2.4": MACH_ROCKET}
G = 9807


def _stuck(fl, at_s, value_g):
    """Stuck at a value from ``at_s`` on."""
    accel = fl.accel_mmps2.copy()
    accel[fl.time_s >= at_s] = int(value_g * G)
    return {"accel_mmps2": accel}


def _scaled(fl, at_s, factor):
    """Reads ``factor`` x the specific force from ``at_s`` on (a part reset to another range)."""
    accel = fl.accel_mmps2.copy()
    after = fl.time_s >= at_s
    accel[after] = (accel[after] * factor).astype(np.int64)
    return {"accel_mmps2": accel}


def _baro_frozen(fl, at_s):
    """The barometer repeats one reading for 2 s, then reads again."""
    alt = fl.alt_mm.copy()
    held = np.flatnonzero((fl.time_s >= at_s) & (fl.time_s < at_s + 2.0))
    alt[held] = alt[held[0]]
    return {"alt_mm": alt}


def _garbage(fl, at_s):
    """Both sensors read random values for 0.2 s (+-500 m, +-16 g)."""
    rng = np.random.default_rng(1)
    alt, accel = fl.alt_mm.copy(), fl.accel_mmps2.copy()
    burst = (fl.time_s >= at_s) & (fl.time_s < at_s + 0.2)
    alt[burst] += rng.integers(-500000, 500000, burst.sum())
    accel[burst] = rng.integers(-16 * G, 16 * G, burst.sum())
    return {"alt_mm": alt, "accel_mmps2": accel}


def _baro_lagged(fl, tau_s=0.5):
    """A barometer behind a first-order lag (a heavily filtered part, a small port)."""
    alt = fl.alt_mm.astype(float)
    out = np.empty_like(alt)
    y = alt[0]
    for i, (a, dt_us) in enumerate(zip(alt, fl.dt_us, strict=True)):
        y += (a - y) * (dt_us / 1e6) / tau_s
        out[i] = y
    return {"alt_mm": out.astype(np.int64)}


def _glitches(fl, seed, chance=0.01, off_mm=100000):
    """Readings ``off_mm`` off, of either sign, with ``chance`` each, pad included (a bus error, a
    reading taken mid-conversion)."""
    rng = np.random.default_rng(seed)
    alt = fl.alt_mm.copy()
    hit = rng.random(len(alt)) < chance
    alt[hit] += rng.choice([-off_mm, off_mm], hit.sum())
    return {"alt_mm": alt}


def _accel_glitches(fl, seed, chance, value_g):
    """Accelerometer readings replaced, with ``chance`` each, by +-``value_g`` (negative: that
    value only)."""
    rng = np.random.default_rng(seed)
    accel = fl.accel_mmps2.copy()
    hit = rng.random(len(accel)) < chance
    sign = rng.choice([-1, 1], hit.sum()) if value_g > 0 else -1
    accel[hit] = sign * int(abs(value_g) * G)
    return {"accel_mmps2": accel}


def _jitter(fl, seed, fraction):
    """Each sample's time step off by up to +-``fraction`` (a loop timed by a drifting tick)."""
    rng = np.random.default_rng(seed)
    dt_us = fl.dt_us.copy()
    dt_us[1:] = (dt_us[1:] * (1 + rng.uniform(-fraction, fraction, len(dt_us) - 1))).astype(np.int64)
    return {"dt_us": dt_us}


def _baro_repeats(fl, seed, chance, samples):
    """With ``chance`` per sample, the barometer repeats its last reading for ``samples`` samples
    (a bus retried, the old value returned)."""
    rng = np.random.default_rng(seed)
    alt = fl.alt_mm.copy()
    i = 1
    while i < len(alt):
        if rng.random() < chance:
            alt[i:i + samples] = alt[i - 1]
            i += samples
        i += 1
    return {"alt_mm": alt}


def _stalls(fl, seed, chance, shortest, longest):
    """The loop stalls: from a sample, with ``chance``, the next ``shortest`` to ``longest``
    samples are never read, and the sample after them carries the whole time since (a flash
    write, a bus hang)."""
    rng = np.random.default_rng(seed)
    keep = np.ones(len(fl.dt_us), bool)
    i = 1
    while i < len(keep):
        if rng.random() < chance:
            n = int(rng.integers(shortest, longest + 1))
            keep[i:i + n] = False
            i += n
        i += 1
    clock = np.cumsum(fl.dt_us)[keep]
    dt_us = np.diff(clock, prepend=clock[0] - fl.dt_us[0])
    fields = ("alt_mm", "accel_mmps2", "have", "time_s", "true_alt_m", "true_vel_mps", "mach")
    return dict({name: getattr(fl, name)[keep] for name in fields}, dt_us=dt_us)


def _vibration(fl, at_s, rms_g):
    """Zero-mean noise of ``rms_g`` added to the accelerometer from ``at_s`` on (a loose sled)."""
    accel = fl.accel_mmps2.copy()
    after = fl.time_s >= at_s
    accel[after] += np.random.default_rng(1).normal(0, rms_g * G, after.sum()).astype(np.int64)
    return {"accel_mmps2": accel}


def _probes():
    cases = []
    for name, rocket in ROCKETS.items():
        burn = rocket.burn_s
        for at_s in (0.5, burn + 1.0):
            for value_g in (0.5, -0.5, 2.0):
                cases.append((name, "accel stuck at %+.1f g from %.1f s" % (value_g, at_s),
                              ("stuck", at_s, value_g)))
        for at_s in (0.5, burn + 1.0, burn + 5.0):
            for factor in (2.0, 0.5):
                cases.append((name, "accel x%.1f from %.1f s" % (factor, at_s), ("scaled", at_s, factor)))
        for at_s in (0.5, burn + 0.5, burn + 5.0):
            cases.append((name, "baro frozen 2 s from %.1f s" % at_s, ("frozen", at_s)))
        for at_s in (0.3, burn + 0.2, burn + 5.0):
            cases.append((name, "garbage 0.2 s at %.1f s" % at_s, ("garbage", at_s)))
        cases.append((name, "baro lag 0.5 s", ("lag",)))
        cases.append((name, "baro quantised to 8 m", ("quantised",)))
        cases.append((name, "accel read at 10 Hz", ("held",)))
        for seed in (0, 1, 2):
            cases.append((name, "baro glitches 1%% of 100 m, seed %d" % seed,
                          ("glitches", seed, 0.01, 100000)))
            cases.append((name, "stalls of 50-300 ms, seed %d" % seed, ("stalls", seed, 0.01, 5, 30)))
            cases.append((name, "stalls of 0.5-1 s, seed %d" % seed, ("stalls", seed, 0.002, 50, 100)))
        for rms_g in (4.0, 8.0):
            cases.append((name, "accel vibrating at %.0f g rms from burnout" % rms_g,
                          ("vibration", burn, rms_g)))
        for at_s in (burn + 1.0, burn + 5.0):
            for step in (3.0, -3.0, 6.0, -6.0):
                cases.append((name, "accel bias step %+.0f m/s^2 at %.1f s" % (step, at_s),
                              ("bias", at_s, step)))
        for every in (5, 10, 20):
            cases.append((name, "baro read every %d samples" % every, ("baro_every", every)))
        cases.append((name, "baro glitches 5% of 100 m", ("glitches", 0, 0.05, 100000)))
        cases.append((name, "baro glitches 1% of 1 km", ("glitches", 0, 0.01, 1000000)))
        cases.append((name, "accel glitches 1% of +-50 g", ("accel_glitches", 0, 0.01, 50.0)))
        cases.append((name, "accel glitches 1% of -16 g", ("accel_glitches", 0, 0.01, -16.0)))
        cases.append((name, "accel glitches 5% of +-16 g", ("accel_glitches", 0, 0.05, 16.0)))
        cases.append((name, "time steps 30% off", ("jitter", 0, 0.3)))
        cases.append((name, "baro repeating 5 samples, 2%", ("repeats", 0, 0.02, 5)))
        for rate_mps in (3.0, -3.0):
            cases.append((name, "baro drifting %+.0f m/s from burnout" % rate_mps, ("drift", burn, rate_mps)))
    return sorted(set(cases))


def _apply(fl, probe):
    kind = probe[0]
    if kind == "stuck":
        return _stuck(fl, probe[1], probe[2])
    if kind == "scaled":
        return _scaled(fl, probe[1], probe[2])
    if kind == "frozen":
        return _baro_frozen(fl, probe[1])
    if kind == "garbage":
        return _garbage(fl, probe[1])
    if kind == "lag":
        return _baro_lagged(fl)
    if kind == "quantised":
        return {"alt_mm": fl.alt_mm // 8000 * 8000}
    if kind == "glitches":
        return _glitches(fl, *probe[1:])
    if kind == "accel_glitches":
        return _accel_glitches(fl, *probe[1:])
    if kind == "jitter":
        return _jitter(fl, *probe[1:])
    if kind == "repeats":
        return _baro_repeats(fl, *probe[1:])
    if kind == "stalls":
        return _stalls(fl, *probe[1:])
    if kind == "vibration":
        return _vibration(fl, probe[1], probe[2])
    if kind == "bias":
        return {"accel_mmps2": fl.accel_mmps2 + (fl.time_s >= probe[1]) * int(probe[2] * 1000)}
    if kind == "baro_every":
        index = np.arange(len(fl.alt_mm))
        return {"alt_mm": fl.alt_mm[index // probe[1] * probe[1]]}
    if kind == "drift":
        after = np.maximum(fl.time_s - probe[1], 0.0)
        return {"alt_mm": fl.alt_mm + (after * probe[2] * 1000).astype(np.int64)}
    index = np.arange(len(fl.accel_mmps2))  # "held"
    return {"accel_mmps2": fl.accel_mmps2[index // 10 * 10]}


@pytest.mark.parametrize("name, label, probe", _probes(), ids=lambda v: v if isinstance(v, str) else "")
def test_a_sensor_failure_outside_the_fault_model_never_fires_early(name, label, probe):
    rocket = ROCKETS[name]
    fl = flight(rocket)
    out = run_with_readings(fl, **_apply(fl, probe))
    assert out.drogue_s is not None, "no drogue"
    assert out.early_s <= EARLY_LIMIT_S, "drogue %.2f s before apogee" % out.early_s
    assert -out.early_s <= 3.6, "drogue %.2f s after apogee, after the backup timer" % -out.early_s
