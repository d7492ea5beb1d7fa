"""The board's figures (`board_figures`, the JSON of `snapo alm`): the hedge ratio and key-rate
durations against central bumps of an independent NumPy balance sheet and the mix's closed-form
duration; the fan chart, the probability of underfunding and surplus at risk against the
outcome `evaluate` and `simulate` give without a trajectory."""

import jax
import numpy as np
import pytest

from finance import alm
from finance.alm._board import BoardSettings, balance_sheet_figures, path_figures
from references import alm_balance_sheet
from snapo_ode import InputError


@pytest.fixture(scope="module")
def study():
    return alm.build_study(40, horizon_months=24)


def test_key_rate_durations_and_hedge_ratio_equal_bumps_of_a_numpy_balance_sheet(study):
    figures = balance_sheet_figures(study)
    rates = np.asarray(study.reported["key_rates"])
    assets, liabilities = alm_balance_sheet(study)
    h = 1e-6
    slopes = []
    for k in range(rates.size):
        up, down = rates.copy(), rates.copy()
        up[k] += h
        down[k] -= h
        slopes.append((np.array(alm_balance_sheet(study, up)) - np.array(alm_balance_sheet(study, down))) / (2 * h))
    slopes = np.array(slopes).T  # (2, tenors)
    durations = figures["key_rate_durations"]
    np.testing.assert_allclose(durations["assets"], -slopes[0] / assets, rtol=1e-6, atol=1e-9)
    np.testing.assert_allclose(durations["liabilities"], -slopes[1] / liabilities, rtol=1e-6, atol=1e-9)
    np.testing.assert_allclose(durations["surplus"], -(slopes[0] - slopes[1]) / liabilities, rtol=1e-6, atol=1e-9)
    np.testing.assert_allclose(durations["dv01"]["liabilities"], -slopes[1] * 1e-4, rtol=1e-6, atol=1e-12)
    assert figures["hedge_ratio"] == pytest.approx(slopes[0].sum() / slopes[1].sum(), rel=1e-7)
    # Closed form: the assets' duration is the mix's value-weighted maturity (cash and equities 0).
    expected = sum(alm.DEFAULT_MIX[c.name] * c.maturity for c in study.market.bond_classes)
    assert expected == pytest.approx(0.15 * 5 + 0.30 * 30 + 0.10 * 20 + 0.10 * 7, rel=1e-15)
    assert sum(durations["assets"]) == pytest.approx(expected, rel=1e-12)


def test_path_figures_agree_with_the_hard_evaluation(study):
    shocks = alm.scenarios(study, 256, jax.random.key(7))
    policy = alm.NeuralRebalancing(study.market, key=jax.random.key(8))
    settings = BoardSettings(required_funding_ratio=1.2, months=(6, 24), confidence=0.9)
    figures = path_figures(study, policy, shocks, settings)
    fan = figures["funding_ratio_percentiles"]
    assert fan["months"] == list(range(25))
    np.testing.assert_allclose([fan[p][0] for p in ("p05", "p50", "p95")], 1.1, rtol=1e-12)
    factors = {**study.fixed, **study.reported}
    outcome = alm.simulate(study.problem, policy, factors, shocks, smooth_constraints=False)
    terminal = np.asarray(outcome.funding_ratio)
    assert fan["p50"][-1] == pytest.approx(np.median(terminal), rel=1e-12)
    below = figures["p_underfunded"]
    assert below["months"] == [6, 24]
    assert below["below_1"][-1] == np.mean(terminal < 1.0)
    assert below["below_required"][-1] == np.mean(terminal < 1.2)
    evaluation = alm.evaluate(study, policy, shocks)
    assert below["below_1"][-1] == evaluation.funding_ratio["probability_below_1"]
    # Surplus at risk at the horizon from Outcome.surplus (discounted, per initial liability).
    assets, liabilities = alm_balance_sheet(study)
    discounted = np.asarray(outcome.surplus) * liabilities
    risk = figures["surplus_at_risk"]
    assert risk["initial_surplus"] == pytest.approx(assets - liabilities, rel=1e-10)
    quantile = np.quantile(discounted, 0.1)
    assert risk["surplus_at_risk"][-1] == pytest.approx(risk["initial_surplus"] - quantile, rel=1e-9)
    assert risk["expected_shortfall"][-1] == pytest.approx(
        risk["initial_surplus"] - discounted[discounted <= quantile].mean(), rel=1e-9)
    assert risk["expected_shortfall"][-1] >= risk["surplus_at_risk"][-1]
    # The trajectory is recorded beside the objective's program, not in it.
    again = alm.simulate(study.problem, policy, factors, shocks, smooth_constraints=False, trajectory=True)
    np.testing.assert_array_equal(np.asarray(again.utility), np.asarray(outcome.utility))


@pytest.mark.parametrize("kwargs, message", [
    (dict(required_funding_ratio=0.0), "required_funding_ratio"),
    (dict(confidence=1.0), "confidence"),
    (dict(months=(0,)), r"board months = \[0\]"),
])
def test_board_settings_refuse_bad_values(kwargs, message):
    with pytest.raises(InputError, match=message):
        BoardSettings(**kwargs)
    assert BoardSettings(months=(12, 36)).dates(24) == [12] and BoardSettings(months=(36,)).dates(24) == [24]
