"""Verification: central bump-and-revalue as the independent reference for every adjoint
sensitivity, the agreement between the two, and both timed side by side.

Every domain and benchmark checks its sensitivities through `compare_with_bumps` (or, for a
single check without timings, `central_differences` and `agreement`), so a relative difference
and a compile time mean the same thing in every JSON the project writes:

- relative differences are per entry, each row of a Jacobian (one output) with its own scale,
  an entry below `floor` times its row's largest compared at that scale (`agreement`);
- timings are medians of `repeats` calls after a first call, and `compile_seconds` is that
  first call's time less the median (`snapo_ode.time_function`).
"""

import functools
from collections.abc import Callable
from typing import Any, NamedTuple

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np

from ._sensitivity import JacobianMode, flatten_inputs, jacobian, value_and_sensitivities
from ._timing import Timing, time_function
from ._platform.validation import InputError

# Cube root of float64 machine epsilon: the step that balances truncation and round-off in a
# central difference.
DEFAULT_RELATIVE_STEP = float(np.finfo(np.float64).eps ** (1 / 3))


def _direct(fn, *args):
    return fn(*args)


def _selected(inputs, select: Callable | None):
    """The bumped part and a function putting a new part back into `inputs`."""
    if select is None:
        return inputs, lambda part: part
    return select(inputs), lambda part: eqx.tree_at(select, inputs, part)


def bump_steps(flat, relative_step: float, step_floor: float = 1.0) -> np.ndarray:
    """Central-difference steps: `relative_step * max(|x|, step_floor)` per input, and
    `relative_step` where that is zero (`step_floor=0` with x = 0)."""
    scale = np.maximum(np.abs(np.asarray(flat)), step_floor)
    return relative_step * np.where(scale == 0, 1.0, scale)


def _differences(fn, inputs, args, select, steps, richardson: bool, batched: bool, batch_size, call):
    """The central differences of `central_differences`, with the steps given (shape (n,));
    traceable when `batched` (then `call` is not used)."""
    part, put_back = _selected(inputs, select)
    flat, rebuild = flatten_inputs(part)
    n = flat.shape[0]
    eye = jnp.diag(jnp.asarray(steps, flat.dtype))
    bumps = jnp.concatenate([sign * fraction * eye for fraction in ((1.0, 0.5) if richardson else (1.0,))
                             for sign in (1.0, -1.0)])

    def evaluate(vector):
        return fn(put_back(rebuild(vector)), *args)

    if batched:
        values = jax.vmap(evaluate)(flat + bumps) if batch_size is None else jax.lax.map(
            evaluate, flat + bumps, batch_size=batch_size)
    else:
        single = jax.jit(evaluate)
        values = jnp.stack([call(single, flat + bump) for bump in bumps])
    scale = jnp.reshape(steps, (n,) + (1,) * (values.ndim - 1))
    difference = (values[:n] - values[n:2 * n]) / (2 * scale)
    if richardson:
        difference = (4 * (values[2 * n:3 * n] - values[3 * n:]) / scale - difference) / 3
    return jnp.moveaxis(difference, 0, -1)


def central_differences(fn: Callable, inputs, *args, select: Callable | None = None,
                        relative_step: float = DEFAULT_RELATIVE_STEP, step_floor: float = 1.0,
                        richardson: bool = False, batched: bool = True, batch_size: int | None = None,
                        call: Callable = _direct) -> np.ndarray:
    """Central differences of `fn(inputs, *args)` (a scalar or a vector of m outputs) with
    respect to every inexact leaf of `select(inputs)` (default: of `inputs`), flattened in
    `snapo_ode.flatten_inputs` order: shape (n,) for a scalar, (m, n) for a vector.

    **Arguments:**
    - `relative_step`, `step_floor`: the step is `relative_step * max(|x|, step_floor)`
      (`bump_steps`). `step_floor=1` suits inputs of order one or larger; `step_floor=0` makes
      every step relative, for inputs of very different magnitudes (a rate of 5e-8 next to an
      activation temperature of 1e4).
    - `richardson`: combine steps h and h/2 as (4 D(h/2) - D(h)) / 3 (error O(h^4)), so that
      h can be large enough for a solver's error divided by h to stay small.
    - `batched`: all bumped inputs in one vmapped program (in chunks of `batch_size` through
      `jax.lax.map` when given, to bound memory); otherwise a Python loop over a jitted
      revaluation, one bump at a time, as a desk's bump-and-revalue does.
    - `call`: how a compiled program is called, e.g.
      `functools.partial(snapo_ode.call_checked, what=...)` so that failed solves raise on the
      host and the program is cached.
    """
    part, _ = _selected(inputs, select)
    steps = bump_steps(flatten_inputs(part)[0], relative_step, step_floor)
    if not batched:
        return np.asarray(_differences(fn, inputs, args, select, steps, richardson, False, None, call))
    return np.asarray(call(bumps_program(fn, select, richardson, batch_size), inputs, args, jnp.asarray(steps)))


