"""The search loop of `snapo_ode._solver.bdf`: predictor, Newton iteration on a reused factorisation,
error test, step size and order, with the Jacobian renewed only when an iteration fails to
converge; optionally recording each accepted step for the replay (reverse mode)."""

from typing import NamedTuple

import jax
import jax.numpy as jnp
import jax.scipy.linalg as jsl
import numpy as np

from .bdf_formulas import (ALPHA, ERROR_CONSTANT, MAX_ORDER, ROWS, initial_outputs, interpolate, predict, rescale,
                            rms, update)

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
    """The accepted steps of a search, each row one step: `start` and `end` [time] and its `step`
    size h (end - start rounds differently), `order`, the net `rescale` of the differences since
    the previous step's update (clipping at t1, rejected attempts, the previous step's change of
    size), the `differences` its predictor used (shape `(max_steps, MAX_ORDER + 3, n)`) and its
    converged `increment` d (shape `(max_steps, n)`)."""

    start: jax.Array
    end: jax.Array
    step: jax.Array
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
    record: _Record | None
    saved: jax.Array  # (n_ts, n)
    stats: BdfStats
    collapsed: jax.Array


def _initial_step(rate, t0, t1, y0, f0, rtol, atol):
    """A first step for order 1 from the size of y0, f0 and the change of f over a trial step
    (Hairer, Norsett & Wanner, Solving ODEs I, sec. II.4); one more evaluation."""
    # With t1 <= t0 (a traced empty interval, e.g. one member of a batch) nothing is integrated:
    # the step is then 1, so that no quantity is 0 / 0 in a derivative.
    span = jnp.where(t1 > t0, t1 - t0, 1.0)
    scale = atol + rtol * jnp.abs(y0)
    d0, d1 = rms(y0 / scale), rms(f0 / scale)
    h0 = jnp.where((d0 < 1e-5) | (d1 < 1e-5), 1e-6, 0.01 * d0 / d1)
    h0 = jnp.minimum(h0, span)
    d2 = rms((rate(t0 + h0, y0 + h0 * f0) - f0) / scale) / h0
    small = (d1 <= 1e-15) & (d2 <= 1e-15)
    h1 = jnp.where(small, jnp.maximum(1e-6, h0 * 1e-3), jnp.sqrt(0.01 / jnp.maximum(jnp.maximum(d1, d2), 1e-300)))
    return jnp.where(t1 > t0, jnp.minimum(jnp.minimum(100.0 * h0, h1), span), 1.0)


def _search(rate, jacobian, t0, t1, differences, h, ts, *, rtol, atol, max_steps, corrector=None, record=False):
    """The search loop (see the module docstring): `rate(t, y)`, `jacobian(t, y)` (both without
    gradient), the initial `differences` and step `h`, the output times `ts`. With `corrector(t,
    c, d, predicted, psi)` (`_corrected` bound to the model) the differences are differentiable
    along the loop (forward mode); with `record`, every accepted step is recorded for `_replay`
    (reverse mode: a `_Record` of `max_steps` rows, else None). Returns the solution at `ts`, the
    record, `BdfStats` and the status."""
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
        converged, iterations, d = newton(*jax.lax.stop_gradient((t_new, y_predicted, psi)), c, lu, pivots,
                                          atol + rtol * jnp.abs(jax.lax.stop_gradient(y_predicted)))
        if corrector is not None:  # forward mode: the converged increment, differentiated
            d = jax.lax.cond(converged, lambda: corrector(t_new, c, d, y_predicted, psi), lambda: d)

        # Not converged: with an old Jacobian, take a new one (same step); else halve the step.
        refresh = ~converged & ~s.fresh_jacobian
        halve = ~converged & s.fresh_jacobian
        jacobian_ = jax.lax.cond(refresh, lambda: jacobian(t_new, jax.lax.stop_gradient(y_predicted)),
                                 lambda: s.jacobian)

        # The error test of a converged step.
        scale = atol + rtol * jnp.abs(jax.lax.stop_gradient(y_predicted + d))
        error = jax.lax.stop_gradient(rms(error_constant[order] * d / scale))
        error = jnp.where(jnp.isfinite(error), error, jnp.inf)  # rejects, shrinking by MIN_FACTOR
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
        factors = jax.lax.stop_gradient(jnp.stack([error_down, error, error_up])) ** (-1.0 / (order + jnp.arange(3)))
        grow = jnp.minimum(MAX_FACTOR, safety * jnp.max(factors))

        order_next = jnp.where(change, order + jnp.argmax(factors) - 1, order).astype(order.dtype)
        resized = change | halve | rejected
        factor = jnp.where(change, grow, jnp.where(resized, shrink, 1.0))
        base = jnp.where(accepted, updated, differences)
        # Every attempt writes the row of the next accepted step: one that is not accepted is
        # overwritten by the next that is (a select over the whole record would cost more than
        # the step).
        steps = s.record
        if record:
            steps = jax.tree.map(lambda rows, row: rows.at[s.stats.num_accepted_steps].set(row), steps,
                                 _Record(s.t, t_new, h, order, pending, differences, d))
        within = accepted & (ts > s.t) & (ts <= t_new)
        saved = jnp.where(within[:, None], interpolate(updated, order, t_new, h, ts), s.saved)
        stats = BdfStats(*(count.astype(jnp.int32) for count in (
            s.stats.num_accepted_steps + accepted, s.stats.num_rejected_steps + ~accepted,
            s.stats.num_jacobians + refresh, s.stats.num_factorisations + ~factorised,
            s.stats.num_evaluations + iterations)))
        h_next = h * factor
        t_next = jnp.where(accepted, t_new, s.t)
        return _Search(t_next, h_next, order_next, jnp.where(resized, rescale(base, order_next, factor), base),
                       jacobian_, lu, pivots, ~resized & ~refresh, (s.fresh_jacobian | refresh) & ~accepted,
                       jnp.where(resized, 0, equal_steps + accepted).astype(jnp.int32),
                       jnp.where(accepted, 1.0, pending) * factor, steps, saved, stats,
                       h_next < 10 * jnp.finfo(dtype).eps * jnp.abs(t_next))

    def unfinished(s: _Search):
        attempts = s.stats.num_accepted_steps + s.stats.num_rejected_steps
        return (s.t < t1) & (attempts < max_steps) & ~s.collapsed

    one = jnp.ones((), jnp.int32)
    steps = None
    if record:
        steps = _Record(jnp.zeros(max_steps, dtype), jnp.zeros(max_steps, dtype), jnp.ones(max_steps, dtype),
                        jnp.ones(max_steps, jnp.int32),
                        jnp.ones(max_steps, dtype), jnp.zeros((max_steps, ROWS, n), dtype),
                        jnp.zeros((max_steps, n), dtype))
    y0 = differences[0]
    saved = initial_outputs(ts, t0, y0)
    state = _Search(jnp.asarray(t0, dtype), h, one, differences, jacobian(t0, jax.lax.stop_gradient(y0)),
                    jnp.zeros((n, n), dtype), jnp.zeros(n, jnp.int32), jnp.asarray(False), jnp.asarray(True), zero,
                    jnp.ones((), dtype), steps, saved, BdfStats(zero, zero, one, zero, 2 * one), jnp.asarray(False))
    final = jax.lax.while_loop(unfinished, attempt, state)
    status = jnp.where(final.t >= t1, 0, jnp.where(final.collapsed, 2, 1))
    return final.saved, final.record, final.stats, status
