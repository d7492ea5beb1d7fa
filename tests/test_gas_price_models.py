"""Price models a desk values on: E[spot] = forward by construction (Monte Carlo mean against the
curve), the conditional forward curve against nested simulation and the tower property, the
one-factor model against the built-in spot, and the price-model file's units and refusals."""

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from finance import gas_storage as gs
from finance.gas_storage._price_model_file import load_price_model, sample_price_model
from finance.gas_storage._price_models import PRICE_MODELS, OneFactorModel, model_paths
from snapo_ode import InputError

CURVE = 3.0 + 0.5 * np.cos(2 * np.pi * np.arange(60) / 60)


@pytest.mark.parametrize("name", list(PRICE_MODELS))
def test_mean_spot_is_the_forward_curve(name):
    model = sample_price_model(name)
    paths = model_paths(model, CURVE, 20_000, jax.random.key(3))
    spot = CURVE * np.exp(np.asarray(paths.log_ratio))
    error = (spot.mean(0) - CURVE) / (spot.std(0) / np.sqrt(spot.shape[0]) + 1e-300)
    assert np.abs(error[1:]).max() < 4.5
    assert np.allclose(spot[:, 0], CURVE[0], rtol=1e-14)  # day 0 is known


@pytest.mark.parametrize("name", list(PRICE_MODELS))
def test_conditional_curve_against_nested_simulation_and_tower(name):
    """E_t[S_u] from the closed form against an independent NumPy simulation from day t's
    factors (the step covariance and decay applied by hand), and its mean over day t's
    distribution against the curve (tower property)."""
    model = sample_price_model(name)
    day, n_days = 10, CURVE.size
    paths = model_paths(model, CURVE, 4_000, jax.random.key(5))
    factors_t = np.asarray(paths.factors[:, day])
    conditional = np.asarray(model.conditional_curve(jnp.asarray(factors_t), day, n_days))
    assert np.allclose(conditional[:, :day], 1.0)
    tower = (conditional * CURVE).mean(0)[day:]
    spread = (conditional * CURVE).std(0)[day:] / np.sqrt(factors_t.shape[0])
    assert np.all(np.abs(tower - CURVE[day:]) < 4.5 * spread + 1e-12)
    # Nested: 40,000 continuations of one state.
    decay, covariance = np.asarray(model.decay()), np.asarray(model.step_covariance())
    loadings, variance = np.asarray(model.loadings(n_days)), np.asarray(model.log_variance(n_days))
    rng = np.random.default_rng(0)
    x = np.repeat(factors_t[:1], 40_000, axis=0)
    steps = rng.multivariate_normal(np.zeros(decay.size), covariance, size=(n_days - day, 40_000))
    inner = []
    for u in range(day, n_days):
        inner.append(np.exp(x @ loadings[u] - variance[u] / 2))
        x = decay * x + steps[u - day]
    inner = np.array(inner)  # (T - t, paths)
    se = inner.std(1) / np.sqrt(inner.shape[1])
    assert np.all(np.abs(inner.mean(1) - conditional[0, day:]) < 4.5 * se + 1e-12)


@pytest.mark.parametrize("name", list(PRICE_MODELS))
def test_next_day_moments_match_the_conditional_curve(name):
    model = sample_price_model(name)
    paths = model_paths(model, CURVE, 50, jax.random.key(1))
    mean, sd = model.next_day_moments(paths.factors, CURVE.size)
    for day in (0, 7, 30):
        conditional = model.conditional_curve(paths.factors[:, day], day, CURVE.size)[:, day + 1]
        np.testing.assert_allclose(np.exp(mean[:, day] + sd[day] ** 2 / 2), conditional, rtol=1e-12)
    # The innovations are the shocks that built the paths (standardised, independent of the past).
    eps = np.asarray(model.factor_innovations(paths.factors))[:, :-1]
    assert abs(eps.mean()) < 0.05 and abs(eps.std() - 1) < 0.05


def test_one_factor_model_is_the_built_in_spot():
    facility, curve = gs.CASES["bdj"]()
    inputs = gs.make_inputs(facility, curve[:90], volatility=0.6018, mean_reversion=18.25)
    shocks = jax.random.normal(jax.random.key(2), (30, 90))
    built_in, _ = gs.spot_prices(inputs, shocks)
    model = OneFactorModel(jnp.asarray(18.25), jnp.asarray(0.6018))
    paths = model.simulate(inputs.forward_curve, shocks[..., None])
    np.testing.assert_allclose(inputs.forward_curve * jnp.exp(paths.log_ratio), built_in, rtol=1e-13)


def test_shipped_one_factor_file_is_bdj_low_volatility():
    model = sample_price_model("one-factor")
    assert float(model.mean_reversion) == pytest.approx(gs.BDJ_MEAN_REVERSION, rel=1e-12)
    assert float(model.volatility) == pytest.approx(0.0315 * np.sqrt(365), rel=1e-12)