def bumps_program(fn, select=None, richardson: bool = False, batch_size: int | None = None):
    """The jitted program of every central bump of `fn` at once (vmapped; arguments as in
    `central_differences`): `(inputs, args, steps) -> differences`, `steps` shape (n,) from
    `bump_steps`. It is the program `compare_with_bumps` and `central_differences` run, for a
    caller that keeps it (`snapo_ode.exported`) or reads it ahead (`prefetch_checked`)."""
    return eqx.filter_jit(lambda inputs, args, steps: _differences(fn, inputs, args, select, steps, richardson,
                                                                   True, batch_size, _direct))


def bump_and_revalue(fn: Callable, inputs, *args, select: Callable | None = None,
                     relative_step: float = DEFAULT_RELATIVE_STEP, batched: bool = True,
                     batch_size: int | None = None):
    """Central bump-and-revalue of scalar `fn(inputs, *args)`, (f(x+h) - f(x-h)) / 2h per input
    with h = `relative_step * max(|x|, 1)`, as a pytree shaped like `select(inputs)` (default:
    `inputs`); see `central_differences`. Traceable when `batched`: it may run inside a jitted
    function."""
    part, _ = _selected(inputs, select)
    flat, rebuild = flatten_inputs(part)
    steps = relative_step * jnp.maximum(jnp.abs(flat), 1.0)
    if not batched:
        return rebuild(_differences(fn, inputs, args, select, steps, False, False, None, _direct))
    return rebuild(bumps_program(fn, select, False, batch_size)(inputs, args, steps))


class Agreement(NamedTuple):
    """How well an estimate (the adjoint) matches a reference (the bumps), entry by entry.

    - `max_rel_diff`: the largest |estimate - reference| / max(|reference|, floor * row max)
      over the entries that are not structural zeros.
    - `normwise`: the largest |estimate - reference| over its row's largest |reference|.
    - `at_structural_zeros`: where the estimate is exactly zero (an output that does not depend
      on an input, e.g. crystal size on the dryer), the largest |reference| over its row's
      largest: what the bumps see there (round-off); 0 when no zeros are split off.
    """

    max_rel_diff: float
    normwise: float
    at_structural_zeros: float


def _rows(tree) -> np.ndarray:
    """A 2-D array as it is (rows = outputs); any other pytree as one row of all its leaves."""
    if isinstance(tree, (np.ndarray, jax.Array)) and tree.ndim == 2:
        return np.asarray(tree)
    return np.concatenate([np.ravel(np.asarray(leaf)) for leaf in jax.tree.leaves(tree)])[None, :]


def agreement(estimate, reference, *, scales=None, floor: float = 1e-8, zero: float | None = None) -> Agreement:
    """Compare `estimate` with `reference`: 2-D arrays as matrices whose rows are outputs, any
    other pytrees (of the same structure) as one row of all their leaves.

    **Arguments:**
    - `scales`: optional per-input factors (shape (n,)) applied to both first, e.g. |x| to
      compare d y / d ln x, so that an input of size 1e-8 and one of size 1e4 weigh alike.
    - `floor`: an entry below `floor` times its row's largest |reference| is compared at that
      scale, not against round-off. `floor=1` gives the normwise figure.
    - `zero`: if given, entries where |estimate| <= `zero` times its row's largest are
      structural zeros: left out of `max_rel_diff` and reported in `at_structural_zeros`.
    """
    a, b = _rows(estimate).astype(float), _rows(reference).astype(float)
    if a.shape != b.shape:
        raise InputError(f"estimate has shape {a.shape} and reference {b.shape}; they must match.")
    if scales is not None:
        a, b = a * np.asarray(scales), b * np.asarray(scales)
    difference = np.abs(a - b)
    row_max = np.max(np.abs(b), axis=1, keepdims=True)
    scale = np.maximum(np.abs(b), floor * row_max)
    relative = np.where(difference == 0, 0.0, difference / np.where(scale == 0, 1.0, scale))
    normwise = float(np.max(np.where(difference == 0, 0.0, difference / np.where(row_max == 0, 1.0, row_max)),
                            initial=0.0))
    if zero is None:
        return Agreement(float(np.max(relative, initial=0.0)), normwise, 0.0)
    estimate_max = np.max(np.abs(a), axis=1, keepdims=True)
    structural = np.abs(a) <= zero * estimate_max
    at_zeros = np.abs(b) / np.where(row_max == 0, 1.0, row_max)
    return Agreement(float(np.max(relative[~structural], initial=0.0)), normwise,
                     float(np.max(at_zeros[structural], initial=0.0)))


