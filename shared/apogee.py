"""Apogee decision rules over the Kalman state. Portable and allocation-free per sample.

Each rule has ``update(kf, rate_hz, enabled)``: called once per sample after the filter step;
returns True on the one sample at which it declares apogee. ``enabled`` is the caller's lockout
(False before burnout, before a minimum time or altitude, or through Mach): while it is False
the rule keeps its history current but never fires. A rule whose ``history`` is False keeps none,
and the caller may skip it while ``enabled`` is False (shared/detector.py does).
"""


class SeedRule:
    """The seed's rule: the altitude estimate fell on two consecutive samples (x[k] < x[k-1] < x[k-2])."""

    history = True  # the last two altitudes, from every sample

    def __init__(self):
        self.reset()

    def reset(self):
        self.prev1_q4 = 0
        self.prev2_q4 = 0
        self.history = 0  # samples seen, saturating at 2
        self.fired = False

    def update(self, kf, rate_hz, enabled):
        alt = kf.alt_q4
        falling = self.history >= 2 and alt < self.prev1_q4 < self.prev2_q4
        self.prev2_q4 = self.prev1_q4
        self.prev1_q4 = alt
        if self.history < 2:
            self.history += 1
        if enabled and falling and not self.fired:
            self.fired = True
            return True
        return False


class VelocityRule:
    """Velocity estimate reaches zero, to the nearest sample.

    Fires at the first sample where v <= 0, or where v > 0 but the filter's own deceleration
    brings v to zero within half a period (v <= -a T / 2): firing now is then nearer the true
    crossing than firing at the next sample.
    """

    history = False

    def __init__(self):
        self.reset()

    def reset(self):
        self.fired = False

    def update(self, kf, rate_hz, enabled):
        if not enabled or self.fired:
            return False
        vel = kf.vel_q4
        if vel <= 0 or (kf.acc_q4 < 0 and vel <= (-kf.acc_q4) // (2 * rate_hz)):
            self.fired = True
            return True
        return False
