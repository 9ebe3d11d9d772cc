"""A filter that always re-converges (docs/DESIGN.md, "A filter that always re-converges"): from
altitude errors up to 3 km and velocity errors up to 600 m/s, in every model that uses the
barometer, the integer filter with the flight's gates and clamps settles within 1.5 times the
settling time of the linear filter its gains describe, and from its first reversal on each
velocity-error peak is at most half the one before (no limit cycle, no growing or sustained
oscillation). 500 seeded disturbances per model; a quick subset runs in the default suite.
"""

import numpy as np
import pytest

import shared.detector as detector_module
from tests.support.reconverge import (
    MODELS,
    integer_errors,
    linear_errors,
    linear_matrices,
    peaks_halve,
    settling_s,
)

HORIZON_S = 35  # the slowest linear settling is 21 s: 1.5 x that fits

# Linear settling to 1 m and 0.5 m/s from the worst of the 500 disturbances, at 100 Hz (measured
# with linear_errors; docs/DESIGN.md states them).
LINEAR_SETTLING_MAX_S = {"plain": 21.0, "coast_bias": 21.5, "late_coast": 21.5, "baro_only": 13.5}


def _disturbances(model, n):
    rng = np.random.default_rng({"plain": 1, "coast_bias": 2, "late_coast": 3, "baro_only": 4}[model])
    return zip(rng.uniform(-3000, 3000, n), rng.uniform(-600, 600, n), strict=True)


def _check(model, n):
    worst = 0.0
    for d_alt, d_vel in _disturbances(model, n):
        lin = linear_errors(model, d_alt, d_vel, HORIZON_S)
        t_lin = settling_s(lin)
        assert t_lin is not None and t_lin <= LINEAR_SETTLING_MAX_S[model]
        got = integer_errors(model, d_alt, d_vel, HORIZON_S)
        t_int = settling_s(got)
        assert t_int is not None, (model, d_alt, d_vel)
        assert t_int <= 1.5 * t_lin, (model, d_alt, d_vel, t_int, t_lin)
        assert peaks_halve(got), (model, d_alt, d_vel)
        worst = max(worst, t_int / t_lin)
    return worst


@pytest.mark.parametrize("model", list(MODELS))
def test_linear_filters_are_stable(model):
    f, _ = linear_matrices(model)
    assert np.abs(np.linalg.eigvals(f)).max() < 1


@pytest.mark.parametrize("model", list(MODELS))
def test_reconverges_from_large_errors_quick(model):
    assert _check(model, 6) <= 1.5


@pytest.mark.slow
@pytest.mark.parametrize("model", list(MODELS))
def test_reconverges_from_500_disturbances(model):
    # measured worst ratio: 1.21 (plain, coast_bias, late_coast), 1.12 (baro_only)
    assert _check(model, 500) <= 1.5


def test_gate_that_closes_at_once_makes_a_limit_cycle(monkeypatch):
    # the mutation: a re-synchronised gate that re-arms at the first reading inside it (the old
    # rule) cuts every overshoot short; the barometer-only filter then fails to settle
    monkeypatch.setattr(detector_module, "GATE_REARM_US", 0)
    failures = 0
    for d_alt, d_vel in _disturbances("baro_only", 6):
        got = integer_errors("baro_only", d_alt, d_vel, HORIZON_S)
        t_int = settling_s(got)
        t_lin = settling_s(linear_errors("baro_only", d_alt, d_vel, HORIZON_S))
        failures += t_int is None or t_int > 1.5 * t_lin or not peaks_halve(got)
    assert failures >= 4