@pytest.mark.parametrize("text, message", [
    ("model: four-factor\n", "line 1: model = 'four-factor'; allowed: one-factor"),
    ("model: one-factor\nmean_reversion: 2 /week\nvolatility: 0.5\n", "line 2: mean_reversion = '2 /week': unknown unit"),
    ("model: one-factor\nmean_reversion: 2\nvolatility: 12 /sqrt(yr)\n", "line 3: volatility = '12 /sqrt(yr)' (12 in"),
    ("model: one-factor\nmean_reversion: 2\n", "volatility is missing"),
    ("model: two-factor\nshort_mean_reversion: 2\nshort_volatility: 0.5\nlong_volatility: 0.1\ncorrelation: 1.5\n",
     "line 5: correlation = 1.5"),
    ("model: one-factor\nmean_reversion: 2\nvolatility: 0.5\nspeed: 3\n", "line 4: speed is no parameter"),
    ("model: one-factor\nmean_reversion: .nan\nvolatility: 0.5\n", "mean_reversion = nan"),
])
def test_price_model_file_refusals(tmp_path, text, message):
    path = tmp_path / "model.yaml"
    path.write_text(text)
    with pytest.raises(InputError, match=None) as error:
        load_price_model(path)
    assert message in str(error.value) and str(path) in str(error.value) and "\n" not in str(error.value)


def _ratcheted_month():
    """A 30-day ratcheted facility with fuel and costs, the stochastic scene and a 41-level grid."""
    from finance.gas_storage._lsmc import inventory_grid
    from finance.gas_storage._model import stochastic_scene

    facility = dict(capacity=10_000.0, initial_inventory=3_000.0, terminal_inventory_min=3_000.0,
                    max_injection=1_500.0, max_withdrawal=2_500.0, injection_ratchet=[[0.0, 1.0], [1.0, 0.6]],
                    withdrawal_ratchet=[[0.0, 0.5], [1.0, 1.0]], fuel_loss=0.01, injection_cost=0.01,
                    withdrawal_cost=0.01, rate=0.05)
    inputs = gs.make_inputs(facility, CURVE[:30])
    scene = stochastic_scene()
    return inputs, scene, inventory_grid(inputs, scene, 41)


def test_penalty_fitted_in_the_lsmc_pass_equals_the_penalty_replayed_on_the_frozen_rule():
    """`fit_state_lsmc_and_penalty` (one backward pass, as `snapo gas --price-model` runs it) gives
    the LSMC of `fit_state_lsmc` and the penalty of `fit_state_penalty` replaying that rule on the
    same paths; the penalty is zero on the last day and not zero before (not vacuous)."""
    from finance.gas_storage._state_lsmc import fit_state_lsmc
    from finance.gas_storage._state_penalty import fit_state_lsmc_and_penalty, fit_state_penalty

    inputs, scene, grid = _ratcheted_month()
    model = sample_price_model("two-factor")
    paths = model_paths(model, inputs.forward_curve, 600, jax.random.key(5))
    fit, penalty = fit_state_lsmc_and_penalty(model, inputs, scene, grid, paths, 2)
    alone = fit_state_lsmc(inputs, scene, grid, paths, 2)
    np.testing.assert_array_equal(fit.coefficients, alone.coefficients)
    np.testing.assert_array_equal(fit.values, alone.values)
    replayed = fit_state_penalty(alone, model, inputs, scene, grid, paths)
    scale = np.abs(np.asarray(replayed.coefficients)).max()
    np.testing.assert_allclose(penalty.coefficients, replayed.coefficients, rtol=0, atol=1e-12 * scale)
    assert np.all(np.asarray(penalty.coefficients)[-1] == 0.0)
    assert scale > 0


def test_a_days_decisions_from_the_coefficients_equal_those_from_the_continuation():
    """`level_decisions(..., regressors=basis)` (the state LSMC's backward pass: the coefficients
    interpolated, then multiplied) decides and credits as the same continuation given per path,
    to round-off, on a ratcheted facility mid-contract; the credited value is not the decided
    one (`later` differs from the continuation), so both outputs are checked."""
    from finance.gas_storage._lsmc import level_decisions
    from finance.gas_storage._model import inventory_floor, spot_prices
    from finance.gas_storage._state_lsmc import fit_state_lsmc

    inputs, scene, grid = _ratcheted_month()
    paths = model_paths(sample_price_model("two-factor"), inputs.forward_curve, 400, jax.random.key(6))
    fit = fit_state_lsmc(inputs, scene, grid, paths, 2)
    day = 12
    basis = fit.basis(paths.state())[:, day]
    coefficients = fit.coefficients[day]
    price = spot_prices(inputs, paths)[0][:, day]
    floor_tomorrow = inventory_floor(inputs, scene, None)[day + 1]
    later = basis @ coefficients + 50.0 * jax.random.normal(jax.random.key(7), (paths.shape[0], grid.nodes))
    per_path = level_decisions(inputs, scene, grid, price, day, floor_tomorrow, basis @ coefficients, later)
    from_coefficients = level_decisions(inputs, scene, grid, price, day, floor_tomorrow, coefficients, later,
                                        regressors=basis)
    scale = float(np.abs(np.asarray(per_path[1])).max())
    for expected, got in zip(per_path, from_coefficients):
        np.testing.assert_allclose(got, expected, rtol=0, atol=1e-9 * scale)
    assert float(np.abs(np.asarray(per_path[0] - per_path[1])).max()) > 1.0
