"""Per-sensor health, judged on every sample before the filter sees the readings.

Portable and allocation-free per sample. ``SensorHealth.judge()`` takes the sample's ``have``
mask (``shared.detector.HAVE_BARO | HAVE_ACCEL``) and returns the mask of the readings that may
be used: a sensor the board does not have (``sensors`` in the configuration) is never used, and
an accelerometer reading at its full scale under-reads, so the sample uses the barometer alone.
"""

from shared.detector import HAVE_ACCEL, HAVE_BARO


class SensorHealth:
    """The verdict on each sample's readings (see the module docstring)."""

    def __init__(self, config):
        self.has_baro = config.has_baro
        self.has_accel = config.has_accel
        self.accel_limit_mmps2 = config.accel_limit_mmps2  # 0: full scale unknown, no check
        self.accel_clipped = 0  # count of clipped accelerometer readings
        self.clipped = False  # this sample's accelerometer reading was clipped

    def judge(self, accel_mmps2, have):
        """The usable readings of this sample (``have`` minus what cannot be trusted)."""
        if not self.has_baro:
            have &= HAVE_ACCEL
        if not self.has_accel:
            have &= HAVE_BARO
        limit = self.accel_limit_mmps2
        if have & HAVE_ACCEL and limit and (accel_mmps2 >= limit or accel_mmps2 <= -limit):
            have &= HAVE_BARO  # a clipped reading under-reads: use the barometer alone
            self.accel_clipped += 1
            self.clipped = True
        else:
            self.clipped = False
        return have
