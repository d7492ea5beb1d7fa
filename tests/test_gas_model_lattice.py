"""The dynamic program on a Gaussian model's factors (`_model_lattice.py`): its expectation is exact
for the tabulated value (Monte Carlo of the model's own step), on one factor it is the
one-factor lattice, on two it approaches the independent dynamic program of `gas_factor_dp.py`,
and the policy started on its targets trades as that program's rule does; the study starts on it
where it values more on the training paths."""

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
import pytest

from finance import gas_storage as gs
from snapo_ode import InputError
from finance.gas_storage._lattice import solve_factor_lattice
from finance.gas_storage._lsmc import inventory_grid
from finance.gas_storage._model import stochastic_scene
from finance.gas_storage._model_lattice import (
    _coordinates,
    _expectation_weights,
    expect,
    interpolate_grid,
    lattice_coordinates,
    lattice_points,
    solve_model_lattice,
)
from finance.gas_storage import _model_study
from finance.gas_storage._model_study import value_on_model
from finance.gas_storage._price_models import OneFactorModel, ThreeFactorSeasonalModel, TwoFactorModel, model_paths
from finance.gas_storage._state_lsmc import fit_state_lsmc
from finance.gas_storage._state_policy import load_state_policy, make_state_policy, simulate_state_policy, state_policy_bytes
from test_gas_factor_dp import SEASON, _dp_case

MODELS = {
    "two-factor": TwoFactorModel(*(jnp.asarray(v) for v in (6.0, 1.2, 0.5, -0.6))),
    "three-factor": ThreeFactorSeasonalModel(*(jnp.asarray(v) for v in (10.0, 1.0, 0.3, 0.4, 40.0))),
}


