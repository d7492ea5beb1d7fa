"""The basestock head: its ceiling against the closed form, the warm start reproduces the
intrinsic LP, the hard evaluation is feasible for any targets and moves to a target at the
largest feasible rate (bang-bang up to the target), its deltas equal central bumps, its per-head
training defaults, and a trained policy written and read back."""

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
import pytest

import snapo_ode
from finance import gas_storage as gs
from finance.gas_storage._cases import BDJ_MEAN_REVERSION, BDJ_VOLATILITY, CASES
from finance.gas_storage._study import constraint_violation


def bdj(volatility=BDJ_VOLATILITY["low"]):
    facility, curve = CASES["bdj"]()
    return gs.make_inputs(facility, curve, volatility=volatility, mean_reversion=BDJ_MEAN_REVERSION)


def test_ceiling_is_the_withdrawable_level_on_bdj():
    inputs = bdj()
    days_left = inputs.n_days - np.arange(inputs.n_days + 1)
    expected = np.minimum(250_000.0, 100_000.0 + 7_500.0 * days_left)
    np.testing.assert_allclose(gs.inventory_ceiling(inputs, gs.stochastic_scene(), None), expected)


@pytest.mark.parametrize("case", ["sample", "bdj", "peaking_winter_spike"])
def test_warm_start_follows_the_intrinsic_schedule(case):
    facility, curve = CASES[case]()
    inputs = gs.make_inputs(facility, curve)
    scene = gs.deterministic_scene()
    lp = gs.solve_intrinsic(inputs, scene)
    policy = gs.make_policy(scene, inputs, key=jax.random.key(0), head="basestock", intrinsic_inventory=lp.inventory)
    assert isinstance(policy, gs.BasestockPolicy)
    policy = eqx.tree_at(lambda p: p.mlp.layers[-1].weight, policy, jnp.zeros_like(policy.mlp.layers[-1].weight))
    run = gs.simulate(policy, inputs, scene, sharpness=None)
    assert float(run.value) == pytest.approx(lp.value, rel=1e-3)
    assert constraint_violation(run, inputs, 1 - float(inputs.fuel_loss)) < 1e-6 * float(inputs.capacity)


def test_hard_evaluation_is_feasible_for_any_targets(key):
    facility, curve = CASES["peaking_winter_spike"]()  # ratchets, fuel loss, costs, discounting
    inputs = gs.make_inputs(facility, curve, volatility=1.0, mean_reversion=5.0)
    scene = gs.stochastic_scene()
    policy = gs.make_policy(scene, inputs, key=key, head="basestock", spot_scale=0.3)
    # Large random weights: targets that jump between the bounds from day to day.
    policy = eqx.tree_at(lambda p: p.mlp.layers[-1].weight, policy,
                         5.0 * jax.random.normal(key, policy.mlp.layers[-1].weight.shape))
    shocks = jax.random.normal(jax.random.key(1), (64, inputs.n_days))
    run = gs.simulate(policy, inputs, scene, sharpness=None, shocks=shocks)
    assert constraint_violation(run, inputs, 1 - float(inputs.fuel_loss)) < 1e-6 * float(inputs.capacity)


def test_hard_deltas_equal_central_bumps(key):
    inputs = bdj(BDJ_VOLATILITY["high"])
    scene = gs.stochastic_scene()
    policy = gs.make_policy(scene, inputs, key=key, head="basestock", spot_scale=0.3,
                            intrinsic_inventory=gs.solve_intrinsic(inputs, gs.deterministic_scene()).inventory)
    policy = eqx.tree_at(lambda p: p.mlp.layers[-1].weight, policy,
                         jax.random.normal(key, policy.mlp.layers[-1].weight.shape))
    shocks = jax.random.normal(jax.random.key(2), (32, inputs.n_days))

    def value(curve):
        return gs.expected_value(policy, eqx.tree_at(lambda i: i.forward_curve, inputs, curve), scene,
                                 sharpness=None, shocks=shocks)

    deltas = jax.grad(value)(inputs.forward_curve)
    bumped = snapo_ode.bump_and_revalue(jax.jit(value), inputs.forward_curve)
    assert snapo_ode.max_relative_difference(np.asarray(deltas), np.asarray(bumped), floor=1e-3) < 1e-6


def random_targets(inputs, scene, key, scale):
    policy = gs.make_policy(scene, inputs, key=key, head="basestock", spot_scale=0.3)
    return eqx.tree_at(lambda p: p.mlp.layers[-1].weight, policy,
                       scale * jax.random.normal(key, policy.mlp.layers[-1].weight.shape))


