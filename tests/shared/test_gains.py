"""The gains tool: the seed's recursion, the converged gains, and the generated table."""

import numpy as np
import pytest

from shared import gains_table
from tools import gen_gains

# docs/DESIGN.md D7: the seed's recursion computed with numpy from the seed's listing.
SEED_K_FIXTURE = np.array([
    [0.0329735204, 1.4504801e-06],
    [0.0193120142, 5.98274301e-05],
    [4.86e-11, 0.998802871],
])


def test_seed_recursion_matches_fixture():
    k = gen_gains.seed_gain()
    # The fixture is printed to 9-10 significant digits; compare relative to each entry.
    assert np.allclose(k, SEED_K_FIXTURE, rtol=1e-8, atol=1e-12)


def test_print_seed_cli(capsys):
    assert gen_gains.main(["--print-seed"]) == 0
    out = capsys.readouterr().out
    assert "3.2973520421e-02" in out and "9.9880287139e-01" in out


def test_generated_table_is_current():
    # within one least significant bit: BLAS kernels may round the last bit differently
    tables = {name: getattr(gains_table, name) for name in ("PROJECT", "PROJECT_LOW_NOISE", "SEED")}
    assert gen_gains.table_differences(tables) == []
    assert gen_gains.main(["--check"]) == 0


@pytest.mark.parametrize("have, expected, same", [
    ((5000, 20), (5000, 20), True),
    ((5001, 20), (5000, 20), True),
    ((4999, 20), (5000, 20), True),
    ((5002, 20), (5000, 20), False),
    ((-5002, 20), (-5000, 20), False),
    ((16383, 20), (8192, 19), True),  # 0.0156240 vs 0.015625: a rounding carry across 2**-6
    ((16381, 20), (8192, 19), False),
])
def test_same_gain_allows_one_lsb(have, expected, same):
    assert gen_gains.same_gain(have, expected) is same


def test_table_differences_name_a_gain_two_lsb_off():
    expected = {"PROJECT": ((50, 1000, 20, 2000, 20),)}
    assert gen_gains.table_differences({"PROJECT": ((50, 1001, 20, 1999, 20),)}, expected) == []
    problems = gen_gains.table_differences({"PROJECT": ((50, 1000, 20, 2002, 20),)}, expected)
    assert problems == ["PROJECT at 50 Hz, gain 1: (2002, 20), expected (2000, 20)"]
    assert gen_gains.table_differences({"PROJECT": ((20, 1000, 20, 2000, 20),)}, expected) != []
    assert gen_gains.table_differences({}, expected) != []


@pytest.mark.parametrize("h, observable", [
    (gen_gains.H_BOTH, True), (gen_gains.H_BARO, True), (gen_gains.H_ACCEL, False)])
@pytest.mark.parametrize("rate_hz", gen_gains.RATES_HZ)
def test_observability_of_each_filter(rate_hz, h, observable):
    assert gen_gains.is_observable(gen_gains.transition(1.0 / rate_hz), h) is observable


@pytest.mark.parametrize("rate_hz", gen_gains.RATES_HZ)
def test_accelerometer_only_gain_never_calls_the_riccati_solver(rate_hz, monkeypatch):
    # the method follows from observability, not from how the solver fails on a given BLAS kernel
    def refuse(*args):
        raise AssertionError("solve_discrete_are called for an unobservable filter")

    monkeypatch.setattr(gen_gains.scipy.linalg, "solve_discrete_are", refuse)
    r = np.array([[gen_gains.SIGMA_ACCEL_MPS2**2]])
    k = gen_gains.steady_gain(1.0 / rate_hz, gen_gains.H_ACCEL, r)
    # the acceleration state follows the accelerometer; altitude and velocity gains stay finite
    assert k.shape == (3, 1) and 0 < k[2, 0] < 1 and np.all(np.isfinite(k))


def test_doubled_recursion_is_the_recursion_in_steps_of_two_to_the_j():
    t = 0.01
    a, q = gen_gains.transition(t), gen_gains.white_jerk_q(t)
    h, r = gen_gains.H_BOTH, np.diag([gen_gains.SIGMA_ALT_M**2, gen_gains.SIGMA_ACCEL_MPS2**2])
    p_doubled = gen_gains.doubled_recursion_prior(a, q, h, r)
    # the fixed point of one recursion step
    k = gen_gains.kalman_gain(p_doubled, h, r)
    p_next = a @ (np.eye(3) - k @ h) @ p_doubled @ a.T + q
    assert np.allclose(p_next, p_doubled, rtol=1e-12, atol=0)


def test_cross_check_catches_a_wrong_riccati_solution(monkeypatch):
    monkeypatch.setattr(gen_gains.scipy.linalg, "solve_discrete_are", lambda a, b, q, r: 1.01 * np.eye(3))
    with pytest.raises(gen_gains.GainError, match="disagree"):
        gen_gains.steady_gain(0.01, gen_gains.H_BARO, np.array([[gen_gains.SIGMA_ALT_M**2]]))


@pytest.mark.parametrize("rate_hz", gen_gains.RATES_HZ)
def test_riccati_solution_is_the_limit_of_the_recursion(rate_hz):
    t = 1.0 / rate_hz
    for h, r in ((gen_gains.H_BOTH, np.diag([gen_gains.SIGMA_ALT_M**2, gen_gains.SIGMA_ACCEL_MPS2**2])),
                 (gen_gains.H_BARO, np.array([[gen_gains.SIGMA_ALT_M**2]]))):
        # the plain recursion stops when K changes by < 1e-14 per step, short of its limit by ~1e-7
        assert np.allclose(gen_gains.steady_gain(t, h, r), gen_gains.iterated_gain(t, h, r),
                           rtol=1e-5, atol=1e-12)


def test_altos_gains_reproduced_at_100hz():
    # docs/DESIGN.md D12: AltOS's BOTH gains at 0.01 s in SI units. AltOS scales Q
    # by 16^2 in its internal units, which moves K01 by ~2.5%; the rest agree to 0.1%.
    both = gen_gains.project_gains(100)[0]
    altos = np.array([[0.0081273, 8.964e-4], [0.0033206, 0.0094928], [9.96e-5, 0.0951244]])
    assert np.allclose(both[:, 0], altos[:, 0], rtol=0.03)
    assert np.allclose(both[:, 1], altos[:, 1], rtol=0.03)


@pytest.mark.parametrize("table", [gains_table.PROJECT, gains_table.SEED])
def test_integer_gains_encode_the_float_gains(table):
    for row in table:
        assert len(row) == 53
        rate = row[0]
        if table is gains_table.SEED:
            floats = gen_gains.seed_family_gains()
        else:
            floats = gen_gains.project_gains(rate)
        values = np.concatenate([m.reshape(-1) for m in floats])
        for i, k in enumerate(values):
            mantissa, shift = row[1 + 2 * i], row[2 + 2 * i]
            assert abs(mantissa) < 2**14 and 14 <= shift <= 29
            # 14-bit mantissa: relative error <= 2^-14; gains below 2^-14 lose bits (shift <= 28)
            assert abs(gen_gains.decode(mantissa, shift) - k) <= max(abs(k) * 2**-13, 2**-29)


def test_to_fixed_rejects_out_of_range():
    with pytest.raises(ValueError):
        gen_gains.to_fixed(1.0)
