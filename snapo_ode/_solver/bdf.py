"""A variable-order BDF solver for forward solves of stiff ODEs: the numerical differentiation
formulas of orders 1-5 (Shampine & Reichelt, "The MATLAB ODE Suite", SIAM J. Sci. Comput. 18,
1997), in the quasi-constant step size form with a backward-difference array that is
re-expressed whenever the step changes.

Why a second stiff family beside `snapo_ode.Rodas5`: a Rosenbrock step needs the exact Jacobian
and a new factorisation at every step and evaluates the vector field once per stage (8 times
for Rodas5), while a BDF step solves one implicit equation by a Newton iteration that reuses its
Jacobian over many steps and its factorisation until the step size or order changes, as CVODES
does. Rodas5 itself cannot reuse its Jacobian: with an old one it takes many times the steps
(the measurements: docs/architecture.md, Measurements behind the design).

The search (`snapo_ode._solver.bdf_search`) takes the steps: predictor, Newton iteration, error test,
step size and order. Derivatives are those of the discrete solution with the step sizes and
orders held as taken (decisions, not functions of the inputs), and the corrector's increment d,
which solves d - c f(t, y_pred + d, args) + psi = 0, is differentiated implicitly (one exact
Jacobian at the converged state and one solve a step, `_corrected`), not through the Newton
iterations. Forward mode differentiates the search itself (`jax.lax.while_loop`). Reverse mode
cannot (a while loop), so there the search records each accepted step (its decisions, the
differences its predictor used, its increment: `max_steps` rows) and the backward pass replays
them (`_replay`, in equinox's checkpointed loop, whose checkpoints hold the differences only,
not the search's Jacobian and factorisation: a fraction of the memory). Both are behind a
`jax.custom_vjp` (`_reverse_solve`), so that a solve nobody differentiates records nothing
(allocating the record costs more than a solve on a large mechanism).
"""

import functools

import diffrax
import equinox as eqx
import equinox.internal as eqxi
import jax
import jax.numpy as jnp
from jax.flatten_util import ravel_pytree

from .._ode import SolveResult, checked_ys
from .._platform.validation import InputError
from .base import AbstractSolver, output_times, solution
from .bdf_formulas import ALPHA, ROWS, initial_outputs, interpolate, predict, rescale, update
from .bdf_search import _initial_step, _search


@functools.partial(jax.custom_jvp, nondiff_argnums=(0, 1))
def _corrected(vector_field, jacobian, t, c, increment, predicted, psi, args, field_consts, jacobian_consts):
    """The corrector's converged `increment` d (found by the Newton iteration), as a function of
    `predicted`, `psi`, `args` and the values f closes over: d solves
    d - `c` f(`t`, `predicted` + d, `args`) + `psi` = 0. The functions are closure-converted
    (`_hoisted`: `vector_field(t, y, args, *field_consts)`), so that what they close
    over (a model's parameters) is differentiated too. The value is `increment` itself; the
    tangent is the implicit function's (see the JVP)."""
    return increment


def _hoisted(fn, t0, y0, args):
    """`fn(t, y, args)` as `(converted, consts)` with `converted(t, y, args, *consts)`: every
    tracer `fn` closes over hoisted into `consts` (`equinox.filter_closure_convert`; constants
    stay closed over, as `jax.closure_convert` leaves them). `jax.closure_convert` also leaves
    integer tracers closed over: under an outer `jit` they then leak out of the custom rules and
    fail the lowering ("No constant handler for type: DynamicJaxprTracer"; the pharma chain's
    index arrays did, in both modes)."""
    consts, static = eqx.partition(eqx.filter_closure_convert(fn, t0, y0, args),
                                   lambda leaf: isinstance(leaf, jax.core.Tracer))
    leaves, treedef = jax.tree.flatten(consts)

    def converted(t, y, args, *leaves):
        return eqx.combine(jax.tree.unflatten(treedef, leaves), static)(t, y, args)

    return converted, leaves


@functools.partial(jax.custom_jvp, nondiff_argnums=(0, 1))
def _timed(vector_field, sign, times, ys, args, field_consts):
    """`ys` (shape `(n_t, n)`) as they are, with their derivative with respect to `times` (which
    the solve itself holds fixed): `sign` f(t, y) dt. +1 for the outputs (d y(tau) / d tau = f);
    -1 for the initial state (moving the start by dt0 is moving y0 by -f(t0, y0) dt0)."""
    return ys


