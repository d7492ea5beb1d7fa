"""Discrete-time models x_{k+1} = F(k, x_k, args), rolled out by `jax.lax.scan` or by
`diffrax.diffeqsolve` through a fixed-step solver.

Both give identical states and gradients (tested). `lax.scan` is the default because it is the
faster of the two forward and compiles much faster (the rollout table of `snapo bench gas`); the
Diffrax route lets a discrete-time model share Diffrax's adjoints and its memory bound.
"""

from collections.abc import Callable
from typing import ClassVar, Literal

import diffrax
import jax
import jax.numpy as jnp

from ._elementwise import elementwise_rollout
from ._platform.validation import InputError, check_choice

RolloutMethod = Literal["scan", "diffrax"]


class DiscreteStepper(diffrax.AbstractSolver):
    """A Diffrax solver that advances a discrete-time map: y1 = vf(t0, y0, args).

    Use with an `ODETerm` whose vector field is the map, `ConstantStepSize` and `dt0` equal to
    the model's step. It reports no error estimate and never rejects a step.
    """

    term_structure: ClassVar = diffrax.AbstractTerm
    interpolation_cls: ClassVar = diffrax.LocalLinearInterpolation

    def order(self, terms):
        return 1

    def init(self, terms, t0, t1, y0, args):
        return None

    def step(self, terms, t0, t1, y0, args, solver_state, made_jump):
        y1 = terms.vf(t0, y0, args)
        return y1, None, dict(y0=y0, y1=y1), None, diffrax.RESULTS.successful

    def func(self, terms, t0, y0, args):
        return terms.vf(t0, y0, args)


def rollout(
    step: Callable,
    state0,
    n_steps: int,
    args=None,
    *,
    method: RolloutMethod = "scan",
    checkpoints: int | None = None,
    per_step=None,
    remat: bool = False,
    elementwise: bool = False,
):
    """Roll a discrete-time model forward `n_steps` steps.

    **Arguments:**
    - `step`: `step(k, state, args) -> state`, with `k` the integer step index (0-based); with
      `per_step`, `step(k, state, args, data_k)`.
    - `state0`: the initial state, any pytree of arrays.
    - `n_steps`: number of steps (static).
    - `method`: `"scan"` (default, faster) or `"diffrax"` (`DiscreteStepper` under
      `diffeqsolve`, reverse pass by `RecursiveCheckpointAdjoint`).
    - `checkpoints`: Diffrax only: checkpoints of the adjoint (default `n_steps`, a checkpoint at
      every step, so that no step is recomputed; fewer bound memory at more recomputation).
    - `per_step`: optional pytree of arrays with a leading axis of length `n_steps` (prices,
      shocks, ...); step k receives slice k. Passing such data here rather than indexing a
      closed-over array in `step` keeps the reverse pass from accumulating a full-size
      cotangent at every step.
    - `remat`: scan only: recompute each step's intermediates in the reverse pass
      (`jax.checkpoint` on the step) instead of storing them. Worth it when a step is wide
      (many Monte Carlo paths): storing per-path activations for every step makes the reverse
      pass memory-bound.
    - `elementwise`: scan only: the state is one array whose entries each depend on their own
      previous value only (a scalar state, independent paths); the reverse pass is then one
      linear recurrence and one linearisation vectorised over every step (`elementwise_rollout`),
      several times faster than the reverse scan on a CPU on few paths. Reverse mode only: no
      `jax.jvp` through it.

    **Returns:** the states, each leaf with a leading axis of length `n_steps + 1` (state0 first).
    """
    check_choice("method", method, ("scan", "diffrax"))
    if not isinstance(n_steps, int) or n_steps < 1:
        raise InputError(f"n_steps = {n_steps!r} must be a positive integer.")
    if per_step is None:
        apply = lambda k, state, data: step(k, state, args)  # noqa: E731
    else:
        apply = lambda k, state, data: step(k, state, args, data)  # noqa: E731
    if elementwise:
        if method != "scan" or remat:
            raise InputError("elementwise=True is a scan's reverse pass: use it with method='scan' and remat=False.")
        return elementwise_rollout(apply, state0, n_steps, per_step)
    if method == "scan":

        def body(state, k_and_data):
            k, data = k_and_data
            new = apply(k, state, data)
            return new, new

        _, states = jax.lax.scan(jax.checkpoint(body) if remat else body, state0,
                                 (jnp.arange(n_steps), per_step))
    else:

        def vector_field(t, state, args):
            k = jnp.round(t).astype(int)
            return apply(k, state, jax.tree.map(lambda leaf: leaf[k], per_step))

        solution = diffrax.diffeqsolve(
            diffrax.ODETerm(vector_field),
            DiscreteStepper(),
            t0=0.0,
            t1=float(n_steps),
            dt0=1.0,
            y0=state0,
            args=args,
            saveat=diffrax.SaveAt(steps=True),
            stepsize_controller=diffrax.ConstantStepSize(),
            adjoint=diffrax.RecursiveCheckpointAdjoint(checkpoints=checkpoints or n_steps),
            max_steps=n_steps,
        )
        states = solution.ys
    return jax.tree.map(lambda first, rest: jnp.concatenate([first[None], rest]), state0, states)
