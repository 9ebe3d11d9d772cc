"""The array twin of shared.altitude.pressure_to_alt_mm gives the board's integers exactly."""

import numpy as np

from desktop.io.pressure_altitude import pressure_to_alt_mm_array
from shared.altitude import pressure_to_alt_mm
from shared.altitude_table import BAND_START_Q4, P_MAX_Q4, P_MIN_Q4


def test_every_band_edge_and_a_spread_of_pressures_match_the_board_function():
    edges = [s + d for s in BAND_START_Q4 for d in (-1, 0, 1)]
    outside = [-5, 0, P_MIN_Q4 - 1, P_MIN_Q4, P_MAX_Q4, P_MAX_Q4 + 1, 2**31]
    spread = np.random.default_rng(3).integers(P_MIN_Q4, P_MAX_Q4 + 1, 50_000).tolist()
    p_q4 = edges + outside + spread
    assert pressure_to_alt_mm_array(np.array(p_q4)).tolist() == [pressure_to_alt_mm(p) for p in p_q4]


def test_an_empty_log_has_no_altitudes():
    assert pressure_to_alt_mm_array(np.array([], dtype=np.int64)).size == 0
