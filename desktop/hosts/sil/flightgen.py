"""Host side (CPython) of the software-in-the-loop runs: a simulated flight as raw sensor registers.

``Scenario`` describes the truth: pad, boost at constant acceleration, drag-free coast, a steady
descent under the drogue to the ground, plus knocks (accelerometer spikes) and pressure steps, and
sensor faults. ``write_frames(path, scenario)`` samples it every ``frame_us`` and turns it into the
raw data registers the register-level fakes (desktop/fakes) hold: barometer words through
``FakeBMP390.encode_pressure`` (the inverse of the Bosch compensation for the fake's calibration),
accelerometer counts through ``FakeADXL375.set_truth``. ``desktop/hosts/sil/world.py`` replays them on the
guest.
"""

import math
import struct
from dataclasses import dataclass, field

import numpy as np

from desktop.hosts.sil.world import FLAG_BARO_NEW, HDR_FMT, MAGIC
from desktop.sim.fakes import FakeADXL375, FakeBMP390

G = 9.80665


def isa_pressure_pa(alt_msl_m):
    return 101325.0 * (1.0 - 2.25577e-5 * alt_msl_m) ** 5.25588


@dataclass
class Scenario:
    duration_s: float = 90.0
    launch_s: float | None = 30.0  # None: never launched
    boost_mps2: float = 60.0
    burn_s: float = 1.5
    descent_mps: float = 20.0
    site_alt_m: float = 300.0
    temp_c: float = 15.0
    noise_pa: float = 1.0
    noise_mps2: float = 0.3
    seed: int = 1
    frame_us: int = 5000
    baro_every: int = 4  # frames per barometer conversion (5 ms frames: 50 Hz)
    knocks: list = field(default_factory=list)  # (t_s, duration_s, extra specific force m/s^2)
    pressure_steps: list = field(default_factory=list)  # (t_s, duration_s, delta Pa)
    kill_baro_s: float | None = None
    kill_accel_s: float | None = None
    stalls: list = field(default_factory=list)  # (t_s, stall_us), at most two

    def truth(self, t):
        """(altitude above the pad m, velocity m/s, specific force along the axis m/s^2) at t."""
        if self.launch_s is None or t < self.launch_s:
            return 0.0, 0.0, G
        tau = t - self.launch_s
        a, tb = self.boost_mps2, self.burn_s
        if tau < tb:
            return 0.5 * a * tau * tau, a * tau, a + G
        vb, hb = a * tb, 0.5 * a * tb * tb
        tc = tau - tb
        t_fall = (vb + self.descent_mps) / G  # coast until the descent rate is reached
        if tc < t_fall:
            return hb + vb * tc - 0.5 * G * tc * tc, vb - G * tc, 0.0
        h1 = hb + vb * t_fall - 0.5 * G * t_fall * t_fall
        h = h1 - self.descent_mps * (tc - t_fall)
        if h <= 0:
            return 0.0, 0.0, G
        return h, -self.descent_mps, G

    def apogee(self):
        """(time s, altitude m) of the true apogee."""
        vb = self.boost_mps2 * self.burn_s
        hb = 0.5 * self.boost_mps2 * self.burn_s ** 2
        return self.launch_s + self.burn_s + vb / G, hb + vb * vb / (2 * G)


def write_frames(path, sc):
    n = int(round(sc.duration_s * 1e6 / sc.frame_us))
    rng = np.random.default_rng(sc.seed)
    baro = FakeBMP390()
    raw_t = baro.encode_temp(sc.temp_c)
    acc = FakeADXL375()
    acc.regs[0x2D] = 0x08  # measuring
    acc.regs[0x31] = 0x0B
    kill_b = -1 if sc.kill_baro_s is None else int(sc.kill_baro_s * 1e6 // sc.frame_us)
    kill_a = -1 if sc.kill_accel_s is None else int(sc.kill_accel_s * 1e6 // sc.frame_us)
    st = [(int(t * 1e6 // sc.frame_us), int(us)) for t, us in sc.stalls] + [(-1, 0), (-1, 0)]
    out = bytearray(struct.pack(HDR_FMT, MAGIC, sc.frame_us, n, kill_b, kill_a, st[0][0], st[0][1],
                                st[1][0], st[1][1]))
    raw_p = 0
    for i in range(n):
        t = i * sc.frame_us / 1e6
        h, _v, f = sc.truth(t)
        for t0, dur, extra in sc.knocks:
            if t0 <= t < t0 + dur:
                f += extra
        flags = 0
        if i % sc.baro_every == 0:
            p = isa_pressure_pa(sc.site_alt_m + h) + rng.normal(0.0, sc.noise_pa)
            for t0, dur, dp in sc.pressure_steps:
                if t0 <= t < t0 + dur:
                    p += dp
            raw_p = baro.encode_pressure(p, raw_t)
            flags = FLAG_BARO_NEW
        acc.set_truth((0.0, 0.0, f + rng.normal(0.0, sc.noise_mps2)))
        out.append(flags)
        out += bytes((raw_p & 0xFF, (raw_p >> 8) & 0xFF, raw_p >> 16,
                      raw_t & 0xFF, (raw_t >> 8) & 0xFF, raw_t >> 16))
        out += bytes(acc.regs[0x32:0x38])
    with open(path, "wb") as fh:
        fh.write(out)
    return n


def agl_at(sc, t_s):
    return sc.truth(t_s)[0]


def close(a, b, tol):
    return math.isfinite(a) and abs(a - b) <= tol