@_timed.defjvp
def _timed_jvp(vector_field, sign, primals, tangents):
    times, ys, args, field_consts = primals
    times_dot, ys_dot, _, _ = tangents
    rates = jax.vmap(lambda t, y: vector_field(t, y, args, *field_consts))(times, ys)
    return ys, ys_dot + sign * rates * times_dot[:, None]


@_corrected.defjvp
def _corrected_jvp(vector_field, jacobian, primals, tangents):
    t, c, increment, predicted, psi, args, field_consts, jacobian_consts = primals
    _, _, _, predicted_dot, psi_dot, args_dot, consts_dot, _ = tangents
    state = predicted + increment
    # (I - c J) dd = c (J dpredicted + f_args dargs + f_consts dconsts) - dpsi, with J at the
    # converged state: linear in the tangents (one JVP of f, one solve), so reverse mode
    # transposes it.
    _, rate_dot = jax.jvp(lambda y, a, consts: vector_field(t, y, a, *consts), (state, args, field_consts),
                          (predicted_dot, args_dot, consts_dot))
    matrix = jnp.eye(state.size, dtype=state.dtype) - c * jacobian(t, state, args, *jacobian_consts)
    return increment, jnp.linalg.solve(matrix, c * rate_dot - psi_dot)


def _replay(field, jacobian, args, field_consts, jacobian_consts, differences, record, count, t0, ts, *,
            checkpoints):
    """The solution at `ts` from the recorded steps (see the module docstring), differentiable in
    `differences` (the initial ones), `args` and the consts; `count` steps of `record`."""
    dtype = differences.dtype
    alpha = jnp.asarray(ALPHA, dtype)
    y0 = differences[0]

    def step(carry):
        k, differences, saved = carry
        start, end, h, order, factor, searched, increment = jax.tree.map(lambda rows: rows[k], record)
        # Under jax.vmap the loop goes on for a member that has finished (k >= count): its step
        # is then a no-op at the initial time and state with c = 0, every quantity finite (its
        # row of the record was never written), so that the discarded branch sends no 0 * NaN
        # into a reverse pass.
        active = k < count
        h = jnp.where(active, h, 1.0)
        end = jnp.where(active, end, t0)
        differences = rescale(differences, order, jnp.where(active, factor, 1.0))
        # The values are the search's, the derivatives those of this recomputation: replayed
        # with its increments held, the recurrence would drift from the search's values by
        # round-off that nothing corrects and that grows step after step.
        differences = jnp.where(active, searched, differences) + (differences - jax.lax.stop_gradient(differences))
        predicted, psi = predict(differences, order)
        predicted = jnp.where(active, predicted, y0)
        c = jnp.where(active, h / alpha[order], 0.0)
        d = _corrected(field, jacobian, end, c, jnp.where(active, increment, 0.0), predicted, psi, args,
                       field_consts, jacobian_consts)
        updated = update(differences, d, order)
        within = active & (ts > start) & (ts <= end)
        saved = jnp.where(within[:, None], interpolate(updated, order, end, h, ts), saved)
        return k + 1, jnp.where(active, updated, differences), saved

    carry = (jnp.zeros((), jnp.int32), differences, initial_outputs(ts, t0, y0))
    carry = eqxi.while_loop(lambda carry: carry[0] < count, step, carry, max_steps=record.start.size,
                            kind="checkpointed", checkpoints=checkpoints)
    return carry[2]


def _frozen(field, jacobian, args, field_consts, jacobian_consts):
    """The rate and the Jacobian as the search sees them: functions of (t, y), without gradient."""
    args, field_consts, jacobian_consts = jax.lax.stop_gradient((args, field_consts, jacobian_consts))
    return (lambda t, y: field(t, y, args, *field_consts)), (lambda t, y: jacobian(t, y, args, *jacobian_consts))


def _initial_differences(field, t0, y0, args, field_consts, h):
    """D_0 = y0, D_1 = h f(t0, y0), the rest 0: shape `(MAX_ORDER + 3, n)`."""
    f0 = field(t0, y0, args, *field_consts)
    return jnp.zeros((ROWS, y0.size), y0.dtype).at[0].set(y0).at[1].set(h * f0)


