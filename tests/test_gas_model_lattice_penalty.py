"""The dual bound's penalty from the factor lattice's value (`_model_lattice_penalty.py`): of
conditional mean zero under the model (Monte Carlo of the model's own step), a valid bound above
an independent dynamic program on the two factors and its rule path by path, tighter there than
the state LSMC's penalty, and its blend with that penalty valid and below the two bounds' mean; its
points fit the memory budget."""

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from finance import gas_storage as gs
from finance.gas_storage import _model_lattice_penalty
from finance.gas_storage._lsmc import InventoryGrid, inventory_grid
from finance.gas_storage._model import Schedule, stochastic_scene
from finance.gas_storage._model_lattice import (
    ModelLattice,
    _coordinates,
    interpolate_grid,
    lattice_coordinates,
    solve_model_lattice,
)
from finance.gas_storage._model_lattice_penalty import ModelLatticePenalty, penalty_lattices
from finance.gas_storage._penalty import BlendedPenalty
from finance.gas_storage._price_models import TwoFactorModel
from finance.gas_storage._state_lsmc import run_state_lsmc
from finance.gas_storage._state_penalty import fit_state_lsmc_and_penalty
from test_gas_factor_dp import _dp_case
from test_gas_model_lattice import MODELS


@pytest.mark.parametrize("own_grid", [False, True])
@pytest.mark.parametrize("name", list(MODELS))
def test_the_penalty_has_conditional_mean_zero(name, own_grid):
    """w_t = V~(z_{t+1}) - E[V~(z_{t+1}) | z_t] at an off-grid state, over 400,000 draws of the
    model's step in the factors: mean zero within 4 standard errors at every level, while V~(z_{t+1})
    alone is many standard errors from zero (the expectation is what cancels it). `own_grid`: the
    tables on 3 levels read at the 7 of a finer grid the bound takes."""
    model = MODELS[name]
    k, points, levels = len(model.factor_names), 9, 3
    unit, _, sd = _coordinates(model)
    axes = jnp.linspace(-3 * sd, 3 * sd, points, axis=-1) * jnp.arange(1, k + 1)[:, None]
    values = jax.random.normal(jax.random.key(0), (2,) + (points,) * k + (levels,)) + 5.0
    grids = (InventoryGrid(3.0, levels, np.arange(2)), InventoryGrid(1.0, 7, np.arange(2))) if own_grid else ()
    penalty = ModelLatticePenalty(model, ModelLattice(unit, axes, None, None, None, values), *grids)
    levels = 7 if own_grid else levels
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
    assert np.all(np.abs(tabulated.mean(axis=0)) > 20 * se.max())  # not vacuous
    if own_grid:  # at the levels both grids share, the tables' own penalty
        coarse = ModelLatticePenalty(model, ModelLattice(unit, axes, None, None, None, values))
        np.testing.assert_allclose(w[:, ::3], coarse.today((z_today, lattice_coordinates(unit, following),
                                                            jnp.asarray(0))), rtol=1e-12, atol=1e-12)
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
    out, incumbent, blend = (_model_study._bound(penalty, inputs, scene, grid, evaluation, policies, 300, False)
                             for penalty in (lattice, state, BlendedPenalty(state, lattice, 0.5)))
    assert out["dual_penalty"].startswith("factor lattice value")
    assert not [w for w in out["bound_warnings"] if "not certified" in w]
    tolerance = 2e-3 * value  # the DP's grids
    assert out["dual_upper_bound"] >= value - 3 * out["dual_upper_bound_se"] - tolerance
    assert out["dp_rule_gap"] >= -3 * out["dp_rule_gap_se"]
    assert out["dual_upper_bound"] < incumbent["dual_upper_bound"] - 2 * out["dual_upper_bound_se"]
    # The blend: a valid bound too, and (the bound convex in the penalty, path by path on the same
    # grids) at most the blend of the two bounds.
    assert blend["dual_penalty"].startswith("0.5 x state LSMC value + 0.5 x factor lattice value")
    assert blend["dual_upper_bound"] >= value - 3 * blend["dual_upper_bound_se"] - tolerance
    assert not [w for w in blend["bound_warnings"] if "not certified" in w]
    assert blend["dual_upper_bound"] <= (out["dual_upper_bound"] + incumbent["dual_upper_bound"]) / 2 + 1e-9 * value


def test_the_penalty_lattices_share_the_start_or_try_the_memory_on_the_factors(monkeypatch):
    """The start's points on the LSMC's grid where they fit; else the most that fit there and on
    a grid of one level to a day's flow (bdj: a day's injection after fuel a little under 1/100
    of capacity: 102 levels), each of at least the fewest allowed; none for a degenerate model."""
    facility, curve = gs.CASES["bdj"]()
    inputs, scene = gs.make_inputs(facility, curve[:30]), stochastic_scene()
    grid = inventory_grid(inputs, scene, 401)
    model = MODELS["two-factor"]
    assert penalty_lattices(model, inputs, scene, grid, 61) == [(61, grid)]
    assert penalty_lattices(model, inputs, scene, grid, None) == [(101, grid)]  # the most, on the LSMC's grid
    # 30 days x 401 levels x 61^2 > 2e7: G = 39 there (odd), and 30 x 102 x G^2 <= 2e7: 80, odd 79.
    monkeypatch.setattr(_model_lattice_penalty, "PENALTY_TABLE_SIZE", 2e7)
    (fine, on_grid), (points, own) = penalty_lattices(model, inputs, scene, grid, 61)
    assert (fine, points, own.nodes) == (39, 79, 102) and on_grid is grid
    assert own.spacing == pytest.approx(float(inputs.capacity) / 101)
    monkeypatch.setattr(_model_lattice_penalty, "PENALTY_TABLE_SIZE", 30 * 102 * 10.0 ** 2)
    assert [(p, g.nodes) for p, g in penalty_lattices(model, inputs, scene, grid, 61)] == [(9, 102)]
    monkeypatch.setattr(_model_lattice_penalty, "PENALTY_TABLE_SIZE", 30 * 102 * 8.0 ** 2)
    assert penalty_lattices(model, inputs, scene, grid, 61) == []
    degenerate = TwoFactorModel(*(jnp.asarray(v) for v in (6.0, 1.2, 0.0, -0.6)))
    assert penalty_lattices(degenerate, inputs, scene, grid, None) == []
