"""Host side (CPython) of the software-in-the-loop runs: a simulated flight as raw sensor registers.

``Scenario`` describes the truth: pad, boost at constant acceleration, drag-free coast, a steady
descent under the drogue to the ground, plus knocks (accelerometer spikes) and pressure steps, and
sensor faults; ``Recording`` is a recorded flight (a flight CSV's pressure and specific force).
``write_frames(path, scenario)`` and ``write_recording_frames(path, recording)`` sample them every
``frame_us`` and turn them into the raw data registers the register-level fakes
(desktop/sim/fakes) hold: barometer words through ``FakeBMP390.encode_pressure`` (the inverse of
the Bosch compensation for the fake's calibration), accelerometer counts through
``FakeADXL375.set_truth``. ``desktop/hosts/sil/world.py`` replays them on the guest.
"""

import math
import struct
from dataclasses import dataclass, field

import numpy as np

from desktop.hosts.sil.world import FLAG_BARO_NEW, HDR_FMT, MAGIC
from desktop.sim.fakes import FakeADXL375, FakeBMP390
from shared.physics import G0_MPS2

G = G0_MPS2


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

    def write(self, path):
        """Write the frames file; returns the number of frames."""
        return write_frames(path, self)


class FrameWriter:
    """The frames file: a header, then one frame per ``frame_us`` with the barometer's data
    registers (when it completed a conversion in that frame) and the accelerometer's."""

    def __init__(self, frame_us, n, temp_c, kill_baro_frame=-1, kill_accel_frame=-1, stalls=()):
        st = list(stalls) + [(-1, 0), (-1, 0)]
        self.out = bytearray(struct.pack(HDR_FMT, MAGIC, frame_us, n, kill_baro_frame, kill_accel_frame,
                                         st[0][0], st[0][1], st[1][0], st[1][1]))
        self.baro = FakeBMP390()
        self.raw_t = self.baro.encode_temp(temp_c)
        self.raw_p = 0
        self.acc = FakeADXL375()
        self.acc.regs[0x2D] = 0x08  # measuring
        self.acc.regs[0x31] = 0x0B

    def add(self, pressure_pa, force_mps2):
        """One frame: ``pressure_pa`` a new barometer conversion (None: none in this frame),
        ``force_mps2`` the specific force along the long axis."""
        flags = 0
        if pressure_pa is not None:
            self.raw_p = self.baro.encode_pressure(pressure_pa, self.raw_t)
            flags = FLAG_BARO_NEW
        self.acc.set_truth((0.0, 0.0, force_mps2))
        raw_p, raw_t = self.raw_p, self.raw_t
        self.out.append(flags)
        self.out += bytes((raw_p & 0xFF, (raw_p >> 8) & 0xFF, raw_p >> 16,
                           raw_t & 0xFF, (raw_t >> 8) & 0xFF, raw_t >> 16))
        self.out += bytes(self.acc.regs[0x32:0x38])

    def save(self, path):
        with open(path, "wb") as fh:
            fh.write(self.out)


def write_frames(path, sc):
    """Frames of the scenario ``sc``; returns the number of frames."""
    n = int(round(sc.duration_s * 1e6 / sc.frame_us))
    rng = np.random.default_rng(sc.seed)
    kill_b = -1 if sc.kill_baro_s is None else int(sc.kill_baro_s * 1e6 // sc.frame_us)
    kill_a = -1 if sc.kill_accel_s is None else int(sc.kill_accel_s * 1e6 // sc.frame_us)
    stalls = [(int(t * 1e6 // sc.frame_us), int(us)) for t, us in sc.stalls]
    frames = FrameWriter(sc.frame_us, n, sc.temp_c, kill_b, kill_a, stalls)
    for i in range(n):
        t = i * sc.frame_us / 1e6
        h, _v, f = sc.truth(t)
        for t0, dur, extra in sc.knocks:
            if t0 <= t < t0 + dur:
                f += extra
        p = None
        if i % sc.baro_every == 0:
            p = isa_pressure_pa(sc.site_alt_m + h) + rng.normal(0.0, sc.noise_pa)
            for t0, dur, dp in sc.pressure_steps:
                if t0 <= t < t0 + dur:
                    p += dp
        frames.add(p, f + rng.normal(0.0, sc.noise_mps2))
    frames.save(path)
    return n


@dataclass
class Recording:
    """A recorded flight as the SIL world's source: the log's samples held between rows, after
    ``pad_s`` of the first row's readings (the board powers up, arms and calibrates on the pad
    first) and followed by ``tail_s`` of the last row's (so the board sees the landing and
    writes its log). A log time ``t`` is simulated time ``t - time_s[0] + pad_s``."""

    time_s: np.ndarray
    pressure_pa: np.ndarray
    accel_mps2: np.ndarray
    pad_s: float = 30.0
    tail_s: float = 20.0
    frame_us: int = 5000
    baro_every: int = 4  # frames per barometer conversion (5 ms frames: 50 Hz)
    temp_c: float = 15.0

    @property
    def duration_s(self):
        return self.pad_s + float(self.time_s[-1] - self.time_s[0]) + self.tail_s

    def offset_s(self):
        """Simulated time minus log time."""
        return self.pad_s - float(self.time_s[0])

    def write(self, path):
        """Write the frames file; returns the number of frames."""
        return write_recording_frames(path, self)


def _held(time_s, values, at_s):
    """The last finite value at or before each time of ``at_s`` (the first finite value before it)."""
    ok = np.isfinite(values)
    t, v = time_s[ok], values[ok]
    idx = np.searchsorted(t, at_s, side="right") - 1
    return v[np.clip(idx, 0, len(v) - 1)]


def write_recording_frames(path, rec):
    """Frames of a recorded flight (``Recording``); returns the number of frames."""
    n = int(round(rec.duration_s * 1e6 / rec.frame_us))
    log_t = np.arange(n) * (rec.frame_us / 1e6) - rec.offset_s()
    pressure = _held(rec.time_s, rec.pressure_pa, log_t)
    force = _held(rec.time_s, rec.accel_mps2, log_t)
    frames = FrameWriter(rec.frame_us, n, rec.temp_c)
    for i in range(n):
        frames.add(float(pressure[i]) if i % rec.baro_every == 0 else None, float(force[i]))
    frames.save(path)
    return n


def agl_at(sc, t_s):
    return sc.truth(t_s)[0]


def close(a, b, tol):
    return math.isfinite(a) and abs(a - b) <= tol
