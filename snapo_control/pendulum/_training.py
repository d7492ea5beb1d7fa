"""Training a swing-up policy by backpropagation through whole 200-step episodes.

Each optimisation step draws a batch of initial states from Pendulum-v1's reset distribution,
rolls the smooth model out for the whole episode and differentiates the mean episode cost.
Through an unstable, chaotic rollout the exact gradient is dominated by long products of step
Jacobians (its norms grow huge, and it trains a poor policy), so the
reverse pass decays each step's state cotangent by `gradient_decay` (the forward pass is
untouched): a cost k steps after an action reaches it weighted by gradient_decay^k, a soft
short horizon of about 1 / (1 - gradient_decay) steps. The decay follows a curriculum: held
low while the policy learns to swing up (a longer horizon at the start left some seeds stuck near
the untrained return), then raised towards the exact gradient to refine the policy. The
comparisons behind these choices: docs/pendulum.md, What mattered.
"""

import os

import equinox as eqx
import jax
import jax.numpy as jnp

import snapo_ode
from snapo_ode import MLPPolicy, Settings, check_count, check_range

from ._model import Pendulum, features


class TrainingSettings(Settings):
    """How a policy is trained (defaults chosen by the comparisons in docs/pendulum.md).

    - `steps`: optimisation steps; `batch`: initial states per step.
    - `learning_rate`: Adam's peak rate (warm-up, then cosine decay to 1%); `clip_norm`: global
      gradient norm clip.
    - `gradient_decay`: in (0, 1], the factor by which the reverse pass scales each step's state
      cotangent (1: the exact gradient), held for the first `ramp_start` fraction of the steps,
      then raised linearly to `final_gradient_decay` at the last step.
    - `sharpness`: of the smooth clips and the smooth angle cost [1/unit].
    - `width`, `depth`: the policy MLP.
    - `float32`: train in float32 (faster on a CPU, same returns); the returned policy is float64.
    - `periodic`: the periodic treatment of theta (features and cost); `False` for the baseline.
    """

    steps: int = eqx.field(static=True, default=600)
    batch: int = eqx.field(static=True, default=64)
    learning_rate: float = eqx.field(static=True, default=1e-2)
    clip_norm: float = eqx.field(static=True, default=1.0)
    gradient_decay: float = eqx.field(static=True, default=0.9)
    final_gradient_decay: float = eqx.field(static=True, default=0.99)
    ramp_start: float = eqx.field(static=True, default=0.3)
    sharpness: float = eqx.field(static=True, default=10.0)
    width: int = eqx.field(static=True, default=64)
    depth: int = eqx.field(static=True, default=2)
    float32: bool = eqx.field(static=True, default=True)
    periodic: bool = eqx.field(static=True, default=True)

    def __check_init__(self):
        check_count("train_steps", self.steps)
        check_count("batch", self.batch)
        check_count("width", self.width)
        check_count("depth", self.depth)
        check_range("learning_rate", self.learning_rate, 0.0, 1.0, low_open=True)
        check_range("clip_norm", self.clip_norm, 0.0, low_open=True)
        check_range("gradient_decay", self.gradient_decay, 0.0, 1.0, low_open=True)
        check_range("final_gradient_decay", self.final_gradient_decay, 0.0, 1.0, low_open=True)
        check_range("ramp_start", self.ramp_start, 0.0, 1.0)
        check_range("sharpness", self.sharpness, 0.0, low_open=True)

    def decay_at(self, step):
        """The gradient decay at training step `step` (0-based; an int or a traced integer)."""
        progress = (step / max(self.steps - 1, 1) - self.ramp_start) / max(1.0 - self.ramp_start, 1e-12)
        return self.gradient_decay + (self.final_gradient_decay - self.gradient_decay) * jnp.clip(progress, 0.0, 1.0)


def new_policy(pendulum: Pendulum, settings: TrainingSettings, key) -> MLPPolicy:
    """An untrained policy: features -> torque [N m], unbounded (the model clips it)."""
    n_features = 3 if settings.periodic else 2
    return MLPPolicy(n_features, 1, key=key, width=settings.width, depth=settings.depth,
                     feature_scale=pendulum.feature_scale(settings.periodic))


def torque(policy: MLPPolicy, states, periodic: bool = True):
    """The policy's torque for states (..., 2) -> (...)."""
    view = features(states, periodic)
    flat = view.reshape(-1, view.shape[-1])
    return jax.vmap(policy)(flat)[:, 0].reshape(view.shape[:-1])


def _decay_gradient(tree, factor):
    """The identity forward; in reverse, cotangents scaled by `factor` (a float or a traced scalar)."""
    if isinstance(factor, float) and factor == 1.0:
        return tree
    return jax.tree.map(lambda x: factor * x + (1 - factor) * jax.lax.stop_gradient(x), tree)


def episode_costs(policy: MLPPolicy, pendulum: Pendulum, states0, sharpness: float | None = None, *,
                  periodic: bool = True, gradient_decay=1.0, n_steps: int | None = None):
    """Roll the policy out from `states0` (n, 2) for an episode (or `n_steps`).

    **Returns:** the states, shape (n_steps + 1, n, 2), and the costs, shape (n_steps, n).
    """

    def step(k, carry, args):
        states, _ = carry
        states = _decay_gradient(states, gradient_decay)
        return pendulum.step(states, torque(policy, states, periodic), sharpness, periodic=periodic)

    zero = jnp.zeros(states0.shape[:-1], states0.dtype)
    states, costs = snapo_ode.rollout(step, (states0, zero), n_steps or pendulum.episode_steps)
    return states, costs[1:]


def _cast(tree, dtype):
    return jax.tree.map(lambda x: x.astype(dtype) if eqx.is_inexact_array(x) else x, tree)


def train_policy(pendulum: Pendulum, settings: TrainingSettings, key, *, progress: bool = True,
                 checkpoint_path: str | os.PathLike | None = None):
    """Train a policy (see the module docstring).

    **Returns:** the policy (float64) and the `snapo_ode.TrainResult` (history of the loss, the
    mean smooth episode cost, per step; wall time after the first step; compile time).
    """
    dtype = jnp.float32 if settings.float32 else jnp.float64
    init_key, data_key = jax.random.split(key)
    policy = _cast(new_policy(pendulum, settings, init_key), dtype)

    def loss(policy, key, step):
        states0 = pendulum.reset(key, settings.batch, dtype)
        decay = settings.decay_at(step).astype(dtype)
        _, costs = episode_costs(policy, pendulum, states0, settings.sharpness, periodic=settings.periodic,
                                 gradient_decay=decay)
        episode_cost = jnp.mean(jnp.sum(costs, axis=0))
        return episode_cost, {"value": -episode_cost, "gradient_decay": decay}

    result = snapo_ode.train(loss, policy, steps=settings.steps, learning_rate=settings.learning_rate,
                             clip_norm=settings.clip_norm, key=data_key, progress=progress, pass_step=True,
                             keep_best=False,
                             checkpoint_path=checkpoint_path,
                             description="pendulum" if settings.periodic else "pendulum (no periodic)")
    return _cast(result.params, jnp.float64), result
