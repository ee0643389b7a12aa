"""The growth fit of the Lyapunov records (sensitivity/growth.py) on records of known form."""
from __future__ import annotations

import numpy as np
import pytest

from lagdsl.sensitivity.growth import growth_fits

T = np.arange(1.0, 1001.0)


def fit(record: np.ndarray):
    return growth_fits(T, (record / T)[:, None])[0]


@pytest.mark.parametrize("record, kind, rate, power", [
    (0.3 + 0.2 * T, "exponential", 0.2, 0.0),
    (0.3 + np.log(T), "algebraic", 0.0, 1.0),
    (0.3 + 0.5 * np.sin(T / 2.4), "bounded", None, None),
])
def test_the_three_kinds_of_growth_are_told_apart(record, kind, rate, power):
    growth = fit(record)
    assert growth.kind == kind
    assert growth.window == (100.0, 1000.0) and growth.points == 901
    if rate is not None:
        assert growth.rate == pytest.approx(rate, abs=1e-12) and growth.power == pytest.approx(power, abs=1e-9)
    else:
        assert abs(growth.rate) < 3 * growth.rate_error and abs(growth.power) < 3 * growth.power_error


def test_the_standard_error_follows_the_spread_of_correlated_residuals():
    # AR(1) residuals with ρ = 0.8 (the record correlated over a few points, as a chaotic one is
    # over a few Lyapunov times): the mean standard error agrees with the spread of the fitted
    # rate over 400 draws within 30%; the uncorrected one would be about 3 times too small
    rng = np.random.default_rng(7)
    rates, errors = [], []
    for _ in range(400):
        noise = np.zeros(T.size)
        shocks = rng.standard_normal(T.size)
        for j in range(1, T.size):
            noise[j] = 0.8 * noise[j - 1] + shocks[j]
        growth = fit(0.1 * T + 0.5 * np.log(T) + noise)
        rates.append(growth.rate)
        errors.append(growth.rate_error)
    assert np.mean(errors) == pytest.approx(np.std(rates), rel=0.3)
    assert np.mean(rates) == pytest.approx(0.1, abs=3 * np.std(rates) / np.sqrt(400))


def test_the_fit_is_linear_so_paired_records_give_rates_that_sum_to_zero():
    record = 0.05 * T + np.sin(T)
    fits = growth_fits(T, np.column_stack([record / T, -record / T]))
    assert fits[0].rate + fits[1].rate == pytest.approx(0.0, abs=1e-15)


def test_too_few_points_give_no_fit():
    assert growth_fits(np.arange(1.0, 5.0), np.ones((4, 1))) is None
