"""A variable-order BDF solver for forward solves of stiff ODEs: the numerical differentiation
formulas of orders 1-5 (Shampine & Reichelt, "The MATLAB ODE Suite", SIAM J. Sci. Comput. 18,
1997), in the quasi-constant step size form with a backward-difference array that is
re-expressed whenever the step changes.

Why a second stiff family beside `snapo_ode.Rodas5`: a Rosenbrock step needs the exact Jacobian
and a new factorisation at every step and evaluates the vector field once per stage (8 times
for Rodas5), while a BDF step solves one implicit equation by a Newton iteration that reuses its
Jacobian over many steps and its factorisation until the step size or order changes, as CVODES
does (measured with Cantera's CVODES on the ignition benchmark at rtol 1e-10: h2o2 in 261 steps
with 5 Jacobians and 306 evaluations, gri30 in 397 steps with 7 Jacobians). Rodas5 itself cannot
reuse its Jacobian: with one 2-5 steps old, the same h2o2 ignition took 3,000-3,600 steps
instead of 239.

A solve runs in two loops. The search (`_search`, values only) takes the steps: predictor,
Newton iteration, error test, step size and order; it records what each accepted step decided
(its end, size, order, the net rescaling before it), the differences its predictor used and its
converged corrector increment. The replay (`_replay`) goes over the accepted steps again with
those decisions held, as plain arithmetic on the differences, and with the increment d, which
solves d - c f(t, y_pred + d, args) + psi = 0, differentiated implicitly (one exact Jacobian at
the converged state and one solve a step, `_corrected`) rather than through the Newton
iterations. Derivatives are thus those of the discrete solution with the step sizes and orders
held as taken (decisions, not functions of the inputs); the values are the search's. The replay
is a `jax.lax.while_loop` for forward mode, or equinox's checkpointed loop for reverse mode,
whose checkpoints hold the differences only (measured on a gri30 gradient: 31 MB of XLA
temporaries, against 203 MB when the search itself, its Jacobian and factorisation included,
was checkpointed). The replay costs 10-25% of a values-only solve (h2o2 4.8 -> 6.1 ms, gri30
28.4 -> 31 ms), which runs it too: nothing tells a trace whether it will be differentiated.
"""

import functools
from typing import NamedTuple

import equinox.internal as eqxi
import jax
import jax.numpy as jnp
import jax.scipy.linalg as jsl
import numpy as np

from ._bdf_formulas import ALPHA, ERROR_CONSTANT, MAX_ORDER, ROWS, interpolate, predict, rescale, rms, update

NEWTON_ITERATIONS = 4
"""Newton iterations per attempt; a slower one refreshes the Jacobian, then halves the step."""
MIN_FACTOR, MAX_FACTOR = 0.2, 10.0
"""Bounds of a step size change after a rejected or an accepted step."""


class BdfStats(NamedTuple):
    """Counts of one solve: accepted steps, attempts not accepted (failed error test, or a Newton
    iteration that did not converge), Jacobians, LU factorisations and vector-field evaluations
    (Newton iterations and the initial step's two)."""

    num_accepted_steps: jax.Array
    num_rejected_steps: jax.Array
    num_jacobians: jax.Array
    num_factorisations: jax.Array
    num_evaluations: jax.Array


class _Record(NamedTuple):
    """The accepted steps of a search, each row one step: `start` and `end` [time], `order`, the
    net `rescale` of the differences since the previous step's update (clipping at t1, rejected
    attempts, the previous step's change of size), the `differences` its predictor used (shape
    `(max_steps, MAX_ORDER + 3, n)`) and its converged `increment` d (shape `(max_steps, n)`)."""

    start: jax.Array
    end: jax.Array
    order: jax.Array
    rescale: jax.Array
    differences: jax.Array
    increment: jax.Array


class _Search(NamedTuple):
    t: jax.Array
    h: jax.Array
    order: jax.Array
    differences: jax.Array  # (MAX_ORDER + 3, n)
    jacobian: jax.Array
    lu: jax.Array
    pivots: jax.Array
    factorised: jax.Array  # the LU is of I - c J for the current h, order and J
    fresh_jacobian: jax.Array  # J was evaluated during this step's attempts
    equal_steps: jax.Array
    pending: jax.Array  # the rescaling since the last update
    record: _Record
    stats: BdfStats
    collapsed: jax.Array