def max_relative_difference(estimate, reference, *, floor: float = 1e-8) -> float:
    """`agreement(estimate, reference, floor=floor).max_rel_diff`: the largest per-entry
    relative difference, entries below `floor` times the largest compared at that scale."""
    return agreement(estimate, reference, floor=floor).max_rel_diff


class BumpComparison(NamedTuple):
    """The adjoint next to central bump-and-revalue of the same model, timed side by side in one
    run (medians after a first call; compile apart).

    - `value`: the function's value(s); `adjoint`: the gradient pytree (scalar `fn`) or the
      Jacobian matrix (vector `fn`); `bumped`: the central differences (same shape as the
      compared part of `adjoint`).
    - `agreement`: `Agreement` of the selected adjoint entries against the bumps.
    - `adjoint_seconds`, `adjoint_compile_seconds`: one reverse pass (all inputs at once).
    - `bump_seconds`, `bump_compile_seconds`: all bumps, batched (vmapped) in one program; None
      when they were not timed (`bump_repeats=0`).
    - `sequential_seconds`: with `sequential=True`, 2n times the median single revaluation (a
      desk's loop of identical revaluations), else None.
    - `speedup`: `bump_seconds / adjoint_seconds` (None untimed).
    - `forward_mode_seconds`, `forward_mode_compile_seconds`, `forward_mode_agreement`: with
      `forward_mode=True`, n vmapped tangents of the same part, else None.
    """

    value: Any
    adjoint: Any
    bumped: Any
    agreement: Agreement
    adjoint_seconds: float
    adjoint_compile_seconds: float
    bump_seconds: float | None
    bump_compile_seconds: float | None
    sequential_seconds: float | None
    speedup: float | None
    forward_mode_seconds: float | None = None
    forward_mode_compile_seconds: float | None = None
    forward_mode_agreement: Agreement | None = None

    @property
    def max_rel_diff(self) -> float:
        return self.agreement.max_rel_diff


def _forward_mode(fn, inputs, args, select, batch_size):
    """Forward-mode derivatives of `fn` with respect to the flattened `select(inputs)`: one
    vmapped tangent per input, in chunks of `batch_size`; shape (n,) or (m, n)."""
    part, put_back = _selected(inputs, select)
    flat, rebuild = flatten_inputs(part)

    def directional(tangent):
        return jax.jvp(lambda x: fn(put_back(rebuild(x)), *args), (flat,), (tangent,))[1]

    basis = jnp.eye(flat.size, dtype=flat.dtype)
    columns = jax.vmap(directional)(basis) if batch_size is None else jax.lax.map(directional, basis,
                                                                                  batch_size=batch_size)
    return jnp.moveaxis(columns, 0, -1)


def _bump_times(bump_timing: Timing | None, adjoint_timing: Timing) -> dict:
    """`BumpComparison`'s bump timings, None where the bumps were not timed."""
    if bump_timing is None:
        return {"bump_seconds": None, "bump_compile_seconds": None, "speedup": None}
    return {"bump_seconds": bump_timing.median_seconds, "bump_compile_seconds": bump_timing.compile_seconds,
            "speedup": bump_timing.median_seconds / adjoint_timing.median_seconds}


