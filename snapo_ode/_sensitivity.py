"""Sensitivities: one reverse pass for a scalar, a vmapped Jacobian for a vector, and central
bump-and-revalue as the independent reference.

Inputs are any pytree (an `equinox.Module` policy, a dict of model inputs, or both together);
the differentiable part is every inexact array leaf, as in `equinox.filter_grad`.
"""

import time
from collections.abc import Callable
from typing import Literal, NamedTuple

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
from jax.flatten_util import ravel_pytree

from ._validation import check_choice

JacobianMode = Literal["auto", "reverse", "forward"]
# Cube root of float64 machine epsilon: the step that balances truncation and round-off in a
# central difference.
DEFAULT_RELATIVE_STEP = float(np.finfo(np.float64).eps ** (1 / 3))


def flatten_inputs(inputs):
    """Split `inputs` into a flat float vector of its inexact array leaves and a function that
    rebuilds the full pytree from such a vector."""
    params, static = eqx.partition(inputs, eqx.is_inexact_array)
    flat, unravel = ravel_pytree(params)

    def rebuild(vector):
        return eqx.combine(unravel(vector), static)

    return flat, rebuild


def value_and_sensitivities(fn: Callable, inputs, *args, has_aux: bool = False):
    """The value of scalar `fn(inputs, *args)` and its gradient with respect to every inexact
    array leaf of `inputs`, from one reverse pass.

    **Returns:** `(value, gradient)` (or `((value, aux), gradient)` with `has_aux`); the gradient
    has the structure of `inputs`, with `None` at non-differentiable leaves.
    """
    return eqx.filter_value_and_grad(fn, has_aux=has_aux)(inputs, *args)


class Jacobian(NamedTuple):
    """`values`: shape (m,); `matrix`: d values / d inputs, shape (m, n) over the flattened
    inputs; `mode`: "reverse" (m vmapped reverse passes) or "forward" (n vmapped tangents);
    `rebuild`: maps a length-n vector back to the structure of the inputs."""

    values: jax.Array
    matrix: jax.Array
    mode: str
    rebuild: Callable

    def row(self, i: int):
        """d values[i] / d inputs, in the structure of the inputs."""
        return self.rebuild(self.matrix[i])


def choose_mode(n_outputs: int, n_inputs: int) -> str:
    """Reverse mode costs one pass per output, forward mode one per input: pick the fewer
    (reverse on a tie, since it also serves gradients of scalar objectives)."""
    return "reverse" if n_outputs <= n_inputs else "forward"


def jacobian(fn: Callable, inputs, *args, mode: JacobianMode = "auto") -> Jacobian:
    """The Jacobian of the vector `fn(inputs, *args)` (shape (m,)) with respect to `inputs`.

    `mode="auto"` picks reverse or forward mode from the Jacobian's shape (`choose_mode`); the
    mode used is in the result. A model integrated with `diffrax.RecursiveCheckpointAdjoint`
    supports reverse mode only; build it with `diffrax.ForwardMode()` for forward mode.
    """
    check_choice("mode", mode, ("auto", "reverse", "forward"))
    flat, rebuild = flatten_inputs(inputs)

    def flat_fn(vector):
        return jnp.ravel(fn(rebuild(vector), *args))

    if mode == "auto":
        n_outputs = jax.eval_shape(flat_fn, flat).shape[0]
        mode = choose_mode(n_outputs, flat.shape[0])
    if mode == "reverse":
        values, pullback = jax.vjp(flat_fn, flat)
        (matrix,) = jax.vmap(pullback)(jnp.eye(values.shape[0], dtype=values.dtype))
    else:
        values = flat_fn(flat)
        tangents = jnp.eye(flat.shape[0], dtype=flat.dtype)
        columns = jax.vmap(lambda tangent: jax.jvp(flat_fn, (flat,), (tangent,))[1])(tangents)
        matrix = columns.T
    return Jacobian(values, matrix, mode, rebuild)


def bump_steps(flat: jax.Array, relative_step: float) -> jax.Array:
    """Central-difference steps: `relative_step * max(|x|, 1)` per input."""
    return relative_step * jnp.maximum(jnp.abs(flat), 1.0)