def _initial_step(rate, t0, t1, y0, f0, rtol, atol):
    """A first step for order 1 from the size of y0, f0 and the change of f over a trial step
    (Hairer, Norsett & Wanner, Solving ODEs I, sec. II.4); one more evaluation."""
    scale = atol + rtol * jnp.abs(y0)
    d0, d1 = rms(y0 / scale), rms(f0 / scale)
    h0 = jnp.where((d0 < 1e-5) | (d1 < 1e-5), 1e-6, 0.01 * d0 / d1)
    h0 = jnp.minimum(h0, t1 - t0)
    d2 = rms((rate(t0 + h0, y0 + h0 * f0) - f0) / scale) / h0
    small = (d1 <= 1e-15) & (d2 <= 1e-15)
    h1 = jnp.where(small, jnp.maximum(1e-6, h0 * 1e-3), jnp.sqrt(0.01 / jnp.maximum(jnp.maximum(d1, d2), 1e-300)))
    return jnp.minimum(jnp.minimum(100.0 * h0, h1), t1 - t0)


@functools.partial(jax.custom_jvp, nondiff_argnums=(0, 1))
def _corrected(vector_field, jacobian, t, c, increment, predicted, psi, args, field_consts, jacobian_consts):
    """The corrector's converged `increment` d (found by the Newton iteration), as a function of
    `predicted`, `psi`, `args` and the values f closes over: d solves
    d - `c` f(`t`, `predicted` + d, `args`) + `psi` = 0. The functions are closure-converted
    (`jax.closure_convert`: `vector_field(t, y, args, *field_consts)`), so that what they close
    over (a model's parameters) is differentiated too. The value is `increment` itself; the
    tangent is the implicit function's (see the JVP)."""
    return increment


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


