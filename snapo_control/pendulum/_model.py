"""Gymnasium's Pendulum-v1 in JAX: the same step, cost and reset distribution, written once for
both forms, smooth (training) and hard (`sharpness=None`, equal to Gymnasium's step to round-off;
tested side by side).

The state is (theta [rad], theta_dot [rad/s]), theta = 0 upright and unwrapped as in Gymnasium
(it counts whole turns). theta is a periodic component (`PERIODIC`): the policy sees
(sin theta, cos theta, theta_dot) and the angle's cost is the squared distance along the circle,
smooth across theta = +-pi. `periodic=False` is the same model without that treatment, as the
published SNAPO ran it: the policy sees the wrapped angle, which jumps from pi to -pi at the
bottom, and the cost differentiates Gymnasium's formula as written, whose slope jumps there.
"""

import math

import equinox as eqx
import jax
import jax.numpy as jnp

from snapo_ode import Periodic, smooth, wrap

TAU = 2 * math.pi
STATE = ("theta", "theta_dot")
PERIODIC = Periodic((TAU, None))


class Pendulum(eqx.Module):
    """Pendulum-v1's constants (Gymnasium 1.x defaults): gravity `g` [m/s^2], mass `m` [kg],
    length `l` [m], time step `dt` [s], `max_speed` [rad/s], `max_torque` [N m], cost weights on
    theta^2, theta_dot^2 and torque^2, `episode_steps`, and the reset box: theta ~ U[-reset_theta,
    reset_theta], theta_dot ~ U[-reset_speed, reset_speed]."""

    g: float = eqx.field(static=True, default=10.0)
    m: float = eqx.field(static=True, default=1.0)
    l: float = eqx.field(static=True, default=1.0)  # noqa: E741  (Gymnasium's name)
    dt: float = eqx.field(static=True, default=0.05)
    max_speed: float = eqx.field(static=True, default=8.0)
    max_torque: float = eqx.field(static=True, default=2.0)
    speed_weight: float = eqx.field(static=True, default=0.1)
    torque_weight: float = eqx.field(static=True, default=0.001)
    episode_steps: int = eqx.field(static=True, default=200)
    reset_theta: float = eqx.field(static=True, default=math.pi)
    reset_speed: float = eqx.field(static=True, default=1.0)

    def step(self, state, torque, sharpness: float | None = None, *, periodic: bool = True):
        """One step of Pendulum-v1.

        **Arguments:**
        - `state`: shape (..., 2), (theta [rad], theta_dot [rad/s]).
        - `torque`: shape (...), the policy's torque [N m], clipped to +-max_torque here.
        - `sharpness`: `None` for Gymnasium's exact step; k > 0 for the smooth surrogates
          (torque and speed clips by `smooth.clip`, the angle cost by `wrapped_square`) [1/unit].
        - `periodic`: the angle cost along the circle (smooth at +-pi), or, with `False`,
          Gymnasium's `angle_normalize(theta)^2` differentiated as written.

        **Returns:** the next state, shape (..., 2), and the step's cost (the negative reward),
        shape (...), computed on the current state and the clipped torque as Gymnasium does.
        """
        theta, speed = state[..., 0], state[..., 1]
        torque = smooth.clip(torque, -self.max_torque, self.max_torque, sharpness)
        if periodic:
            angle_cost = PERIODIC.squared_error(state, sharpness=sharpness)[..., 0]
        else:
            angle_cost = wrap(theta, TAU) ** 2
        cost = angle_cost + self.speed_weight * speed**2 + self.torque_weight * torque**2
        # Gymnasium's expression, term for term, so that the hard form agrees to round-off.
        acceleration = 3 * self.g / (2 * self.l) * jnp.sin(theta) + 3.0 / (self.m * self.l**2) * torque
        new_speed = smooth.clip(speed + acceleration * self.dt, -self.max_speed, self.max_speed, sharpness)
        new_theta = theta + new_speed * self.dt
        return jnp.stack([new_theta, new_speed], axis=-1), cost

    def reset(self, key, n: int, dtype=float):
        """`n` initial states from Gymnasium's reset distribution, shape (n, 2)."""
        high = jnp.array([self.reset_theta, self.reset_speed], dtype)
        return jax.random.uniform(key, (n, 2), dtype, -high, high)

    def feature_scale(self, periodic: bool = True) -> tuple[float, ...]:
        """Scales that bring the policy's features to order one."""
        return (1.0, 1.0, self.max_speed) if periodic else (math.pi, self.max_speed)


def features(state, periodic: bool = True):
    """The policy's view of states (..., 2): (sin theta, cos theta, theta_dot) with the periodic
    treatment, else (theta wrapped into [-pi, pi), theta_dot)."""
    if periodic:
        return PERIODIC.features(state)
    return jnp.stack([wrap(state[..., 0], TAU), state[..., 1]], axis=-1)


def features_from_observation(observation, periodic: bool = True):
    """The same features from Gymnasium's observation (cos theta, sin theta, theta_dot), shape
    (..., 3): the wrapped angle is recovered as atan2(sin, cos)."""
    cos, sin, speed = observation[..., 0], observation[..., 1], observation[..., 2]
    if periodic:
        return jnp.stack([sin, cos, speed], axis=-1)
    return jnp.stack([jnp.arctan2(sin, cos), speed], axis=-1)
