"""The liabilities valued as an actuary values them: each cash flow discounted at its own date on
the interpolated curve (against a NumPy loop written from docs/alm.md), their key-rate
sensitivities through the interpolation weights (the bucketed PV01) and the funding ratio's, by
adjoint against central bumps of the key rates in float64, the same valuation inside the
scenarios, and the duration liability matching hedges."""

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from finance import alm
from references import alm_balance_sheet, alm_liability_value
from snapo_ode import central_differences


@pytest.fixture(scope="module")
def study():
    """A fund whose flows run past the last key tenor (60 years) and start before the first (3
    months), with every effect on (half the benefits indexed)."""
    return alm.build_study(40, horizon_months=6)


def _value(study, key_rates):
    factors = {**study.fixed, **study.reported, "key_rates": key_rates}
    return alm.initial_values(study.problem, factors)[1]


def test_each_flow_is_discounted_at_its_own_date_on_the_interpolated_curve(study):
    rates = np.asarray(study.reported["key_rates"])
    bent = rates + 0.01 * np.sin(np.arange(rates.size))  # a curve with kinks between the tenors
    for key_rates in (rates, bent):
        assert float(_value(study, jnp.asarray(key_rates))) == pytest.approx(
            alm_liability_value(study, key_rates), rel=1e-13)
    nominal = alm.build_study(40, horizon_months=6, without=("inflation_indexation",))
    assert float(_value(nominal, jnp.asarray(bent))) == pytest.approx(alm_liability_value(nominal, bent), rel=1e-13)


def test_the_value_does_not_depend_on_where_the_key_tenors_sit_on_a_flat_curve(study):
    """With every key rate equal the interpolated curve is flat wherever the tenors are: the value
    is the flat closed form (the cash-flow mapping moved with the tenors)."""
    factors = {k: np.asarray(v) for k, v in {**study.fixed, **study.reported}.items()}
    flows = np.asarray(study.problem.schedule.monthly(factors["liability_cash_flows"]))
    tau = np.arange(1, flows.size + 1) / 12
    closed_form = np.sum(flows * np.exp(-0.03 * tau))
    for tenors in (study.market.tenors, np.array([1.0, 7.0, 25.0]), np.array([10.0])):
        outstanding = alm.outstanding_cash_flows(factors["liability_cash_flows"], 0, study.problem.schedule)[0]
        value = alm.liability_value_at_dates(outstanding, jnp.full((1, tenors.size), 0.03), tenors)[0]
        assert float(value) == pytest.approx(closed_form, rel=1e-13)


def test_key_rate_sensitivities_of_the_liabilities_and_funding_ratio_equal_central_bumps(study):
    rates = jnp.asarray(study.reported["key_rates"])

    def funding_ratio(key_rates):
        assets, liabilities = alm.initial_values(study.problem, {**study.fixed, **study.reported,
                                                                 "key_rates": key_rates})
        return assets / liabilities

    for fn in (lambda r: _value(study, r), funding_ratio):
        adjoint = np.asarray(jax.grad(fn)(rates))
        bumped = np.asarray(central_differences(fn, rates, relative_step=1e-6))
        np.testing.assert_allclose(adjoint, bumped, rtol=1e-7, atol=1e-9 * np.abs(bumped).max())
    # The bucketed PV01: dL/dr_k = -sum_j tau_j w_jk L_j, each flow's PV through its interpolation weights.
    factors = {k: np.asarray(v) for k, v in {**study.fixed, **study.reported}.items()}
    flows = np.asarray(study.problem.schedule.monthly(factors["liability_cash_flows"]))
    tau = alm.cash_flow_maturities(flows.size)
    weights = alm.interpolation_weights(tau, study.market.tenors)
    f = study.problem.config.indexation
    present = flows * np.exp(-(weights @ factors["key_rates"]) * tau) * (1 - f + f * np.exp(factors["inflation"] * tau))
    np.testing.assert_allclose(np.asarray(jax.grad(lambda r: _value(study, r))(rates)),
                               -(present * tau) @ weights, rtol=1e-12)


def test_the_liabilities_inside_the_scenarios_are_valued_at_each_flows_date(study):
    """Month by month on a path, the simulation's liability value equals the NumPy loop on that
    path's curve, price index and inflation."""
    shocks = alm.scenarios(study, 3, jax.random.key(1))
    factors = {**study.fixed, **study.reported}
    policy = alm.FixedMix(np.full(6, 1 / 6))
    path = alm.simulate(study.problem, policy, factors, shocks, smooth_constraints=False, trajectory=True).trajectory
    state = alm.MarketState(jnp.broadcast_to(factors["key_rates"], (3, study.market.n_tenors)),
                            factors["inflation"] * jnp.ones(3), jnp.ones(3), factors["spread"] * jnp.ones(3))
    for month in range(study.problem.horizon_months + 1):
        for p in range(3):
            expected = alm_liability_value(study, np.asarray(state.key_rates[p]), month=month,
                                           cpi=float(state.cpi[p]), inflation=float(state.inflation[p]))
            assert float(path.liabilities[month, p]) == pytest.approx(expected, rel=1e-12)
        if month < study.problem.horizon_months:
            state = alm.next_market(state, shocks[month], factors, study.market, True)


def test_liability_matching_hedges_the_duration_as_valued(study):
    """The duration is -dL/ds / L for a parallel shift, as valued (the indexed share included):
    central bumps of the NumPy balance sheet; the mix puts it between the nominal classes."""
    rates = np.asarray(study.reported["key_rates"])
    h = 1e-6
    slope = (alm_balance_sheet(study, rates + h)[1] - alm_balance_sheet(study, rates - h)[1]) / (2 * h)
    duration = alm.liability_duration(study)
    assert duration == pytest.approx(-slope / alm_balance_sheet(study)[1], rel=1e-8)
    weights = np.asarray(alm.baselines(study)["liability_matching"].weights)
    short, long = 5.0, 30.0
    assert (weights[1] * short + weights[2] * long) / (weights[1] + weights[2]) == pytest.approx(duration, rel=1e-12)


def test_the_cash_flow_mapping_kept_for_comparison_overvalues_by_convexity(study):
    """`key_rate_profile` splits each flow onto its two key tenors keeping its amount and, inside
    the tenors, its mean maturity; discounted there (`liability_value`) it is worth at least the
    flow at its own date on a flat curve (exp(-r tau) is convex in tau), more where it spans more."""
    factors = {k: np.asarray(v) for k, v in {**study.fixed, **study.reported}.items()}
    tenors = study.market.tenors
    profile = np.asarray(alm.key_rate_profile(factors["liability_cash_flows"], study.market, 0)[0])
    flows = np.asarray(study.problem.schedule.monthly(factors["liability_cash_flows"]))
    tau = np.clip(alm.cash_flow_maturities(flows.size), tenors[0], tenors[-1])
    assert profile.sum() == pytest.approx(flows.sum(), rel=1e-13)
    assert profile @ tenors == pytest.approx(flows @ tau, rel=1e-13)
    outstanding = alm.outstanding_cash_flows(factors["liability_cash_flows"], 0)[0]
    rates = jnp.full((1, tenors.size), 0.03)
    mapped = float(alm.liability_value(jnp.asarray(profile), rates, tenors)[0])
    at_dates = float(alm.liability_value_at_dates(outstanding, rates, tenors)[0])
    assert mapped == pytest.approx(profile @ np.exp(-0.03 * tenors), rel=1e-13)
    assert mapped > at_dates == pytest.approx(np.sum(flows * np.exp(-0.03 * alm.cash_flow_maturities(flows.size))),
                                              rel=1e-13)