def _search(rate, jacobian, t0, t1, differences, h, *, rtol, atol, max_steps):
    """The search loop (values only, see the module docstring): `rate(t, y)`, `jacobian(t, y)`,
    the initial `differences` and step `h`. Returns the `_Record`, `BdfStats` and the status."""
    dtype = differences.dtype
    n = differences.shape[1]
    eye = jnp.eye(n, dtype=dtype)
    newton_tol = max(10 * np.finfo(np.float64).eps / rtol, min(0.03, rtol ** 0.5))
    alpha, error_constant = jnp.asarray(ALPHA, dtype), jnp.asarray(ERROR_CONSTANT, dtype)
    zero = jnp.zeros((), jnp.int32)

    def newton(t_new, y_predicted, psi, c, lu, pivots, scale):
        """The Newton iteration for the corrector's increment d: whether it converged, its
        iterations, and d."""

        def step(carry):
            k, y, d, norm_old, _, _ = carry
            f = rate(t_new, y)
            dy = jsl.lu_solve((lu, pivots), c * f - psi - d)
            norm = rms(dy / scale)
            ratio = norm / norm_old  # inf on the first iteration (norm_old = 0 there)
            first = k == 0
            diverging = ~first & ((ratio >= 1.0) | (ratio ** (NEWTON_ITERATIONS - k) / (1.0 - ratio) * norm > newton_tol))
            bad = ~jnp.all(jnp.isfinite(f)) | diverging
            y, d = jnp.where(bad, y, y + dy), jnp.where(bad, d, d + dy)
            done = ~bad & ((norm == 0.0) | (~first & (ratio / (1.0 - ratio) * norm < newton_tol)))
            return k + 1, y, d, norm, done, bad | done

        carry = (zero, y_predicted, jnp.zeros_like(y_predicted), jnp.zeros((), dtype), jnp.asarray(False),
                 jnp.asarray(False))
        k, _, d, _, converged, _ = jax.lax.while_loop(lambda carry: ~carry[5] & (carry[0] < NEWTON_ITERATIONS),
                                                      step, carry)
        return converged, k, d

    def attempt(s: _Search) -> _Search:
        # A step that would pass t1 ends there.
        over = s.t + s.h > t1
        h = jnp.where(over, t1 - s.t, s.h)
        differences = jnp.where(over, rescale(s.differences, s.order, h / s.h), s.differences)
        pending = jnp.where(over, s.pending * h / s.h, s.pending)
        factorised = s.factorised & ~over
        equal_steps = jnp.where(over, 0, s.equal_steps)
        t_new = jnp.where(over, t1, s.t + h)
        order = s.order

        c = h / alpha[order]
        lu, pivots = jax.lax.cond(factorised, lambda: (s.lu, s.pivots), lambda: jsl.lu_factor(eye - c * s.jacobian))
        y_predicted, psi = predict(differences, order)
        converged, iterations, d = newton(t_new, y_predicted, psi, c, lu, pivots, atol + rtol * jnp.abs(y_predicted))

        # Not converged: with an old Jacobian, take a new one (same step); else halve the step.
        refresh = ~converged & ~s.fresh_jacobian
        halve = ~converged & s.fresh_jacobian
        jacobian_ = jax.lax.cond(refresh, lambda: jacobian(t_new, y_predicted), lambda: s.jacobian)

        # The error test of a converged step.
        scale = atol + rtol * jnp.abs(y_predicted + d)
        error = rms(error_constant[order] * d / scale)
        safety = 0.9 * (2 * NEWTON_ITERATIONS + 1) / (2 * NEWTON_ITERATIONS + iterations)
        accepted = converged & (error <= 1.0)
        rejected = converged & ~accepted
        shrink = jnp.where(halve, 0.5, jnp.maximum(MIN_FACTOR, safety * error ** (-1.0 / (order + 1))))

        # After order + 1 equal steps, the order (one down, the same, one up) and the step that
        # promise the largest step.
        updated = update(differences, d, order)
        change = accepted & (equal_steps + 1 >= order + 1)
        error_down = jnp.where(order > 1, rms(error_constant[order - 1] * updated[order] / scale), jnp.inf)
        error_up = jnp.where(order < MAX_ORDER, rms(
            error_constant[order + 1] * updated[jnp.minimum(order + 2, ROWS - 1)] / scale), jnp.inf)
        factors = jnp.stack([error_down, error, error_up]) ** (-1.0 / (order + jnp.arange(3)))
        grow = jnp.minimum(MAX_FACTOR, safety * jnp.max(factors))

        order_next = jnp.where(change, order + jnp.argmax(factors) - 1, order).astype(order.dtype)
        resized = change | halve | rejected
        factor = jnp.where(change, grow, jnp.where(resized, shrink, 1.0))
        base = jnp.where(accepted, updated, differences)
        # Every attempt writes the row of the next accepted step: one that is not accepted is
        # overwritten by the next that is (a select over the whole record would cost more than
        # the step).
        record = jax.tree.map(lambda rows, row: rows.at[s.stats.num_accepted_steps].set(row), s.record,
                              _Record(s.t, t_new, order, pending, differences, d))
        stats = BdfStats(*(count.astype(jnp.int32) for count in (
            s.stats.num_accepted_steps + accepted, s.stats.num_rejected_steps + ~accepted,
            s.stats.num_jacobians + refresh, s.stats.num_factorisations + ~factorised,
            s.stats.num_evaluations + iterations)))
        h_next = h * factor
        t_next = jnp.where(accepted, t_new, s.t)
        return _Search(t_next, h_next, order_next, jnp.where(resized, rescale(base, order_next, factor), base),
                       jacobian_, lu, pivots, ~resized & ~refresh, (s.fresh_jacobian | refresh) & ~accepted,
                       jnp.where(resized, 0, equal_steps + accepted).astype(jnp.int32),
                       jnp.where(accepted, 1.0, pending) * factor, record, stats,
                       h_next < 10 * jnp.finfo(dtype).eps * jnp.abs(t_next))

    def unfinished(s: _Search):
        attempts = s.stats.num_accepted_steps + s.stats.num_rejected_steps
        return (s.t < t1) & (attempts < max_steps) & ~s.collapsed

    one = jnp.ones((), jnp.int32)
    record = _Record(jnp.zeros(max_steps, dtype), jnp.zeros(max_steps, dtype), jnp.ones(max_steps, jnp.int32),
                     jnp.ones(max_steps, dtype), jnp.zeros((max_steps, ROWS, n), dtype),
                     jnp.zeros((max_steps, n), dtype))
    y0 = differences[0]
    state = _Search(jnp.asarray(t0, dtype), h, one, differences, jacobian(t0, y0), jnp.zeros((n, n), dtype),
                    jnp.zeros(n, jnp.int32), jnp.asarray(False), jnp.asarray(True), zero, jnp.ones((), dtype),
                    record, BdfStats(zero, zero, one, zero, 2 * one), jnp.asarray(False))
    final = jax.lax.while_loop(unfinished, attempt, state)
    status = jnp.where(final.t >= t1, 0, jnp.where(final.collapsed, 2, 1))
    return final.record, final.stats, status