def compare_with_bumps(fn: Callable, inputs, *args, select: Callable | None = None, mode: JacobianMode = "auto",
                       adjoint_fn: Callable | None = None, bump_fn: Callable | None = None,
                       relative_step: float = DEFAULT_RELATIVE_STEP, step_floor: float = 1.0,
                       richardson: bool = False, batch_size: int | None = None, scales=None,
                       floor: float = 1e-8, zero: float | None = None, repeats: int = 3,
                       bump_repeats: int | None = None, sequential: bool = False, forward_mode: bool = False,
                       forward_batch_size: int | None = None, call: Callable = _direct) -> BumpComparison:
    """The adjoint sensitivities of `fn(inputs, *args)` against central bump-and-revalue, timed.

    **Arguments:**
    - `fn`: a scalar (gradient by one reverse pass, `value_and_sensitivities`, with respect to
      every input) or a vector (its `jacobian` in `mode`).
    - `select`: the part of `inputs` to bump (scalar `fn` only; default: all); the adjoint is
      still taken with respect to everything, and its `select` part is compared.
    - `adjoint_fn(inputs, *args) -> (value, gradient or matrix)`: the domain's own compiled
      sensitivity program, when it has one (so the comparison times what users run and does
      not compile a second copy); default: built from `fn`.
    - `bump_fn`: the function bumped (default `fn`), e.g. the same model at tighter solver
      tolerances than the adjoint's, so that the bumps' truncation error is not the solver's.
    - `relative_step`, `step_floor`, `richardson`, `batch_size`: as in `central_differences`.
    - `scales`, `floor`, `zero`: as in `agreement`.
    - `repeats` (adjoint) and `bump_repeats` (bumps and forward mode; default `repeats`, at
      least 1): timed calls after the first; `bump_repeats=0`: the bumps are a check only, run
      once and not timed (for a check, a second run only to time it is time lost; the pharma
      study's figure: docs/architecture.md); forward mode is then timed on one call after the first.
    - `sequential`: also time one revaluation and report 2n times its median.
    - `forward_mode`: also time forward mode on the same part (n tangents, vmapped, in chunks of
      `forward_batch_size` through `jax.lax.map` when given) and compare it with the adjoint.
    - `call`: how a compiled program is called (see `central_differences`).
    """
    scalar = eqx.filter_eval_shape(fn, inputs, *args).shape == ()
    if select is not None and not scalar:
        raise InputError("select is for a scalar fn; a vector fn is compared on every input.")
    if adjoint_fn is None:
        if scalar:
            adjoint_fn = eqx.filter_jit(lambda inputs, *args: value_and_sensitivities(fn, inputs, *args))
        else:
            adjoint_fn = eqx.filter_jit(lambda inputs, *args: (lambda j: (j.values, j.matrix))(
                jacobian(fn, inputs, *args, mode=mode)))
    adjoint_timing, (value, gradient) = time_function(functools.partial(call, adjoint_fn), inputs, *args,
                                                      repeats=repeats)
    part, put_back = _selected(inputs, select)
    compared = gradient if select is None else select(gradient)
    reference = bump_fn or fn
    bump_repeats = max(repeats, 1) if bump_repeats is None else bump_repeats

    steps = jnp.asarray(bump_steps(flatten_inputs(part)[0], relative_step, step_floor))
    program = bumps_program(reference, select, richardson, batch_size)
    if bump_repeats:
        bump_timing, bumped = time_function(functools.partial(call, program), inputs, args, steps,
                                            repeats=bump_repeats)
    else:
        bump_timing, bumped = None, call(program, inputs, args, steps)
    bumped = np.asarray(bumped)
    if scalar:
        _, rebuild = flatten_inputs(part)
        bumped = rebuild(jnp.asarray(bumped))
    sequential_seconds = None
    if sequential:
        flat, rebuild = flatten_inputs(part)
        single = jax.jit(lambda vector: reference(put_back(rebuild(vector)), *args))
        single_timing, _ = time_function(functools.partial(call, single), flat, repeats=max(repeats, 5))
        sequential_seconds = 2 * flat.shape[0] * single_timing.median_seconds
    # A scalar's gradient is one row, whatever the shapes of its leaves.
    as_rows = (lambda tree: (eqx.filter(tree, eqx.is_inexact_array),)) if scalar else (lambda tree: tree)
    result = BumpComparison(
        value=value, adjoint=gradient, bumped=bumped,
        agreement=agreement(as_rows(compared), as_rows(bumped), scales=scales, floor=floor, zero=zero),
        adjoint_seconds=adjoint_timing.median_seconds, adjoint_compile_seconds=adjoint_timing.compile_seconds,
        sequential_seconds=sequential_seconds, **_bump_times(bump_timing, adjoint_timing))
    if not forward_mode:
        return result
    forward = eqx.filter_jit(lambda inputs, *args: _forward_mode(fn, inputs, args, select, forward_batch_size))
    forward_timing, columns = time_function(functools.partial(call, forward), inputs, *args, repeats=bump_repeats)
    _, rebuild = flatten_inputs(part)
    tangents = rebuild(columns) if scalar else columns
    return result._replace(
        forward_mode_seconds=forward_timing.median_seconds,
        forward_mode_compile_seconds=forward_timing.compile_seconds,
        forward_mode_agreement=agreement(as_rows(compared), as_rows(tangents), scales=scales, floor=floor,
                                         zero=zero))
