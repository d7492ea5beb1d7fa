"""The dual bound's penalty from the factor lattice's value (`_model_lattice_penalty.py`): of
conditional mean zero under the model (Monte Carlo of the model's own step), a valid bound above
an independent dynamic program on the two factors and its rule path by path, tighter there than
the state LSMC's penalty; its points fit the memory budget."""

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from finance import gas_storage as gs
from finance.gas_storage import _model_lattice_penalty
from finance.gas_storage._lsmc import inventory_grid
from finance.gas_storage._model import Schedule, stochastic_scene
from finance.gas_storage._model_lattice import (
    ModelLattice,
    _coordinates,
    interpolate_grid,
    lattice_coordinates,
    solve_model_lattice,
)
from finance.gas_storage._model_lattice_penalty import ModelLatticePenalty, penalty_points
from finance.gas_storage._price_models import TwoFactorModel
from finance.gas_storage._state_lsmc import run_state_lsmc
from finance.gas_storage._state_penalty import fit_state_lsmc_and_penalty
from test_gas_factor_dp import _dp_case
from test_gas_model_lattice import MODELS


@pytest.mark.parametrize("name", list(MODELS))
def test_the_penalty_has_conditional_mean_zero(name):
    """w_t = V~(z_{t+1}) - E[V~(z_{t+1}) | z_t] at an off-grid state, over 400,000 draws of the
    model's step in the factors: mean zero within 4 standard errors at every level, while V~(z_{t+1})
    alone is many standard errors from zero (the expectation is what cancels it)."""
    model = MODELS[name]
    k, points, levels = len(model.factor_names), 9, 3
    unit, _, sd = _coordinates(model)
    axes = jnp.linspace(-3 * sd, 3 * sd, points, axis=-1) * jnp.arange(1, k + 1)[:, None]
    values = jax.random.normal(jax.random.key(0), (2,) + (points,) * k + (levels,)) + 5.0
    penalty = ModelLatticePenalty(model, ModelLattice(unit, axes, None, None, None, values))
    x = unit @ (0.37 * axes[:, -2])  # between nodes
    draws = 400_000
    following = model.decay() * x + jax.random.normal(jax.random.key(1), (draws, k)) @ jnp.linalg.cholesky(
        model.step_covariance()).T
    z_today = jnp.broadcast_to(lattice_coordinates(unit, x[None]), (draws, k))
    w = np.asarray(penalty.today((z_today, lattice_coordinates(unit, following), jnp.asarray(0))))
    se = w.std(axis=0) / np.sqrt(draws)
    assert w.shape == (draws, levels)
    assert np.all(np.abs(w.mean(axis=0)) < 4 * se), (w.mean(axis=0), se)
    tabulated = np.asarray(interpolate_grid(axes, values[1], lattice_coordinates(unit, following)))
    assert np.all(np.abs(tabulated.mean(axis=0)) > 20 * se)  # not vacuous
    last = penalty.today((z_today[:3], lattice_coordinates(unit, following[:3]), jnp.asarray(1)))
    np.testing.assert_array_equal(last, 0.0)  # nothing after the last day


def test_on_a_ratcheted_facility_the_lattice_penalty_bounds_the_dp_tighter_than_the_state_penalty():
    """The two-factor DP of `gas_factor_dp.py` (ratchets, fuel, costs, discounting): the bound with
    the lattice's penalty lies above the DP's value and, path by path with the penalty, above the
    DP's rule and LSMC (`certify`); and below the bound with the state LSMC's penalty, paired on
    the same paths."""
    from finance.gas_storage import _model_study

    model, inputs, training, evaluation, value, (cash, inventory) = _dp_case(1_000, 300, levels=201, points=21,
                                                                              nodes=7)
    scene = stochastic_scene()
    grid = inventory_grid(inputs, scene, 51)
    fit, state = fit_state_lsmc_and_penalty(model, inputs, scene, grid, training, 2)
    lattice = ModelLatticePenalty(model, solve_model_lattice(model, inputs, scene, grid, 41, keep_values=True))
    policies = {"dp_rule": Schedule(jnp.asarray(cash), None, None, jnp.asarray(inventory)),
                "lsmc": run_state_lsmc(fit, inputs, scene, grid, evaluation)}
    out, incumbent = (_model_study._bound(penalty, inputs, scene, grid, evaluation, policies, 300, False)
                      for penalty in (lattice, state))
    assert out["dual_penalty"].startswith("factor lattice value")
    assert not [w for w in out["bound_warnings"] if "not certified" in w]
    tolerance = 2e-3 * value  # the DP's grids
    assert out["dual_upper_bound"] >= value - 3 * out["dual_upper_bound_se"] - tolerance
    assert out["dp_rule_gap"] >= -3 * out["dp_rule_gap_se"]
    assert out["dual_upper_bound"] < incumbent["dual_upper_bound"] - 2 * out["dual_upper_bound_se"]


def test_the_penalty_lattice_shares_the_start_points_where_its_tables_fit(monkeypatch):
    facility, curve = gs.CASES["bdj"]()
    inputs = gs.make_inputs(facility, curve[:30])
    grid = inventory_grid(inputs, stochastic_scene(), 41)
    model = MODELS["two-factor"]
    assert penalty_points(model, inputs, grid, 61) == 61
    assert penalty_points(model, inputs, grid, None) == 101
    # 30 days x 41 levels x G^2 <= 2e6: G = 39, odd; below the fewest allowed: none.
    monkeypatch.setattr(_model_lattice_penalty, "PENALTY_TABLE_SIZE", 2e6)
    assert penalty_points(model, inputs, grid, 61) == 39
    monkeypatch.setattr(_model_lattice_penalty, "PENALTY_TABLE_SIZE", 30 * 41 * 8.0 ** 2)
    assert penalty_points(model, inputs, grid, 61) is None
    assert penalty_points(TwoFactorModel(*(jnp.asarray(v) for v in (6.0, 1.2, 0.0, -0.6))), inputs, grid, None) is None
