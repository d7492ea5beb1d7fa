"""The adjoint sensitivities of the ALM objective against independent references: central
bump-and-revalue with the same random numbers (float64), forward mode, and closed forms."""

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from finance import alm
from finance.alm._liabilities import monthly_cash_flows
from snapo_ode import bump_and_revalue, max_relative_difference, value_and_sensitivities


def _sensitivities(study, n_paths=16):
    shocks = alm.scenarios(study, n_paths, jax.random.key(3))
    policy = alm.NeuralRebalancing(study.market, key=jax.random.key(4))
    fn = alm.objective_of_reported(study.problem, study.fixed)
    return fn, policy, shocks


@pytest.mark.parametrize("n_risk_factors", [10, 40])
def test_adjoint_equals_central_bump_on_every_factor(n_risk_factors):
    study = alm.build_study(n_risk_factors, horizon_months=12)
    fn, policy, shocks = _sensitivities(study)
    value, gradient = jax.jit(lambda r: value_and_sensitivities(fn, r, policy, shocks))(study.reported)
    reference = bump_and_revalue(fn, study.reported, policy, shocks, relative_step=1e-6)
    names = alm.named_sensitivities(gradient, study.layout, study.market)
    assert len(names) == n_risk_factors
    assert max_relative_difference(gradient, reference) <= 1e-6
    assert np.isfinite(float(value))
    # Every group moves the objective: no factor is silently disconnected.
    for group in study.layout.reported:
        assert np.any(np.asarray(gradient[group]) != 0), group


def test_forward_mode_and_timed_bump_agree_with_the_adjoint():
    study = alm.build_study(40, horizon_months=6)
    fn, policy, shocks = _sensitivities(study, n_paths=8)
    measured = alm.measure_sensitivities(study, policy, shocks, repeats=1)
    assert measured.max_rel_diff <= 1e-6
    assert measured.max_rel_diff_forward_mode <= 1e-10
    assert set(measured.sensitivities) == {
        name for group in study.layout.reported
        for name in alm.factor_names(study.layout, study.market)[group]}
    assert measured.speedup == pytest.approx(measured.bump_seconds / measured.adjoint_seconds)
    assert measured.gradient_forward_ratio == pytest.approx(measured.adjoint_seconds / measured.value_seconds)


def _flat_cash_fund(rate, horizon):
    """A fund on a flat curve with no volatility, holding only cash, no effects."""
    study = alm.build_study(40, horizon_months=horizon, effects=())
    factors = {**study.fixed, **study.reported}
    factors = {k: np.asarray(v) for k, v in factors.items()}
    factors["key_rates"] = np.full_like(factors["key_rates"], rate)
    for group in ("rate_vols", "equity_vols", "inflation_vol", "spread_vol"):
        factors[group] = np.zeros_like(factors[group])
    return alm.build_study(40, horizon_months=horizon, effects=(), factors=factors)


def _flat_value(cash_flows, rate, month):
    """The liability value after `month` on a flat curve, in closed form: each outstanding flow
    discounted at its own date, exp(-rate (m - month) / 12)."""
    flows = np.asarray(monthly_cash_flows(cash_flows))
    months = np.arange(1, flows.size + 1)
    later = months > month
    return float(np.sum(flows[later] * np.exp(-rate * (months[later] - month) / 12)))


def test_cash_only_fund_on_a_flat_deterministic_curve_matches_the_closed_form():
    rate, horizon = 0.03, 24
    study = _flat_cash_fund(rate, horizon)
    factors = {**study.fixed, **study.reported}
    shocks = alm.scenarios(study, 4, jax.random.key(0))
    cash = alm.FixedMix([1.0, 0, 0, 0, 0, 0])
    outcome = alm.simulate(study.problem, cash, factors, shocks)
    maturities = np.array([5.0, 30.0, 20.0, 7.0])
    bonds = np.exp(-rate * maturities)
    bonds[2] = np.exp(-(rate - float(factors["inflation"])) * 20.0)
    initial_prices = np.concatenate([[1.0], bonds, np.asarray(factors["equity_levels"])])
    assets = float(np.sum(np.asarray(factors["holdings"]) * initial_prices))
    flows = np.asarray(monthly_cash_flows(factors["liability_cash_flows"]))
    for month in range(horizon):
        assets = assets * np.exp(rate / 12) - flows[month]
    liability_end = _flat_value(factors["liability_cash_flows"], rate, horizon)
    liability_start = _flat_value(factors["liability_cash_flows"], rate, 0)
    surplus = (assets - liability_end) * np.exp(-rate * horizon / 12) / liability_start
    np.testing.assert_allclose(np.asarray(outcome.surplus), surplus, rtol=1e-12)
    np.testing.assert_allclose(np.asarray(outcome.funding_ratio), assets / liability_end, rtol=1e-12)


def test_liability_value_is_linear_in_each_cash_flow_with_its_own_discount_factor():
    study = alm.build_study(40, horizon_months=12)
    tenors = study.market.tenors
    cash_flows = jnp.asarray(study.reported["liability_cash_flows"])
    rates = jnp.full((1, tenors.size), 0.02)

    def value(flows):
        outstanding = alm.outstanding_cash_flows(flows, 12)
        return alm.liability_value_at_dates(outstanding[5], rates, tenors)[0]

    gradient = np.asarray(jax.grad(value)(cash_flows))
    for bucket in (0, 3, len(cash_flows) - 1):
        unit = np.zeros(len(cash_flows))
        unit[bucket] = 1.0
        assert gradient[bucket] == pytest.approx(_flat_value(unit, 0.02, 5), rel=1e-12)
