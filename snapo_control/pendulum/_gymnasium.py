"""Evaluation on Gymnasium's own Pendulum-v1 (its dynamics, its reward, its 200-step limit), not on
our model: the trained policy is called on Gymnasium's float32 observations and its torque is
handed to `env.step` unclipped, as any agent's would be."""

import numpy as np

from snapo_ode import MLPPolicy, check_count

from ._model import features_from_observation

ENV_ID = "Pendulum-v1"


def require_gymnasium():
    """The `gymnasium` module, or an `ImportError` saying how to install it (checked before
    training, so that a long run does not fail at its evaluation)."""
    try:
        import gymnasium
    except ImportError as error:
        raise ImportError("The pendulum study evaluates on Gymnasium's Pendulum-v1: install it with "
                          "`pip install gymnasium==1.4.0` (the project's test extra pins it).") from error
    return gymnasium


def gymnasium_returns(policy: MLPPolicy, episodes: int, seed: int, *, periodic: bool = True) -> np.ndarray:
    """The policy's undiscounted return in each of `episodes` episodes of Gymnasium's
    Pendulum-v1: the environment is reset with `seed` before the first episode and continues its
    own random stream after it. Shape (episodes,)."""
    import equinox as eqx
    import jax.numpy as jnp

    check_count("eval_episodes", episodes)
    check_count("eval_seed", seed, low=0)
    gym = require_gymnasium()
    act = eqx.filter_jit(lambda policy, observation: policy(features_from_observation(
        jnp.asarray(observation, jnp.float64), periodic)))
    env = gym.make(ENV_ID)
    returns = np.empty(episodes)
    try:
        for episode in range(episodes):
            observation, _ = env.reset(seed=seed if episode == 0 else None)
            total, done = 0.0, False
            while not done:
                action = np.asarray(act(policy, observation), dtype=np.float32)
                observation, reward, terminated, truncated, _ = env.step(action)
                total += float(reward)
                done = terminated or truncated
            returns[episode] = total
    finally:
        env.close()
    return returns
