"""The lax.scan rollout and the Diffrax DiscreteStepper rollout give identical states and
gradients; both agree with a closed form."""

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
import pytest

import snapo_ode
from snapo_ode import MLPPolicy, rollout


def controlled_step(k, state, args):
    """A small discrete-time control problem: a policy pushes a decaying level toward a
    day-dependent target; the cost accumulates in the state."""
    policy, target = args
    level, cost = state
    action = policy(jnp.stack([k / 50.0, level]))[0]
    new_level = 0.9 * level + action
    return new_level, cost + (new_level - target[k]) ** 2


@pytest.fixture(scope="module")
def problem():
    policy = MLPPolicy(2, 1, key=jax.random.key(3), action_low=-1.0, action_high=1.0, output_gain=1.0)
    target = jnp.sin(jnp.arange(50) / 8.0)
    return policy, target


def terminal_cost(args, method):
    _, costs = rollout(controlled_step, (jnp.array(0.3), jnp.array(0.0)), 50, args, method=method)
    return costs[-1]


def test_closed_form_linear_recursion():
    states = rollout(lambda k, x, a: a * x + k, jnp.array(1.0), 4, 0.5)
    expected = [1.0]
    for k in range(4):
        expected.append(0.5 * expected[-1] + k)
    np.testing.assert_allclose(states, expected, rtol=0, atol=0)


def test_scan_and_diffrax_identical_values_and_gradients(problem):
    values = {m: terminal_cost(problem, m) for m in ("scan", "diffrax")}
    grads = {m: eqx.filter_grad(lambda a, m=m: terminal_cost(a, m))(problem) for m in ("scan", "diffrax")}
    np.testing.assert_allclose(values["scan"], values["diffrax"], rtol=1e-14)
    for a, b in zip(jax.tree.leaves(grads["scan"]), jax.tree.leaves(grads["diffrax"]), strict=True):
        np.testing.assert_allclose(a, b, rtol=1e-12, atol=1e-14)


def test_gradient_matches_central_bumps(problem):
    policy, target = problem
    fn = lambda target: terminal_cost((policy, target), "scan")  # noqa: E731
    adjoint = jax.grad(fn)(target)
    bumped = snapo_ode.bump_and_revalue(fn, target)
    assert snapo_ode.max_relative_difference(adjoint, bumped) < 1e-6


def test_rejects_bad_arguments():
    with pytest.raises(snapo_ode.InputError, match="method"):
        rollout(lambda k, x, a: x, jnp.array(0.0), 3, method="euler")
    with pytest.raises(snapo_ode.InputError, match="n_steps"):
        rollout(lambda k, x, a: x, jnp.array(0.0), 0)


def test_remat_gives_identical_values_and_gradients(problem):
    def cost(args, remat):
        _, costs = rollout(controlled_step, (jnp.array(0.3), jnp.array(0.0)), 50, args, remat=remat)
        return costs[-1]

    plain, rematerialised = (eqx.filter_value_and_grad(lambda a, r=r: cost(a, r))(problem) for r in (False, True))
    np.testing.assert_allclose(plain[0], rematerialised[0], rtol=1e-15)
    for a, b in zip(jax.tree.leaves(plain[1]), jax.tree.leaves(rematerialised[1]), strict=True):
        np.testing.assert_allclose(a, b, rtol=1e-12, atol=1e-15)


def _paths_step(k, level, args, data):
    """An elementwise step: each path's level depends on its own previous level, the day's data
    and closed-over parameters, through smooth and hard clips."""
    gain, ceiling = args
    target, shock = data
    pushed = level + snapo_ode.smooth.clip(target - level, -0.3, gain, 50.0) + 0.05 * shock
    return jnp.clip(pushed + 0.001 * k, -ceiling, ceiling)


def _paths_objective(state0, data, args, elementwise):
    levels = rollout(_paths_step, state0, 40, args, per_step=data, elementwise=elementwise)
    return jnp.sum(jnp.sin(levels) * jnp.arange(41.0)[:, None])


@pytest.fixture(scope="module")
def paths_problem():
    keys = jax.random.split(jax.random.key(5), 3)
    data = (1.5 * jnp.sin(jnp.arange(40.0) / 6)[:, None] * jnp.ones(6), jax.random.normal(keys[0], (40, 6)))
    state0 = jax.random.uniform(keys[1], (6,), minval=-0.5, maxval=0.5)
    return state0, data, (jnp.array(0.4), jnp.array(1.2))


def test_elementwise_reverse_pass_equals_the_scan_s(paths_problem):
    """The closed-form reverse pass (one linear recurrence, one vectorised pass) gives the scan's
    states exactly and its gradient in every argument, closed-over parameters included."""
    states = {e: rollout(_paths_step, paths_problem[0], 40, paths_problem[2], per_step=paths_problem[1],
                         elementwise=e) for e in (False, True)}
    np.testing.assert_array_equal(states[True], states[False])
    grads = {e: jax.grad(_paths_objective, argnums=(0, 1, 2))(*paths_problem, e) for e in (False, True)}
    assert 0 < np.mean(np.abs(np.asarray(states[True])) == 1.2) < 0.5  # the hard clip binds on some days
    for a, b in zip(jax.tree.leaves(grads[True]), jax.tree.leaves(grads[False]), strict=True):
        np.testing.assert_allclose(a, b, rtol=1e-10, atol=1e-13)


def test_elementwise_gradient_matches_central_bumps(paths_problem):
    state0, data, args = paths_problem
    args = (args[0], jnp.array(10.0))  # the hard clip idle: a bump across its kink is no reference
    for select, point in ((lambda x: _paths_objective(x, data, args, True), state0),
                          (lambda g: _paths_objective(state0, data, (g, args[1]), True), args[0]),
                          (lambda t: _paths_objective(state0, (t, data[1]), args, True), data[0])):
        adjoint = jax.grad(select)(point)
        bumped = snapo_ode.bump_and_revalue(select, point)
        # ~1e-5: the bumps' round-off on the objective (~300) over steps of 1e-6 of entries ~0.03
        assert snapo_ode.max_relative_difference(adjoint, bumped, floor=1e-2) < 1e-4


def test_elementwise_is_a_scan_s_reverse_pass_only():
    with pytest.raises(snapo_ode.InputError, match="elementwise"):
        rollout(lambda k, x, a: x, jnp.array(0.0), 3, method="diffrax", elementwise=True)
    with pytest.raises(snapo_ode.InputError, match="elementwise"):
        rollout(lambda k, x, a: x, jnp.array(0.0), 3, remat=True, elementwise=True)
