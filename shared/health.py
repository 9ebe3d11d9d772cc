"""Per-sensor health, judged on every sample before the filter sees the readings.

Portable and allocation-free per sample. ``SensorHealth.judge()`` takes the sample's ``have``
mask (``shared.detector.HAVE_BARO | HAVE_ACCEL``) and returns the mask of the readings that may
be used:

- a sensor the board does not have (``sensors`` in the configuration) is never used;
- a barometric altitude at either end of the altitude table (a pressure outside 1 to 110 kPa:
  a BMP280 returning 0, a broken bus) is out of range and not used;
- an accelerometer reading at its full scale under-reads, so the sample uses the barometer alone.

``age()`` then counts how long each sensor has gone without a usable reading; one without a
usable reading for ``sensor_lost_s`` is lost (``baro_ok`` / ``accel_ok`` False), and the proof of
flight falls back to the other sensor's (shared/flight.py).
"""

from shared.altitude import pressure_to_alt_mm
from shared.altitude_table import P_MAX_Q4, P_MIN_Q4
from shared.detector import HAVE_ACCEL, HAVE_BARO

# The ends of the altitude table: shared.altitude clamps any pressure outside it to these.
ALT_TOP_MM = pressure_to_alt_mm(P_MIN_Q4)
ALT_BOTTOM_MM = pressure_to_alt_mm(P_MAX_Q4)
_AGE_LIMIT_MS = 0x3FFFFFFF  # ages saturate here (days), inside 31 bits


class SensorHealth:
    """The verdict on each sample's readings (see the module docstring)."""

    def __init__(self, config):
        self.has_baro = config.has_baro
        self.has_accel = config.has_accel
        self.accel_limit_mmps2 = config.accel_limit_mmps2  # 0: full scale unknown, no check
        self.lost_ms = config.sensor_lost_ms
        self.accel_clipped = 0  # count of clipped accelerometer readings
        self.baro_out_of_range = 0  # count of barometric readings outside the table
        self.clipped = False  # this sample's accelerometer reading was clipped
        self.baro_age_ms = 0  # time since the last usable reading
        self.accel_age_ms = 0
        self.baro_ok = config.has_baro  # the board has it and it is not lost
        self.accel_ok = config.has_accel

    def judge(self, alt_mm, accel_mmps2, have):
        """The usable readings of this sample (``have`` minus what cannot be trusted)."""
        if not self.has_baro:
            have &= HAVE_ACCEL
        if not self.has_accel:
            have &= HAVE_BARO
        if have & HAVE_BARO and (alt_mm >= ALT_TOP_MM or alt_mm <= ALT_BOTTOM_MM):
            have &= HAVE_ACCEL  # an out-of-range pressure is not a reading
            self.baro_out_of_range += 1
        limit = self.accel_limit_mmps2
        if have & HAVE_ACCEL and limit and (accel_mmps2 >= limit or accel_mmps2 <= -limit):
            have &= HAVE_BARO  # a clipped reading under-reads: use the barometer alone
            self.accel_clipped += 1
            self.clipped = True
        else:
            self.clipped = False
        return have

    def age(self, dt_ms, have):
        """Count the time without a usable reading (``have`` as ``judge`` returned it)."""
        if have & HAVE_BARO:
            self.baro_age_ms = 0
        elif self.baro_age_ms < _AGE_LIMIT_MS - dt_ms:
            self.baro_age_ms += dt_ms
        if have & HAVE_ACCEL or self.clipped:  # clipped: alive, at full scale
            self.accel_age_ms = 0
        elif self.accel_age_ms < _AGE_LIMIT_MS - dt_ms:
            self.accel_age_ms += dt_ms
        # a sensor silent for sensor_lost_s no longer proves anything
        self.baro_ok = self.has_baro and self.baro_age_ms < self.lost_ms
        self.accel_ok = self.has_accel and self.accel_age_ms < self.lost_ms
