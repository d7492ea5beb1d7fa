"""The basestock head's start from the factor lattice: its targets are where the lattice's own
rule moves (the rule maximises over every candidate inventory of every path and day, an
independent argmax), so the untrained policy trades as the rule does, ratchets, fuel, costs
and discounting included; the start is written and read back; a study reports it."""

import jax
import numpy as np
import pytest

from finance import gas_storage as gs
from finance.gas_storage._family import curve, facility
from finance.gas_storage._lattice_start import lattice_start
from finance.gas_storage._lsmc import inventory_grid


def contract(kind: str, shape: str, days: int = 60):
    return gs.make_inputs(facility(kind, 3), curve(shape, days, 3), volatility=1.0, mean_reversion=18.25)


def started(inputs, scene, nodes: int = 101):
    grid = inventory_grid(inputs, scene, nodes)
    lattice = gs.solve_factor_lattice(inputs, scene, grid, points=100)
    # The correction the network adds starts at zero: the untrained policy is its start.
    policy = gs.make_policy(scene, inputs, key=jax.random.key(0), head="basestock",
                            start=lattice_start(lattice, inputs, scene, grid))
    assert not np.any(np.asarray(policy.mlp.layers[-1].weight))
    return policy, lattice, grid


@pytest.mark.parametrize("kind, shape", [("fast", "spikes"), ("everything", "holidays"), ("ratchets", "weekly")])
def test_the_started_policy_trades_as_the_lattice_rule(kind, shape):
    inputs, scene = contract(kind, shape), gs.stochastic_scene()
    policy, lattice, grid = started(inputs, scene)
    shocks = jax.random.normal(jax.random.key(1), (1000, inputs.n_days))
    rule = gs.run_lattice_policy(lattice, inputs, scene, grid, gs.spot_prices(inputs, shocks)[0])
    basestock = gs.simulate(policy, inputs, scene, sharpness=None, shocks=shocks)
    moved = np.abs(np.asarray(basestock.inventory - rule.inventory))
    assert moved.mean() < grid.spacing  # on average within one level of the rule's inventory
    difference = np.asarray(basestock.value - rule.value)
    assert abs(difference.mean()) < 4 * difference.std() / np.sqrt(difference.size)
    assert abs(difference.mean()) < 5e-3 * float(np.mean(rule.value))


def test_targets_are_ordered_and_inside_the_feasible_range():
    from finance.gas_storage._lattice_start import lattice_targets

    inputs, scene = contract("everything", "spikes"), gs.stochastic_scene()
    grid = inventory_grid(inputs, scene, 101)
    _, low, high = lattice_targets(gs.solve_factor_lattice(inputs, scene, grid, points=100), inputs, scene, grid)
    floor = np.asarray(gs.inventory_floor(inputs, scene, None))[1:, None]
    ceiling = np.asarray(gs.inventory_ceiling(inputs, scene, None))[1:, None]
    slack = 1e-6 * grid.spacing
    assert np.all(np.asarray(low) <= np.asarray(high))
    assert np.all(np.asarray(low) >= floor - slack) and np.all(np.asarray(high) <= ceiling + slack)
    # Cheap spot (the lowest factor level): fill up; dear spot (the highest): empty down.
    assert np.mean(np.asarray(low)[:, 0] > np.asarray(low)[:, -1]) > 0.5


def test_a_started_policy_is_written_and_read_back(tmp_path):
    inputs, scene = contract("fuel_costs", "contango", days=40), gs.stochastic_scene()
    policy, _, _ = started(inputs, scene)
    path = tmp_path / "policy.eqx"
    path.write_bytes(gs.storage_policy_bytes(policy))
    loaded = gs.load_storage_policy(path)
    assert loaded.start_table.shape == (40, 100, 2)
    shocks = jax.random.normal(jax.random.key(3), (4, inputs.n_days))
    np.testing.assert_array_equal(gs.simulate(loaded, inputs, scene, sharpness=None, shocks=shocks).value,
                                  gs.simulate(policy, inputs, scene, sharpness=None, shocks=shocks).value)


def test_a_study_reports_its_start_and_a_bad_start_is_refused():
    from snapo_ode import InputError

    inputs = contract("fast", "seasonal", days=30)
    study = gs.run_study(inputs, gs.StudySettings(stochastic=True, paths=200, train_paths=64, train_steps=5,
                                                  repeats=1, progress=False))
    assert study.start == "lattice" and study.start_value_hard is not None and study.start_seconds > 0
    assert study.to_json()["start"] == "lattice"
    assert gs.StudySettings(stochastic=True, start="intrinsic").start == "intrinsic"
    with pytest.raises(InputError, match="start"):
        gs.StudySettings(stochastic=True, start="lsmc")