def test_hard_evaluation_moves_to_the_target_at_the_largest_feasible_rate(key):
    inputs = bdj(BDJ_VOLATILITY["high"])
    scene = gs.stochastic_scene()
    policy = random_targets(inputs, scene, key, 2.0)
    shocks = jax.random.normal(jax.random.key(5), (16, inputs.n_days))
    run = gs.simulate(policy, inputs, scene, sharpness=None, shocks=shocks)
    _, factor = gs.spot_prices(inputs, shocks)
    low, high = gs.basestock_targets(policy, inputs, scene, factor, None)
    inventory = np.asarray(run.inventory)
    today, tomorrow = inventory[:, :-1], inventory[:, 1:]
    floor = np.asarray(gs.inventory_floor(inputs, scene, None))[1:]
    _, lower, upper = gs.feasible_flows(inputs, scene, jnp.asarray(today), jnp.asarray(floor), None)
    net, lower, upper, low, high = (np.asarray(a) for a in (tomorrow - today, lower, upper, low, high))
    tol = 1e-6 * float(inputs.capacity)
    below, above = today < np.asarray(low) - tol, today > np.asarray(high) + tol
    # Below the lower target: inject at the largest feasible rate, or exactly up to the target (or
    # more, where the terminal requirement forces it: net = lower > 0); above the upper one:
    # withdraw at the largest rate, or exactly down to it; in between: hold (within [lower, upper]).
    full_in = np.isclose(net, upper, atol=tol) | np.isclose(tomorrow, low, atol=tol) | np.isclose(net, lower, atol=tol)
    full_out = np.isclose(net, lower, atol=tol) | np.isclose(tomorrow, high, atol=tol)
    hold = np.isclose(net, np.clip(0.0, lower, upper), atol=tol)
    assert np.all(full_in[below]) and np.all(full_out[above]) and np.all(hold[~below & ~above])
    assert below.sum() > 100 and above.sum() > 100  # the test exercises every branch
    # Bang-bang: most trading days run at the largest feasible rate, not at a fraction of it.
    trading = np.abs(net) > tol
    at_bound = np.isclose(net, upper, atol=tol) | np.isclose(net, lower, atol=tol)
    assert at_bound[trading].mean() > 0.5


def test_head_defaults_and_bad_head():
    settings = gs.StudySettings(stochastic=True, train_steps=5)
    assert settings.head == "basestock" == gs.DEFAULT_HEAD
    assert settings.train_float32 and settings.train_steps == 5 and settings.train_paths == 512
    assert gs.StudySettings(split_actions=True).head == "split"
    assert gs.StudySettings(head="fraction").sharpness == 200.0
    with pytest.raises(snapo_ode.InputError, match="head"):
        gs.make_policy(gs.deterministic_scene(), bdj(), key=jax.random.key(0), head="targets")
    with pytest.raises(snapo_ode.InputError, match="head"):
        gs.StudySettings(head="targets")


def test_a_trained_policy_is_written_and_read_back(tmp_path, key):
    inputs = bdj()
    scene = gs.stochastic_scene()
    policy = random_targets(inputs, scene, key, 1.0)
    path = tmp_path / "policy.eqx"
    path.write_bytes(gs.storage_policy_bytes(policy))
    loaded = gs.load_storage_policy(path)
    shocks = jax.random.normal(jax.random.key(3), (4, inputs.n_days))
    np.testing.assert_array_equal(gs.simulate(loaded, inputs, scene, sharpness=None, shocks=shocks).value,
                                  gs.simulate(policy, inputs, scene, sharpness=None, shocks=shocks).value)


def test_a_policy_that_reads_the_curve_is_written_and_read_back(tmp_path, key):
    from finance.gas_storage._family import family

    case = family(1)[0]  # weekly-slow-365: a weekend discount on a seasonal curve
    inputs = gs.make_inputs(case.facility, case.curve, volatility=1.0, mean_reversion=18.25)
    scene = gs.stochastic_scene()
    lp = gs.solve_intrinsic(inputs, gs.deterministic_scene())
    policy = gs.make_policy(scene, inputs, key=key, head="basestock", spot_scale=0.3, intrinsic_inventory=lp.inventory)
    features = np.asarray(policy.day_features)
    assert features.shape == (365, 5)
    np.testing.assert_allclose(features.mean(0), 0, atol=1e-12)
    np.testing.assert_allclose(features.std(0), 1, rtol=1e-12)
    # The weekend discount shows in the spread to tomorrow: Friday's is negative, Sunday's positive.
    friday, sunday = np.arange(365) % 7 == 4, np.arange(365) % 7 == 6
    assert features[friday, 1].max() < 0 < features[sunday, 1].min()
    policy = eqx.tree_at(lambda p: p.mlp.layers[-1].weight, policy,
                         jax.random.normal(key, policy.mlp.layers[-1].weight.shape))
    path = tmp_path / "policy.eqx"
    path.write_bytes(gs.storage_policy_bytes(policy))
    shocks = jax.random.normal(jax.random.key(3), (4, inputs.n_days))
    np.testing.assert_array_equal(gs.simulate(gs.load_storage_policy(path), inputs, scene, sharpness=None,
                                              shocks=shocks).value,
                                  gs.simulate(policy, inputs, scene, sharpness=None, shocks=shocks).value)


@pytest.mark.parametrize("sharpness", [200.0, None])
def test_the_rollout_s_reverse_passes_agree(key, monkeypatch, sharpness):
    """The closed-form reverse pass (up to `ELEMENTWISE_PATHS` paths) and the recomputing scan's
    give the same value and the same gradient in the policy and every input, on a facility with
    ratchets, fuel loss, costs and discounting."""
    facility, curve = CASES["peaking_winter_spike"]()
    inputs = gs.make_inputs(facility, curve, volatility=1.0, mean_reversion=5.0)
    scene = gs.stochastic_scene()
    policy = random_targets(inputs, scene, key, 1.0)
    shocks = jax.random.normal(jax.random.key(3), (16, inputs.n_days))

    def value_and_gradient():
        return eqx.filter_value_and_grad(lambda both: gs.expected_value(*both, scene, sharpness=sharpness,
                                                                        shocks=shocks))((policy, inputs))

    closed_form = value_and_gradient()
    monkeypatch.setattr("finance.gas_storage._basestock.ELEMENTWISE_PATHS", 0)
    scan = value_and_gradient()
    assert float(closed_form[0]) == float(scan[0])
    for a, b in zip(jax.tree.leaves(closed_form[1]), jax.tree.leaves(scan[1]), strict=True):
        np.testing.assert_allclose(a, b, rtol=1e-10, atol=1e-10 * float(np.max(np.abs(b), initial=0.0)))
