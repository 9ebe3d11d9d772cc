"""``shared.altitude.pressure_to_alt_mm`` over whole arrays: the same integer interpolation in
numpy int64 (floor division and arithmetic shifts as Python's), for replays of long logs."""

import numpy as np

from shared import altitude_table as _TABLE


def interpolate_mm(p_q4, alt_mm_q, band_start_q4, band_step_q4, band_node, p_min_q4, p_max_q4, frac_bits,
                   bound=False):
    """Altitude (mm, int64 array) of the pressures ``p_q4`` (Pa x 16) in the table given by its
    arrays (shared/altitude_table.py's layout; node altitudes in mm with ``frac_bits`` fractional
    bits); with ``bound``, (altitudes, the largest |intermediate| of the arithmetic): the table
    generator's 31-bit check."""
    alt = np.asarray(alt_mm_q, dtype=np.int64)
    start = np.asarray(band_start_q4, dtype=np.int64)
    step = np.asarray(band_step_q4, dtype=np.int64)
    first = np.asarray(band_node, dtype=np.int64)
    p = np.clip(np.asarray(p_q4, dtype=np.int64), p_min_q4, p_max_q4)
    b = np.searchsorted(start, p, side="right") - 1
    q = p - start[b]
    s = step[b]
    k = q // s
    i = first[b] + k
    lo = alt[i]
    d = alt[i + 1] - lo
    prod = d * (q - k * s)
    num = prod + (s << (frac_bits - 1))
    out = (lo + num // s) >> frac_bits
    if not bound:
        return out
    if not p.size:
        return out, 0
    biggest = max(int(np.abs(a).max()) for a in (p, q, k * s, i, lo, d, prod, num, lo + num // s))
    return out, biggest


def pressure_to_alt_mm_array(p_q4):
    """``shared.altitude.pressure_to_alt_mm`` of every element of ``p_q4`` (Pa x 16): int64 mm."""
    return interpolate_mm(p_q4, _TABLE.ALT_Q2_MM, _TABLE.BAND_START_Q4, _TABLE.BAND_STEP_Q4,
                          _TABLE.BAND_NODE, _TABLE.P_MIN_Q4, _TABLE.P_MAX_Q4, 2)  # ALT_Q2: 2 bits