def _replay(field, jacobian, args, field_consts, jacobian_consts, differences, record, count, ts, *, reverse,
            checkpoints):
    """The solution at `ts` from the recorded steps (see the module docstring), differentiable in
    `differences` (the initial ones), `args` and the consts; `count` steps of `record`."""
    dtype = differences.dtype
    alpha = jnp.asarray(ALPHA, dtype)
    y0 = differences[0]

    def step(carry):
        k, differences, saved = carry
        start, end, order, factor, searched, increment = jax.tree.map(lambda rows: rows[k], record)
        # Under jax.vmap the loop goes on for a member that has finished (k >= count): its step
        # is then a no-op at the initial state with c = 0, every quantity finite, so that the
        # discarded branch sends no 0 * NaN into a reverse pass.
        active = k < count
        h = jnp.where(active, end - start, 1.0)
        differences = rescale(differences, order, jnp.where(active, factor, 1.0))
        # The values are the search's, the derivatives those of this recomputation: replayed
        # with its increments held, the recurrence would drift from the search's values by
        # round-off that nothing corrects (measured: 1e-12 at the first order-5 step of a stiff
        # linear system, 1e-6 after 170 more).
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

    saved = jnp.where((ts <= record.start[0])[:, None] | (count == 0), y0, jnp.zeros((ts.size, y0.size), dtype))
    carry = (jnp.zeros((), jnp.int32), differences, saved)
    if reverse:
        carry = eqxi.while_loop(lambda carry: carry[0] < count, step, carry, max_steps=record.start.size,
                                kind="checkpointed", checkpoints=checkpoints)
    else:
        carry = jax.lax.while_loop(lambda carry: carry[0] < count, step, carry)
    return carry[2]


def bdf_solve(vector_field, jacobian, t0, t1, y0, args, ts, *, rtol: float, atol: float, max_steps: int,
              reverse: bool = False, checkpoints: int | None = None):
    """Integrate dy/dt = `vector_field(t, y, args)` (y of shape `(n,)`) from `t0` to `t1` > `t0`.

    **Arguments:** `jacobian(t, y, args)`: df/dy, shape `(n, n)`; `ts`: the output times, shape
    `(n_ts,)`, increasing within [t0, t1]; `rtol`, `atol`: the local error test on
    `atol + rtol |y|` (root mean square); `max_steps`: attempted steps at most; `reverse`: replay
    the steps so that reverse mode can differentiate them (equinox's checkpointed loop, with
    `checkpoints`, default `max_steps`; forward mode then cannot).

    **Returns:** `(ys, stats, status)`: the solution at `ts` (shape `(n_ts, n)`, from the
    interpolant of the step that covers each time), `BdfStats`, and 0 (reached t1), 1 (max_steps
    reached) or 2 (the step size collapsed, or the Newton iteration never converged).
    """
    t0, t1 = jax.lax.stop_gradient(t0), jax.lax.stop_gradient(t1)
    # What the functions close over (e.g. a model's parameters) as arguments, so that the replay
    # differentiates with respect to it; the search sees it without gradient.
    field, field_consts = jax.closure_convert(vector_field, t0, y0, args)
    jacobian_fn, jacobian_consts = jax.closure_convert(jacobian, t0, y0, args)
    frozen = jax.lax.stop_gradient((y0, args, field_consts, jacobian_consts))

    def rate(t, y):
        return field(t, y, frozen[1], *frozen[2])

    def frozen_jacobian(t, y):
        return jacobian_fn(t, y, frozen[1], *frozen[3])

    f0 = field(t0, y0, args, *field_consts)
    h = jax.lax.stop_gradient(_initial_step(rate, t0, t1, frozen[0], jax.lax.stop_gradient(f0), rtol, atol))
    differences = jnp.zeros((ROWS, y0.size), y0.dtype).at[0].set(y0).at[1].set(h * f0)
    record, stats, status = _search(rate, frozen_jacobian, t0, t1, jax.lax.stop_gradient(differences), h,
                                    rtol=rtol, atol=atol, max_steps=max_steps)
    ys = _replay(field, jacobian_fn, args, field_consts, jacobian_consts, differences, record,
                 stats.num_accepted_steps, ts, reverse=reverse, checkpoints=checkpoints or max_steps)
    return ys, stats, status
