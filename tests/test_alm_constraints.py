"""The fund's choices of constraint and shortfall measure: a turnover limit that trades exactly
the limit beyond it (and whose smooth form's sensitivities equal central bumps), and the squared
or linear shortfall penalty, each against a direct computation from the fund's month-by-month
funding ratio."""

import jax
import numpy as np
import pytest

from finance import alm
from finance.alm._model import limited_weights
from snapo_ode import InputError, bump_and_revalue, max_relative_difference, value_and_sensitivities


def test_the_turnover_limit_trades_the_whole_move_within_it_and_the_limit_beyond(key):
    held = jax.random.dirichlet(key, np.ones(6), (200,))
    target = jax.random.dirichlet(jax.random.fold_in(key, 1), np.ones(6), (200,))
    turnover = np.abs(np.asarray(target - held)).sum(axis=1)
    for limit in (0.1, 0.5, 2.0):
        traded = np.asarray(limited_weights(held, target, limit, None))
        np.testing.assert_allclose(np.abs(traded - np.asarray(held)).sum(axis=1), np.minimum(turnover, limit), rtol=1e-12)
        np.testing.assert_allclose(traded.sum(axis=1), 1.0, rtol=1e-14)
    within = turnover <= 0.5
    np.testing.assert_allclose(np.asarray(limited_weights(held, target, 0.5, None))[within], np.asarray(target)[within],
                               rtol=1e-12, atol=1e-15)


def _study(**config):
    return alm.build_study(20, horizon_months=12, config=alm.ALMConfig(**config))


def test_a_binding_turnover_limits_sensitivities_equal_central_bumps():
    study = _study(max_turnover=0.05)
    shocks = alm.scenarios(study, 16, jax.random.key(3))
    policy = alm.NeuralRebalancing(study.market, key=jax.random.key(4))
    fn = alm.objective_of_reported(study.problem, study.fixed)
    value, gradient = jax.jit(lambda r: value_and_sensitivities(fn, r, policy, shocks))(study.reported)
    assert max_relative_difference(gradient, bump_and_revalue(fn, study.reported, policy, shocks,
                                                              relative_step=1e-6)) <= 1e-6
    free = _study()
    assert float(value) != pytest.approx(float(alm.objective_of_reported(free.problem, free.fixed)(
        free.reported, policy, shocks)), rel=1e-6)  # the limit binds


@pytest.mark.parametrize("measure, power", [("squared", 2), ("linear", 1)])
def test_the_shortfall_penalty_is_the_chosen_measure_of_the_monthly_shortfalls(measure, power):
    base = _study()
    factors = {**base.fixed, **base.reported}
    factors["holdings"] = np.asarray(factors["holdings"]) * 0.9 / 1.1  # underfunded, so the floor binds
    study = alm.build_study(20, horizon_months=12, config=alm.ALMConfig(shortfall_measure=measure), factors=factors)
    shocks = alm.scenarios(study, 64, jax.random.key(5))
    policy = alm.NeuralRebalancing(study.market, key=jax.random.key(6))
    outcome = alm.simulate(study.problem, policy, factors, shocks, smooth_constraints=False, trajectory=True)
    path = outcome.trajectory
    funding = np.asarray(path.assets / path.liabilities)[:-1]  # each month's start
    config = study.problem.config
    expected = config.floor_penalty / 12 * np.sum(np.maximum(config.funding_floor - funding, 0.0) ** power, axis=0)
    assert np.max(expected) > 0
    np.testing.assert_allclose(np.asarray(outcome.shortfall_penalty), expected, rtol=1e-12, atol=1e-15)


def test_bad_choices_are_refused():
    with pytest.raises(InputError, match="shortfall_measure"):
        alm.ALMConfig(shortfall_measure="cubic")
    with pytest.raises(InputError, match="max_turnover"):
        alm.ALMConfig(max_turnover=0.0)
