"""A deterministic synthetic flight in integers, identical on MicroPython and CPython.

Used by the MicroPython tests and the step benchmark, which must feed bit-identical inputs to
every interpreter: no floats, no numpy, exact integer kinematics, and every value a small int
(the 32-bit wasm MicroPython's collector has been seen to crash on big-int temporaries).

Profile: pad (rest), boost at constant acceleration, drag-free coast under g, apogee, fall under g
until the drogue descent rate, then steady descent. Readings: barometric altitude in mm and
kinematic acceleration in mm/s^2, each with triangular pseudo-noise and optional glitches.
"""

from shared.physics import G_MMPS2


class Noise:
    """Wichmann-Hill style combined generator: three small LCGs, products below 2**23."""

    def __init__(self, seed):
        self.s1 = seed % 30268 + 1
        self.s2 = seed * 7 % 30306 + 1
        self.s3 = seed * 13 % 30322 + 1

    def uniform(self, amplitude):
        """Integer in [-amplitude, amplitude] (amplitude < 15000)."""
        self.s1 = 171 * self.s1 % 30269
        self.s2 = 172 * self.s2 % 30307
        self.s3 = 170 * self.s3 % 30323
        if amplitude <= 0:
            return 0
        if amplitude >= 15000:
            raise ValueError("noise amplitude must be below 15000")
        return (self.s1 + self.s2 + self.s3) % 30269 % (2 * amplitude + 1) - amplitude

    def triangular(self, amplitude):
        return (self.uniform(amplitude) + self.uniform(amplitude)) // 2


def make_flight(rate_hz=100, pad_s=2, boost_mmps2=100000, burn_ms=2000, descent_mps=20,
                after_apogee_s=10, alt_noise_mm=1500, acc_noise_mmps2=300, seed=1,
                ground_mm=300000, glitches=()):
    """Return (dt_us, alt_mm, acc_mmps2, truth_alt_mm, apogee_index) as lists of ints.

    ``glitches`` is a sequence of (sample index, altitude offset mm) added to the readings.
    ``apogee_index`` is the sample of the highest true altitude. dt_us[0] is 0.
    Kinematics are exact: with D = 2 rate^2, altitude is h_mm + frac / D and velocity is
    vel / (2 rate) mm/s, so one step is frac += vel + a, vel += 2 a (a in mm/s^2).
    """
    dt_us = 1000000 // rate_hz
    n_pad = pad_s * rate_hz
    n_burn = burn_ms * rate_hz // 1000
    coast_samples = boost_mmps2 * n_burn // 9807
    n_total = n_pad + n_burn + coast_samples + after_apogee_s * rate_hz
    d = 2 * rate_hz * rate_hz
    v_descent = -descent_mps * 1000 * 2 * rate_hz
    rng = Noise(seed)
    glitch_at = {}
    for index, offset in glitches:
        glitch_at[index] = offset
    dts, alts, accs, truth = [], [], [], []
    vel = 0
    alt_mm = ground_mm
    frac = 0
    best = alt_mm
    apogee_index = 0
    for i in range(n_total):
        if i < n_pad:
            acc = 0
        elif i < n_pad + n_burn:
            acc = boost_mmps2
        elif vel > v_descent:
            acc = -G_MMPS2
        else:
            acc = 0
            vel = v_descent
        if i > 0:
            frac += vel + acc
            alt_mm += frac // d
            frac %= d
            vel += 2 * acc
        if alt_mm > best:
            best = alt_mm
            apogee_index = i
        dts.append(dt_us if i else 0)
        truth.append(alt_mm)
        alts.append(alt_mm + rng.triangular(alt_noise_mm) + glitch_at.get(i, 0))
        accs.append(acc + rng.triangular(acc_noise_mmps2))
    return dts, alts, accs, truth, apogee_index