def _searched(field, jacobian, options, t0, t1, h, ts, y0, args, field_consts, jacobian_consts, *, record=False,
              corrector=None):
    """`_search` of the model from y0: values only (optionally recording its steps), or with
    forward-mode derivatives through `corrector`."""
    rtol, atol, max_steps, _ = options
    rate, jacobian_ = _frozen(field, jacobian, args, field_consts, jacobian_consts)
    differences = _initial_differences(field, t0, y0, args, field_consts, h)
    return _search(rate, jacobian_, t0, t1, differences, h, ts, rtol=rtol, atol=atol, max_steps=max_steps,
                   corrector=corrector, record=record)


@functools.partial(jax.custom_vjp, nondiff_argnums=(0, 1, 2))
def _reverse_solve(field, jacobian, options, t0, t1, h, ts, y0, args, field_consts, jacobian_consts):
    """The solve for `differentiation="reverse"`: the search alone when nothing differentiates it;
    under reverse mode the search records its steps and the backward pass replays them
    (`_replay`). `options`: (rtol, atol, max_steps, checkpoints)."""
    saved, _, stats, status = _searched(field, jacobian, options, t0, t1, h, ts, y0, args, field_consts,
                                        jacobian_consts, record=False)
    return saved, stats, status


def _reverse_solve_forward(field, jacobian, options, t0, t1, h, ts, y0, args, field_consts, jacobian_consts):
    saved, record, stats, status = _searched(field, jacobian, options, t0, t1, h, ts, y0, args, field_consts,
                                             jacobian_consts, record=True)
    residuals = (record, stats.num_accepted_steps, t0, t1, h, ts, y0, args, field_consts, jacobian_consts)
    return (saved, stats, status), residuals


def _reverse_solve_backward(field, jacobian, options, residuals, cotangents):
    record, count, t0, t1, h, ts, y0, args, field_consts, jacobian_consts = residuals

    def replayed(y0, args, field_consts, jacobian_consts):
        differences = _initial_differences(field, t0, y0, args, field_consts, h)
        return _replay(field, jacobian, args, field_consts, jacobian_consts, differences, record, count, t0, ts,
                       checkpoints=options[3])

    _, pullback = jax.vjp(replayed, y0, args, field_consts, jacobian_consts)
    return (jnp.zeros_like(t0), jnp.zeros_like(t1), jnp.zeros_like(h), jnp.zeros_like(ts), *pullback(cotangents[0]))


_reverse_solve.defvjp(_reverse_solve_forward, _reverse_solve_backward)


