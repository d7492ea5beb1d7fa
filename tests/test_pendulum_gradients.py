"""The gradients training uses, against central differences in float64: the smooth step's Jacobian
(at the wrap point and with both clips active), an episode's cost with respect to the policy's
weights (the exact gradient, gradient_decay = 1), and what gradient_decay < 1 does: the forward
pass unchanged, and for two steps the myopic gradient blended with the exact one."""

import math

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
import pytest

from snapo_control.pendulum import Pendulum, TrainingSettings, episode_costs, new_policy, torque
from snapo_ode import central_differences, flatten_inputs

K = 10.0
PENDULUM = Pendulum()


@pytest.mark.parametrize("periodic", [True, False])
@pytest.mark.parametrize("theta, speed, u", [
    (math.pi, 0.3, 0.5),          # the wrap point, hanging down
    (-math.pi + 1e-3, -7.9, 2.3),  # just past it, the speed clip and the torque clip active
    (0.4, 7.5, -1.9),
    (7.0, 2.0, -3.0),              # a whole turn on
])
def test_smooth_step_jacobian_matches_central_differences(periodic, theta, speed, u):
    def outputs(x):
        state, cost = PENDULUM.step(x[:2], x[2], K, periodic=periodic)
        return jnp.concatenate([state, cost[None]])

    x = jnp.array([theta, speed, u])
    adjoint = np.asarray(jax.jacrev(outputs)(x))
    bumped = central_differences(outputs, x, relative_step=1e-6)
    if not periodic and abs(theta) == math.pi:
        # Without the periodic treatment the angle cost's slope jumps from +2 pi to -2 pi here.
        assert abs(adjoint[2, 0]) == pytest.approx(2 * math.pi) and abs(bumped[2, 0]) < 1e-3
        adjoint, bumped = adjoint[:, 1:], bumped[:, 1:]
    np.testing.assert_allclose(adjoint, bumped, rtol=1e-6, atol=1e-7)


def _small_policy(periodic=True):
    settings = TrainingSettings(width=6, depth=1, periodic=periodic)
    return new_policy(PENDULUM, settings, jax.random.key(3))


WEIGHTS = lambda policy: policy.mlp  # noqa: E731  (the feature and action scalings are not trained)
STATES0 = jnp.array([[math.pi, 0.2], [2.0, -0.7], [-0.4, 0.9]])


def _mean_episode_cost(policy, n_steps, decay=1.0, periodic=True):
    _, costs = episode_costs(policy, PENDULUM, STATES0, K, periodic=periodic, gradient_decay=decay, n_steps=n_steps)
    return jnp.mean(jnp.sum(costs, axis=0))


@pytest.mark.parametrize("periodic", [True, False])
def test_episode_gradient_matches_central_differences(periodic):
    policy = _small_policy(periodic)
    loss = eqx.filter_jit(lambda p: _mean_episode_cost(p, 25, periodic=periodic))
    adjoint = np.asarray(flatten_inputs(eqx.filter_grad(loss)(policy).mlp)[0])
    bumped = central_differences(loss, policy, select=WEIGHTS, relative_step=1e-5)
    assert adjoint.size == 6 * (3 if periodic else 2) + 6 + 6 + 1 and np.abs(bumped).max() > 1.0
    np.testing.assert_allclose(adjoint, bumped, rtol=1e-5, atol=1e-6 * np.abs(bumped).max())


def test_gradient_decay_keeps_the_forward_pass_and_blends_myopic_and_exact_gradients():
    policy = _small_policy()
    for decay in (1.0, 0.5):
        assert float(_mean_episode_cost(policy, 30, decay)) == float(_mean_episode_cost(policy, 30))

    def flat_grad(decay):
        return np.asarray(flatten_inputs(eqx.filter_grad(_mean_episode_cost)(policy, 2, decay).mlp)[0])

    # Two steps: the cost of step 1 reaches the weights directly (the torque at step 1) and through
    # the state it inherits from step 0; the decay scales the second path only. With the state of
    # step 1 frozen, central differences give the myopic gradient (decay 0) independently.
    states1 = episode_costs(policy, PENDULUM, STATES0, K, n_steps=1)[0][1]

    def myopic(p):
        cost0 = PENDULUM.step(STATES0, torque(p, STATES0), K)[1]
        cost1 = PENDULUM.step(states1, torque(p, states1), K)[1]
        return jnp.mean(cost0 + cost1)

    exact, greedy = flat_grad(1.0), flat_grad(0.0)
    bumped = central_differences(myopic, policy, select=WEIGHTS, relative_step=1e-4)
    np.testing.assert_allclose(greedy, bumped, rtol=1e-5, atol=1e-5 * np.abs(bumped).max())
    np.testing.assert_allclose(flat_grad(0.3), 0.7 * greedy + 0.3 * exact, rtol=1e-10, atol=1e-15)
    # The two paths differ, so the blend is a real test.
    assert np.abs(exact - greedy).max() > 0.1 * np.abs(exact).max()