def bump_and_revalue(
    fn: Callable,
    inputs,
    *args,
    relative_step: float = DEFAULT_RELATIVE_STEP,
    batched: bool = True,
    batch_size: int | None = None,
    select: Callable | None = None,
):
    """Central bump-and-revalue of scalar `fn(inputs, *args)`: (f(x+h) - f(x-h)) / 2h per input.

    **Arguments:**
    - `relative_step`: the step is `relative_step * max(|x|, 1)`.
    - `batched`: evaluate all 2n bumped inputs in one vmapped call (in chunks of `batch_size`
      through `jax.lax.map` when given, to bound memory); otherwise a Python loop over a jitted
      function, one revaluation at a time, as a desk's bump-and-revalue does.
    - `select`: optional function of `inputs` returning the sub-pytree to bump (default: all
      inexact leaves); the other leaves stay fixed.

    **Returns:** the gradient as a pytree shaped like the bumped inputs.
    """
    if select is None:
        flat, rebuild = flatten_inputs(inputs)

        def evaluate(vector):
            return fn(rebuild(vector), *args)
    else:
        part = select(inputs)
        flat, rebuild_part = flatten_inputs(part)

        def evaluate(vector):
            new = eqx.tree_at(select, inputs, rebuild_part(vector))
            return fn(new, *args)

        rebuild = rebuild_part

    steps = bump_steps(flat, relative_step)
    n = flat.shape[0]
    if batched:

        @jax.jit
        def all_bumps(flat, steps):
            bumps = jnp.concatenate([jnp.diag(steps), -jnp.diag(steps)]) + flat
            if batch_size is None:
                values = jax.vmap(evaluate)(bumps)
            else:
                values = jax.lax.map(evaluate, bumps, batch_size=batch_size)
            return (values[:n] - values[n:]) / (2 * steps)

        gradient = all_bumps(flat, steps)
    else:
        single = jax.jit(evaluate)
        gradient = []
        for i in range(n):
            up = single(flat.at[i].add(steps[i]))
            down = single(flat.at[i].add(-steps[i]))
            gradient.append((up - down) / (2 * steps[i]))
        gradient = jnp.stack(gradient)
    return rebuild(gradient)


def max_relative_difference(estimate, reference, *, floor: float = 1e-8) -> float:
    """max |estimate - reference| / max(|reference|, floor * max|reference|) over all leaves.

    The floor keeps entries that are zero up to round-off from dominating: an entry a
    hundred-millionth of the largest (by default) is compared at that scale. `floor=1` gives the
    normwise figure max |estimate - reference| / max |reference|.
    """
    a = np.concatenate([np.ravel(x) for x in jax.tree.leaves(estimate)])
    b = np.concatenate([np.ravel(x) for x in jax.tree.leaves(reference)])
    scale = np.maximum(np.abs(b), floor * np.max(np.abs(b), initial=0.0))
    scale = np.where(scale == 0, 1.0, scale)
    return float(np.max(np.abs(a - b) / scale, initial=0.0))


class BumpComparison(NamedTuple):
    """The adjoint gradient next to central bump-and-revalue of the same function, timed side
    by side in one run (medians after warm-up; compile times apart)."""

    value: float
    adjoint: object
    bumped: object
    max_rel_diff: float
    adjoint_seconds: float
    bump_seconds: float
    speedup: float
    adjoint_compile_seconds: float
    bump_compile_seconds: float


def compare_with_bumps(
    fn: Callable,
    inputs,
    *args,
    select: Callable | None = None,
    batched: bool = True,
    batch_size: int | None = None,
    relative_step: float = DEFAULT_RELATIVE_STEP,
    floor: float = 1e-8,
    repeats: int = 3,
) -> BumpComparison:
    """Gradient of scalar `fn(inputs, *args)` by one reverse pass and by central bumps (with
    respect to `select(inputs)` when given, else every inexact leaf), their
    `max_relative_difference` and the time ratio `speedup = bump_seconds / adjoint_seconds`."""
    from ._timing import time_function

    if select is None:
        part, of_part = inputs, (lambda part, *args: fn(part, *args))
    else:
        part = select(inputs)

        def of_part(part, *args):
            return fn(eqx.tree_at(select, inputs, part), *args)

    adjoint_fn = eqx.filter_jit(lambda part, *args: value_and_sensitivities(of_part, part, *args))
    bump_fn = eqx.filter_jit(lambda part, *args: bump_and_revalue(
        of_part, part, *args, relative_step=relative_step, batched=True, batch_size=batch_size))
    adjoint_timing, (value, adjoint) = time_function(adjoint_fn, part, *args, repeats=repeats)
    if batched:
        bump_timing, bumped = time_function(bump_fn, part, *args, repeats=repeats)
        bump_seconds, bump_compile = bump_timing.median_seconds, bump_timing.compile_seconds
    else:
        start = time.perf_counter()
        bumped = bump_and_revalue(of_part, part, *args, relative_step=relative_step, batched=False)
        bump_seconds, bump_compile = time.perf_counter() - start, 0.0
    return BumpComparison(
        value=float(value),
        adjoint=adjoint,
        bumped=bumped,
        max_rel_diff=max_relative_difference(eqx.filter(adjoint, eqx.is_inexact_array), bumped, floor=floor),
        adjoint_seconds=adjoint_timing.median_seconds,
        bump_seconds=bump_seconds,
        speedup=bump_seconds / adjoint_timing.median_seconds,
        adjoint_compile_seconds=adjoint_timing.compile_seconds,
        bump_compile_seconds=bump_compile,
    )