@pytest.mark.parametrize("name", list(MODELS))
def test_the_expectation_of_the_tabulated_value_is_exact(name):
    """E[V~(z_{t+1}) | X_t] from the axis-by-axis contraction against 400,000 draws of the model's
    step X_{t+1} = a X_t + L eps in the factors themselves (not the lattice's coordinates)."""
    model = MODELS[name]
    k, points = len(model.factor_names), 9
    unit, drift, sd = _coordinates(model)
    axes = jnp.linspace(-3 * sd, 3 * sd, points, axis=-1) * jnp.arange(1, k + 1)[:, None]
    table = jax.random.normal(jax.random.key(0), (points,) * k + (2,))
    expected = expect(_expectation_weights(axes, drift, sd), table)
    node = (2,) + (points // 2,) * (k - 2) + (points - 3,)
    x = unit @ jnp.array([axes[d, i] for d, i in enumerate(node)])
    chol = jnp.linalg.cholesky(model.step_covariance())
    following = model.decay() * x + jax.random.normal(jax.random.key(1), (400_000, k)) @ chol.T
    z = lattice_coordinates(unit, following)
    draws = interpolate_grid(axes, table, z)
    se = draws.std(axis=0) / np.sqrt(draws.shape[0])
    assert np.all(np.abs(draws.mean(axis=0) - expected[node]) < 4 * se), (draws.mean(axis=0), expected[node], se)
    # Not vacuous: the node's own value differs from its expectation by many standard errors.
    assert np.all(np.abs(table[node] - expected[node]) > 20 * se)


def test_on_one_factor_it_is_the_factor_lattice():
    facility, curve = gs.CASES["bdj"]()
    inputs = gs.make_inputs(facility, curve[:60], volatility=0.6018, mean_reversion=18.25)
    scene = stochastic_scene()
    grid = inventory_grid(inputs, scene, 101)
    model = OneFactorModel(jnp.asarray(18.25), jnp.asarray(0.6018))
    lattice = solve_model_lattice(model, inputs, scene, grid, 61, width=6.0)
    reference = solve_factor_lattice(inputs, scene, grid, points=61, width=6.0)
    assert float(lattice.value) == pytest.approx(float(reference.value), rel=1e-11)


@pytest.mark.slow
def test_two_factor_value_approaches_the_independent_dp_and_the_start_trades_near_its_rule():
    """On the ratcheted facility with fuel, costs and discounting (20 days): the lattice's value
    lies within 0.2% of the DP's, closer on the finer grid (the linear interpolation's numerical
    diffusion shrinks), and the policy started on its targets, untrained, earns the DP rule's
    cash to 0.5% (paired, 3 standard errors; the basestock form's own loss under ratchets is
    part of it)."""
    model, inputs, training, evaluation, value, (rule, _) = _dp_case(4_000, 2_000, levels=201, points=41, nodes=9)
    scene = stochastic_scene()
    grid = inventory_grid(inputs, scene, 201)
    coarse, fine = (solve_model_lattice(model, inputs, scene, grid, points) for points in (21, 81))
    assert abs(float(fine.value) - value) < abs(float(coarse.value) - value)
    assert abs(float(fine.value) - value) < 2e-3 * value, (float(fine.value), value)
    policy = make_state_policy(fit_state_lsmc(inputs, scene, grid, training, 2), grid, training, key=jax.random.key(0),
                               lattice=fine)
    difference = np.asarray(eqx.filter_jit(simulate_state_policy)(policy, inputs, scene, evaluation,
                                                                  sharpness=None).value) - rule
    se = difference.std(ddof=1) / np.sqrt(difference.size)
    assert abs(difference.mean()) < 3 * se + 5e-3 * value, (difference.mean(), se, value)


def test_a_policy_started_on_the_lattice_is_written_and_read_back(tmp_path):
    model = MODELS["two-factor"]
    facility, _ = gs.CASES["bdj"]()
    inputs = gs.make_inputs(dict(facility, terminal_inventory_min=0.0), SEASON * 1.0)
    scene = stochastic_scene()
    grid = inventory_grid(inputs, scene, 41)
    paths = model_paths(model, inputs.forward_curve, 200, jax.random.key(3))
    lattice = solve_model_lattice(model, inputs, scene, grid, 11)
    policy = make_state_policy(fit_state_lsmc(inputs, scene, grid, paths, 1), grid, paths, key=jax.random.key(0),
                               lattice=lattice)
    path = tmp_path / "policy.eqx"
    path.write_bytes(state_policy_bytes(policy))
    loaded = load_state_policy(path)
    np.testing.assert_array_equal(loaded.start_logits(inputs, scene, paths), policy.start_logits(inputs, scene, paths))
    assert gs.load_storage_policy(path).lattice is not None


def test_the_study_starts_and_bounds_where_the_training_paths_say(monkeypatch):
    model = MODELS["two-factor"]
    facility, curve = gs.CASES["bdj"]()
    inputs = gs.make_inputs(facility, curve[:30])
    training = model_paths(model, inputs.forward_curve, 1_000, jax.random.key(1))
    evaluation = model_paths(model, inputs.forward_curve, 500, jax.random.key(2))
    monkeypatch.setattr(_model_study, "TRAINING_POOL", 400)
    out = value_on_model(model, inputs, training, evaluation, nodes=41, train_steps=2, rolling_paths=10,
                         dual_paths=50)
    assert out["lattice_points"] is not None and out["lattice_start_in_sample"] is not None
    # The start is chosen on (and SNAPO trains on) the first TRAINING_POOL training paths, the LSMC regressed on all.
    assert out["snapo_train_pool"] == 400 and out["train_paths_available"] == 1_000
    grid, pool = inventory_grid(inputs, stochastic_scene(), 41), training[:400]
    on_lsmc = make_state_policy(fit_state_lsmc(inputs, stochastic_scene(), grid, training), grid, pool,
                                key=jax.random.key(0))
    assert out["lsmc_start_in_sample"] == pytest.approx(
        float(jnp.mean(simulate_state_policy(on_lsmc, inputs, stochastic_scene(), pool, sharpness=None).value)),
        rel=1e-12)
    better = "lattice" if out["lattice_start_in_sample"] > out["lsmc_start_in_sample"] else "lsmc"
    assert out["snapo_start"] == better
    assert (out["policy"].lattice is not None) == (better == "lattice")
    assert better == "lsmc" or out["policy"].lattice.values is None  # the targets only, not the penalty's tables
    # The bound's penalty: the one under which LSMC's pilot gap is smaller, named in the bound's fields.
    gaps = out["penalty_pilot_gaps"]
    assert out["penalty_lattice_points"] is not None
    assert set(gaps) == set(out["penalty_pilot_bounds"]) == {"state", "lattice", "blend"}
    assert out["dual_penalty_choice"] == min(gaps, key=gaps.get) and out["penalty_pilot_gap_difference_se"] > 0
    assert out["penalty_pilot_paths"] == 50 and out["penalty_lattice_levels"] == 41  # no more than the bound's paths
    assert out["dual_penalty"].startswith({"lattice": "factor lattice", "state": "state LSMC",
                                           "blend": "0.5 x state LSMC"}[out["dual_penalty_choice"]])


@pytest.mark.parametrize("fields", [(6.0, 1.2, 0.0, -0.6), (6.0, 0.0, 0.5, -0.6)])
def test_a_degenerate_step_has_no_lattice(fields):
    """A zero volatility: no coordinates to grid, so no lattice (the start is the LSMC's) and a
    direct solve is refused with the reason, before any compile."""
    model = TwoFactorModel(*(jnp.asarray(v) for v in fields))
    facility, curve = gs.CASES["bdj"]()
    inputs = gs.make_inputs(facility, curve[:30])
    scene = stochastic_scene()
    grid = inventory_grid(inputs, scene, 41)
    assert lattice_points(model, inputs, scene, grid) is None
    with pytest.raises(InputError, match="zero variance"):
        solve_model_lattice(model, inputs, scene, grid, 21)
