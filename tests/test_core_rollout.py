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
