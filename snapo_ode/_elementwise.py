"""The reverse pass of an elementwise recursion in closed form: one linear recurrence and one
linearisation vectorised over every step, instead of a reverse scan through each step's
operations.

For x_{k+1} = F(k, x_k, d_k), with every entry of x depending only on its own previous entry
(independent Monte Carlo paths, a scalar state), the Jacobian of a step with respect to x_k is
diagonal, a_k = dF/dx (k, x_k, d_k), and the cotangents of the states obey

    lambda_n = g_n,    lambda_k = g_k + a_k lambda_{k+1}

(g_k the cotangent of x_k from what follows the rollout). Given the forward states, F is
linearised once, vectorised over every k (`jax.linearize`): the linear map applied forward gives
every a_k, a reverse scan of one multiply-add a step the recurrence, and the map transposed the
cotangents of the step data d_k and of whatever F closes over. On a CPU a reverse `lax.scan`
through the step pays its per-iteration overhead on every operation of the step; this pays it
on one (docs/decisions.md, "The adjoint of an elementwise recursion").

Only reverse mode: forward mode (`jax.jvp`) through such a rollout is not defined.
"""

from collections.abc import Callable

import equinox as eqx
import jax
import jax.numpy as jnp


def elementwise_rollout(step: Callable, state0: jax.Array, n_steps: int, per_step=None) -> jax.Array:
    """The states x_0..x_n, shape (n_steps + 1, *state0.shape), of `step(k, state, data_k)`
    (data_k: slice k of the `per_step` pytree, None without it), with the closed-form reverse
    pass of the module docstring. `step` must act elementwise on `state` (each entry of the new
    state depends on the same entry of the old one only); it may close over arrays, which are
    differentiated."""
    state0 = jnp.asarray(state0, dtype=jnp.result_type(state0))  # not weakly typed, as the steps' output
    first = None if per_step is None else jax.tree.map(lambda leaf: leaf[0], per_step)
    closed = eqx.filter_closure_convert(step, jnp.zeros((), int), state0, first)
    return _rollout((closed, state0, per_step), n_steps)


def _steps(step, states, per_step):
    """Every step at once: F(k, x_k, d_k) for k = 0..n-1, from `states` x_0..x_{n-1}."""
    return jax.vmap(step)(jnp.arange(states.shape[0]), states, per_step)


def _forward_states(step, state0, per_step, n_steps: int) -> jax.Array:
    """x_0..x_n by `lax.scan`."""

    def body(state, k_and_data):
        k, data = k_and_data
        new = step(k, state, data)
        return new, new

    _, states = jax.lax.scan(body, state0, (jnp.arange(n_steps), per_step))
    return jnp.concatenate([state0[None], states])


@eqx.filter_custom_vjp
def _rollout(differentiable, n_steps: int):
    return _forward_states(*differentiable, n_steps)


@_rollout.def_fwd
def _rollout_fwd(perturbed, differentiable, n_steps: int):
    states = _forward_states(*differentiable, n_steps)
    return states, states  # the residuals are the states themselves


def _adjoint_states(slopes: jax.Array, cotangents: jax.Array) -> jax.Array:
    """lambda_k = g_k + a_k lambda_{k+1} (lambda_n = g_n) for every k, by a reverse scan of one
    multiply-add a step."""

    def back(later, slope_and_cotangent):
        slope, cotangent = slope_and_cotangent
        earlier = cotangent + slope * later
        return earlier, earlier

    _, adjoint = jax.lax.scan(back, cotangents[-1], (slopes, cotangents[:-1]), reverse=True)
    return jnp.concatenate([adjoint, cotangents[-1:]])


@_rollout.def_bwd
def _rollout_bwd(states, cotangents, perturbed, differentiable, n_steps: int):
    step, _, per_step = differentiable
    cotangents = jnp.zeros_like(states) if cotangents is None else cotangents
    before = states[:-1]
    arrays, static = eqx.partition((step, per_step), eqx.is_inexact_array)

    def steps(x, arrays):
        step, per_step = eqx.combine(arrays, static)
        return _steps(step, x, per_step)

    _, linear = jax.linearize(steps, before, arrays)
    slopes = linear(jnp.ones_like(before), jax.tree.map(jnp.zeros_like, arrays))
    adjoint = _adjoint_states(slopes, cotangents)
    _, (step_cotangent, data_cotangent) = jax.linear_transpose(linear, before, arrays)(adjoint[1:])
    return step_cotangent, adjoint[0], data_cotangent