def bdf_solve(vector_field, jacobian, t0, t1, y0, args, ts, *, rtol: float, atol: float, max_steps: int,
              reverse: bool = False, checkpoints: int | None = None):
    """Integrate dy/dt = `vector_field(t, y, args)` (y of shape `(n,)`) from `t0` to `t1` > `t0`.

    **Arguments:** `jacobian(t, y, args)`: df/dy, shape `(n, n)`; `ts`: the output times, shape
    `(n_ts,)`, increasing within [t0, t1]; `rtol`, `atol`: the local error test on
    `atol + rtol |y|` (root mean square); `max_steps`: attempted steps at most; `reverse`: for
    reverse mode (the search records its accepted steps, `max_steps` rows of (MAX_ORDER + 4) n
    numbers, only when differentiated, and the backward pass replays them in equinox's
    checkpointed loop with `checkpoints`, default `max_steps`); else forward mode, through the
    search itself.

    **Returns:** `(ys, stats, result)`: the solution at `ts` (shape `(n_ts, n)`, from the
    interpolant of the step that covers each time), `BdfStats`, and a `snapo_ode.SolveResult`:
    successful (reached t1), max_steps_reached, failed (the step size collapsed, or the Newton
    iteration never converged) or times_out_of_range (t1 <= t0, or an output time outside
    [t0, t1]). Differentiable in `y0`, `args`, what the functions close
    over, `t0` and `ts` (d y(tau) / d tau = f), not in `t1` beyond the output times.
    """
    # What the functions close over (e.g. a model's parameters) as arguments, so that it is
    # differentiated too; the search's Newton iteration and decisions see it without gradient.
    # Python numbers in `args` become arrays: the custom rules receive them as arrays, and the
    # hoisted functions are called as they were converted.
    args = jax.tree.map(lambda leaf: jnp.asarray(leaf) if eqx.is_array_like(leaf) else leaf, args)
    field, field_consts = _hoisted(vector_field, t0, y0, args)
    jacobian_fn, jacobian_consts = _hoisted(jacobian, t0, y0, args)
    timed_t0, timed_ts = t0, ts
    t0, t1, ts = jax.lax.stop_gradient((t0, t1, ts))
    y0 = _timed(field, -1.0, jnp.atleast_1d(timed_t0), y0[None], args, field_consts)[0]
    rate, _ = _frozen(field, jacobian_fn, args, field_consts, jacobian_consts)
    frozen_y0 = jax.lax.stop_gradient(y0)
    h = jax.lax.stop_gradient(_initial_step(rate, t0, t1, frozen_y0, rate(t0, frozen_y0), rtol, atol))
    options = (rtol, atol, max_steps, checkpoints or max_steps)
    if reverse:
        saved, stats, status = _reverse_solve(field, jacobian_fn, options, t0, t1, h, ts, y0, args, field_consts,
                                              jacobian_consts)
    else:
        def corrector(t, c, increment, predicted, psi):
            return _corrected(field, jacobian_fn, t, c, increment, predicted, psi, args, field_consts,
                              jacobian_consts)

        saved, _, stats, status = _searched(field, jacobian_fn, options, t0, t1, h, ts, y0, args, field_consts,
                                            jacobian_consts, corrector=corrector)
    result = SolveResult.where(status == 0, SolveResult.successful, SolveResult.where(
        status == 1, SolveResult.max_steps_reached, SolveResult.failed))
    # Traced times out of order (`BDF.solve` checks concrete ones before the solve).
    result = SolveResult.where((t1 > t0) & jnp.all((ts >= t0) & (ts <= t1)), result, SolveResult.times_out_of_range)
    return _timed(field, 1.0, timed_ts, saved, args, field_consts), stats, result


class BDF(AbstractSolver):
    """`bdf_solve` as a `SolverSettings` solver (`solver="bdf"`): no options of its own (the error
    test takes the settings' rtol and atol); values at given times only; derivatives by the
    settings' `differentiation`, "reverse" (recorded steps replayed) or "forward" (`jax.jvp`,
    `jax.jacfwd`; under "reverse" forward mode raises JAX's custom_vjp error)."""

    def solve(self, settings, vector_field, t0, t1, y0, args, saveat, jacobian) -> diffrax.Solution:
        ts = jnp.asarray(output_times(self, saveat, t1), float)
        y0 = jax.tree.map(lambda x: x if jnp.issubdtype(jnp.result_type(x), jnp.inexact) else jnp.asarray(x, float), y0)
        if not any(isinstance(x, jax.core.Tracer) for x in (t0, t1, ts)) and not (
                float(t0) < float(t1) and float(t0) <= float(jnp.min(ts)) and float(jnp.max(ts)) <= float(t1)):
            raise InputError(f"solver = 'bdf' integrates forward from t0 = {float(t0):g} to t1 = {float(t1):g} "
                             f"(t0 < t1) and saves within [t0, t1]; saveat.ts spans {float(jnp.min(ts)):g} to "
                             f"{float(jnp.max(ts)):g}.")
        y0_flat, unravel = ravel_pytree(y0)

        def rate(t, y, args):
            return ravel_pytree(vector_field(t, unravel(y), args))[0]

        def jacobian_flat(t, y, args):
            return jax.jacfwd(rate, argnums=1)(t, y, args) if jacobian is None else jacobian(t, unravel(y), args)

        ys, stats, result = bdf_solve(rate, jacobian_flat, jnp.asarray(t0, float), jnp.asarray(t1, float), y0_flat,
                                      args, ts, rtol=settings.rtol, atol=settings.atol, max_steps=settings.max_steps,
                                      reverse=settings.differentiation == "reverse",
                                      checkpoints=settings.checkpoints)
        return solution(t0, t1, ts, jax.vmap(unravel)(checked_ys(ys, result)), stats._asdict())

    def controller_description(self, settings) -> str:
        return "the BDF's own error test and order selection (snapo_ode._solver.bdf)"
