"""Our Pendulum-v1 against Gymnasium's own: the hard step side by side from random states and
torques (beyond both clips), a whole seeded episode, the reset distribution, and the policy's
view of Gymnasium's observation; the smooth step converges to the hard one."""

import gymnasium
import jax
import jax.numpy as jnp
import numpy as np
import pytest
from scipy import stats

from snapo_control.pendulum import ENV_ID, PERIODIC, Pendulum, features, features_from_observation


def _raw_env():
    env = gymnasium.make(ENV_ID).unwrapped  # Gymnasium's step itself, without the wrappers
    env.reset(seed=0)
    return env


def test_hard_step_equals_gymnasiums_from_random_states_and_torques():
    rng = np.random.default_rng(0)
    n = 500
    states = np.stack([rng.uniform(-20, 20, n), rng.uniform(-10, 10, n)], -1)  # unwrapped, beyond max_speed
    torques = rng.uniform(-4, 4, n)  # beyond max_torque
    ours, ours_cost = jax.jit(Pendulum().step)(jnp.asarray(states), jnp.asarray(torques))
    env = _raw_env()
    theirs, theirs_cost, observations = np.empty((n, 2)), np.empty(n), np.empty((n, 3))
    for i in range(n):
        env.state = states[i].copy()
        observations[i], reward, *_ = env.step(np.array([torques[i]]))
        theirs[i], theirs_cost[i] = env.state, -reward
    np.testing.assert_allclose(ours, theirs, rtol=1e-14, atol=1e-14)
    np.testing.assert_allclose(ours_cost, theirs_cost, rtol=1e-14)
    assert np.abs(theirs[:, 1]).max() == 8.0 and np.abs(states[:, 1]).max() > 9  # the speed clip was exercised
    # The policy sees the same features from Gymnasium's float32 observation as from our state.
    np.testing.assert_allclose(features_from_observation(jnp.asarray(observations)), features(ours), atol=1e-6)
    wrapped = features_from_observation(jnp.asarray(observations), periodic=False)
    np.testing.assert_allclose(wrapped, features(ours, periodic=False), atol=1e-5)


def test_a_seeded_episode_matches_step_by_step():
    env = gymnasium.make(ENV_ID)  # with its wrappers: 200 steps, then truncated
    env.reset(seed=3)
    state = jnp.asarray(env.unwrapped.state)
    torques = np.random.default_rng(1).uniform(-2.5, 2.5, 200)
    step = jax.jit(Pendulum().step)
    total_ours, total_theirs, truncated = 0.0, 0.0, False
    for k, torque in enumerate(torques):
        assert not truncated
        _, reward, _, truncated, _ = env.step(np.array([torque]))
        state, cost = step(state, torque)
        total_ours -= float(cost)
        total_theirs += reward
        # Each step starts from Gymnasium's state, so round-off does not grow along the chaotic episode.
        np.testing.assert_allclose(state, env.unwrapped.state, rtol=1e-14, atol=1e-14, err_msg=f"step {k}")
        state = jnp.asarray(env.unwrapped.state)
    assert truncated and total_ours == pytest.approx(total_theirs, rel=1e-13)


def test_reset_distribution_is_gymnasiums():
    env = gymnasium.make(ENV_ID).unwrapped
    env.reset(seed=0)
    theirs = []
    for _ in range(1000):
        env.reset()
        theirs.append(env.state)
    theirs = np.array(theirs)
    ours = np.asarray(Pendulum().reset(jax.random.key(0), 1000))
    for column, high in ((0, np.pi), (1, 1.0)):
        assert np.abs(ours[:, column]).max() <= high and np.abs(ours[:, column]).max() > 0.99 * high
        assert stats.ks_2samp(ours[:, column], theirs[:, column]).pvalue > 1e-3


@pytest.mark.parametrize("periodic", [True, False])
def test_the_smooth_step_converges_to_the_hard_one(periodic):
    rng = np.random.default_rng(2)
    states = jnp.asarray(np.stack([rng.uniform(-7, 7, 300), rng.uniform(-9, 9, 300)], -1))
    torques = jnp.asarray(rng.uniform(-3, 3, 300))
    step = jax.jit(Pendulum().step, static_argnames="periodic")
    hard = step(states, torques, periodic=periodic)
    gaps = []
    for k in (10.0, 100.0, 1000.0):
        smooth = step(states, torques, k, periodic=periodic)
        gaps.append(max(float(jnp.max(jnp.abs(s - h))) for s, h in zip(smooth, hard)))
    assert gaps[0] > gaps[1] > gaps[2] and gaps[2] < 2e-2
    # With the periodic treatment the hard cost is Gymnasium's angle_normalize(theta)^2, still.
    np.testing.assert_allclose(PERIODIC.squared_error(states)[:, 0], np.angle(np.exp(1j * states[:, 0])) ** 2,
                               atol=1e-11)
