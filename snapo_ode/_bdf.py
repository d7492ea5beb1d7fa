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

Derivatives are those of the discrete solution with the step sizes and orders held as taken
(they are decisions, not functions of the inputs): every operation on the differences is plain
arithmetic, and the corrector's converged increment d, which solves
d - c f(t, y_pred + d, args) + psi = 0, is differentiated implicitly (one exact Jacobian at the
converged state and one solve a step, `_corrected`), not through the Newton iterations. The
loop is a `jax.lax.while_loop` for values and forward mode, or equinox's checkpointed loop (a
checkpoint every step) for reverse mode.
"""

import functools
from typing import NamedTuple

import equinox.internal as eqxi
import jax
import jax.numpy as jnp
import jax.scipy.linalg as jsl
import numpy as np

MAX_ORDER = 5
NEWTON_ITERATIONS = 4
"""Newton iterations per attempt; a slower one refreshes the Jacobian, then halves the step."""
MIN_FACTOR, MAX_FACTOR = 0.2, 10.0
"""Bounds of a step size change after a rejected or an accepted step."""

# The NDF coefficients: kappa (Shampine & Reichelt, table 1), gamma_k = sum_{j<=k} 1/j, the
# implicit formula's alpha_k = (1 - kappa_k) gamma_k and the error constants
# kappa_k gamma_k + 1 / (k + 1), indexed by the order k (index 0 unused).
_KAPPA = np.array([0.0, -0.1850, -1.0 / 9.0, -0.0823, -0.0415, 0.0])
_GAMMA = np.concatenate([[0.0], np.cumsum(1.0 / np.arange(1, MAX_ORDER + 1))])
_ALPHA = (1.0 - _KAPPA) * _GAMMA
_ERROR_CONSTANT = np.concatenate([_KAPPA * _GAMMA + 1.0 / np.arange(1, MAX_ORDER + 2), [np.inf]])
_ROWS = MAX_ORDER + 3  # differences 0..order+2 are kept


class BdfStats(NamedTuple):
    """Counts of one solve: accepted and rejected steps, Jacobians, LU factorisations and
    vector-field evaluations (Newton iterations and the initial step's two)."""

    num_accepted_steps: jax.Array
    num_rejected_steps: jax.Array
    num_jacobians: jax.Array
    num_factorisations: jax.Array
    num_evaluations: jax.Array


class _State(NamedTuple):
    t: jax.Array
    h: jax.Array
    order: jax.Array
    differences: jax.Array  # (MAX_ORDER + 3, n)
    jacobian: jax.Array
    lu: jax.Array
    pivots: jax.Array
    factorised: jax.Array  # the LU is of I - c J for the current h, order and J
    fresh_jacobian: jax.Array  # J was evaluated at this step's attempt
    equal_steps: jax.Array
    saved: jax.Array  # (n_ts, n)
    stats: BdfStats
    collapsed: jax.Array


def _rms(x):
    return jnp.sqrt(jnp.mean(x * x))


def _r_matrix(factor):
    """R of Shampine & Reichelt for a step size ratio `factor`, full size (MAX_ORDER + 1)^2."""
    i = np.arange(1, MAX_ORDER + 1)[:, None]
    j = np.arange(1, MAX_ORDER + 1)[None, :]
    m = jnp.zeros((MAX_ORDER + 1, MAX_ORDER + 1)).at[0].set(1.0)
    m = m.at[1:, 1:].set((i - 1 - factor * j) / i)
    return jnp.cumprod(m, axis=0)


_U = np.asarray(_r_matrix(1.0))


def _rescale(differences, order, factor):
    """The differences 0..`order` of a step h re-expressed for the step `factor` h (the same
    interpolating polynomial at the new spacing); the others unchanged."""
    size = MAX_ORDER + 1
    block = (np.arange(size)[:, None] <= order) & (np.arange(size)[None, :] <= order)
    ru = jnp.where(block, _r_matrix(factor), 0.0) @ jnp.where(block, _U, 0.0)
    ru = jnp.where(block, ru, jnp.eye(size))
    return differences.at[:size].set(ru.T @ differences[:size])


def _interpolate(differences, order, t, h, times):
    """The BDF interpolant of the last step (ending at `t`, step `h`) at `times`, shape
    `(n_ts, n)`: y = D_0 + sum_{j=1..order} D_j prod_{m<j} (tau - t + m h) / ((m + 1) h)."""
    m = np.arange(MAX_ORDER)
    factors = (times[:, None] - (t - m * h)) / ((m + 1) * h)  # (n_ts, MAX_ORDER)
    products = jnp.cumprod(factors, axis=1) * (m + 1 <= order)
    return differences[0] + products @ differences[1:MAX_ORDER + 1]


def _initial_step(rate, t0, t1, y0, f0, rtol, atol):
    """A first step for order 1 from the size of y0, f0 and the change of f over a trial step
    (Hairer, Norsett & Wanner, Solving ODEs I, sec. II.4); one more evaluation."""
    scale = atol + rtol * jnp.abs(y0)
    d0, d1 = _rms(y0 / scale), _rms(f0 / scale)
    h0 = jnp.where((d0 < 1e-5) | (d1 < 1e-5), 1e-6, 0.01 * d0 / d1)
    h0 = jnp.minimum(h0, t1 - t0)
    d2 = _rms((rate(t0 + h0, y0 + h0 * f0) - f0) / scale) / h0
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


def bdf_solve(vector_field, jacobian, t0, t1, y0, args, ts, *, rtol: float, atol: float, max_steps: int,
              reverse: bool = False):
    """Integrate dy/dt = `vector_field(t, y, args)` (y of shape `(n,)`) from `t0` to `t1` > `t0`.

    **Arguments:** `jacobian(t, y, args)`: df/dy, shape `(n, n)`; `ts`: the output times, shape
    `(n_ts,)`, increasing within [t0, t1]; `rtol`, `atol`: the local error test on
    `atol + rtol |y|` (root mean square); `max_steps`: attempted steps at most; `reverse`: run
    the loop so that reverse mode can differentiate it (a checkpoint every step; forward mode
    then cannot).

    **Returns:** `(ys, stats, status)`: the solution at `ts` (shape `(n_ts, n)`, from the
    interpolant of the step that covers each time), `BdfStats`, and 0 (reached t1), 1 (max_steps
    reached) or 2 (the step size collapsed, or the Newton iteration never converged).
    """
    dtype = y0.dtype
    n = y0.size
    eye = jnp.eye(n, dtype=dtype)
    newton_tol = max(10 * np.finfo(np.float64).eps / rtol, min(0.03, rtol ** 0.5))
    alpha, gamma, error_constant = (jnp.asarray(a, dtype) for a in (_ALPHA, _GAMMA, _ERROR_CONSTANT))
    rows = np.arange(_ROWS)[:, None]
    gamma_rows = jnp.concatenate([gamma, jnp.zeros(_ROWS - gamma.size, dtype)])[:, None]  # gamma_0 = 0
    t0, t1 = jax.lax.stop_gradient(t0), jax.lax.stop_gradient(t1)
    # What the functions close over (e.g. a model's parameters) as arguments, so that
    # `_corrected` differentiates with respect to it; the Newton iteration, the step decisions and
    # the Jacobian it uses see it without gradient.
    field, field_consts = jax.closure_convert(vector_field, t0, y0, args)
    jacobian_fn, jacobian_consts = jax.closure_convert(jacobian, t0, y0, args)
    frozen_args, frozen_consts = jax.lax.stop_gradient((args, field_consts))

    def rate(t, y):
        return field(t, y, frozen_args, *frozen_consts)

    def frozen_jacobian(t, y):
        return jax.lax.stop_gradient(jacobian_fn(t, y, args, *jacobian_consts))

    f0 = vector_field(t0, y0, args)
    h = jax.lax.stop_gradient(_initial_step(rate, t0, t1, y0, f0, rtol, atol))
    differences = jnp.zeros((_ROWS, n), dtype).at[0].set(y0).at[1].set(h * f0)
    saved = jnp.where((ts <= t0)[:, None], y0, jnp.zeros((ts.size, n), dtype))
    zero = jnp.zeros((), jnp.int32)
    state = _State(jnp.asarray(t0, dtype), h, jnp.ones((), jnp.int32), differences, frozen_jacobian(t0, y0),
                   jnp.zeros((n, n), dtype), jnp.zeros(n, jnp.int32), jnp.asarray(False), jnp.asarray(True), zero,
                   saved, BdfStats(zero, zero, jnp.ones((), jnp.int32), zero, 2 * jnp.ones((), jnp.int32)),
                   jnp.asarray(False))

    def newton(t_new, y_predicted, psi, c, lu, pivots, scale):
        """The Newton iteration for the corrector's increment d (values only: `_corrected`
        differentiates the converged d); whether it converged, and its iterations."""

        def step(carry):
            k, y, d, norm_old, converged, stop = carry
            f = rate(t_new, y)
            dy = jsl.lu_solve((lu, pivots), c * f - psi - d)
            norm = _rms(dy / scale)
            rate_ = norm / norm_old  # inf on the first iteration (norm_old = 0 there)
            first = k == 0
            diverging = ~first & ((rate_ >= 1.0) | (rate_ ** (NEWTON_ITERATIONS - k) / (1.0 - rate_) * norm > newton_tol))
            bad = ~jnp.all(jnp.isfinite(f)) | diverging
            y, d = jnp.where(bad, y, y + dy), jnp.where(bad, d, d + dy)
            done = ~bad & ((norm == 0.0) | (~first & (rate_ / (1.0 - rate_) * norm < newton_tol)))
            return k + 1, y, d, norm, done, bad | done

        y_predicted, psi, scale = (jax.lax.stop_gradient(x) for x in (y_predicted, psi, scale))
        carry = (zero, y_predicted, jnp.zeros_like(y_predicted), jnp.zeros((), dtype), jnp.asarray(False),
                 jnp.asarray(False))
        k, y, d, _, converged, _ = jax.lax.while_loop(
            lambda carry: ~carry[5] & (carry[0] < NEWTON_ITERATIONS), step, carry)
        return converged, k, d

    def attempt(s: _State) -> _State:
        # A step that would pass t1 ends there.
        over = s.t + s.h > t1
        h = jnp.where(over, t1 - s.t, s.h)
        differences = jnp.where(over, _rescale(s.differences, s.order, h / s.h), s.differences)
        factorised = s.factorised & ~over
        equal_steps = jnp.where(over, 0, s.equal_steps)
        t_new = jnp.where(over, t1, s.t + h)
        order = s.order

        c = h / alpha[order]
        lu, pivots = jax.lax.cond(factorised, lambda: (s.lu, s.pivots),
                                  lambda: jax.lax.stop_gradient(jsl.lu_factor(eye - c * s.jacobian)))
        used = rows <= order
        y_predicted = jnp.sum(jnp.where(used, differences, 0.0), axis=0)
        psi = jnp.sum(jnp.where(used, gamma_rows * differences, 0.0), axis=0) / alpha[order]
        scale = atol + rtol * jnp.abs(y_predicted)
        converged, iterations, d = newton(t_new, y_predicted, psi, c, lu, pivots, scale)
        d = _corrected(field, jacobian_fn, t_new, c, d, y_predicted, psi, args, field_consts, jacobian_consts)
        y_new = y_predicted + d
        evaluations = s.stats.num_evaluations + iterations

        # Not converged: with an old Jacobian, take a new one (same step); else halve the step.
        refresh = ~converged & ~s.fresh_jacobian
        halve = ~converged & s.fresh_jacobian
        jacobian_ = jax.lax.cond(refresh, lambda: frozen_jacobian(t_new, jax.lax.stop_gradient(y_predicted)),
                                 lambda: s.jacobian)

        # The error test of a converged step.
        scale = atol + rtol * jnp.abs(y_new)
        error = jax.lax.stop_gradient(_rms(error_constant[order] * d / scale))
        safety = 0.9 * (2 * NEWTON_ITERATIONS + 1) / (2 * NEWTON_ITERATIONS + iterations)
        accepted = converged & (error <= 1.0)
        rejected = converged & ~accepted
        shrink = jnp.where(halve, 0.5, jnp.maximum(MIN_FACTOR, safety * error ** (-1.0 / (order + 1))))

        # An accepted step: the new differences D_{order+2} = d - D_{order+1}, D_{order+1} = d,
        # and D_i += D_{i+1} from i = order down to 0.
        top = jnp.where(rows == order + 2, d - differences[jnp.minimum(order + 1, _ROWS - 1)],
                        jnp.where(rows == order + 1, d, differences))
        summed = jnp.flip(jnp.cumsum(jnp.flip(jnp.where(rows <= order + 1, top, 0.0), 0), 0), 0)
        updated = jnp.where(rows <= order, summed, top)
        # After order + 1 equal steps, the order (one down, the same, one up) and the step that
        # promise the largest step.
        change = accepted & (equal_steps + 1 >= order + 1)
        error_down = jnp.where(order > 1, _rms(error_constant[order - 1] * updated[order] / scale), jnp.inf)
        error_up = jnp.where(order < MAX_ORDER, _rms(error_constant[order + 1] * updated[jnp.minimum(order + 2, _ROWS - 1)]
                                                     / scale), jnp.inf)
        exponents = -1.0 / (order + jnp.arange(3))
        factors = jax.lax.stop_gradient(jnp.stack([error_down, error, error_up])) ** exponents
        new_order = (order + jnp.argmax(factors) - 1).astype(order.dtype)
        grow = jnp.minimum(MAX_FACTOR, safety * jnp.max(factors))

        order_next = jnp.where(change, new_order, order)
        resized = change | halve | rejected
        factor = jnp.where(change, grow, jnp.where(resized, shrink, 1.0))
        base = jnp.where(accepted, updated, differences)
        differences_next = jnp.where(resized, _rescale(base, order_next, factor), base)
        t_next = jnp.where(accepted, t_new, s.t)
        h_next = h * factor
        within = accepted & (ts > s.t) & (ts <= t_new)
        saved = jnp.where(within[:, None], _interpolate(differences_next, order_next, t_new, h_next, ts), s.saved)
        stats = BdfStats(*(count.astype(jnp.int32) for count in (
            s.stats.num_accepted_steps + accepted, s.stats.num_rejected_steps + ~accepted,
            s.stats.num_jacobians + refresh, s.stats.num_factorisations + ~factorised, evaluations)))
        return _State(t_next, h_next, order_next, differences_next, jacobian_, lu, pivots, ~resized & ~refresh,
                      (s.fresh_jacobian | refresh) & ~accepted, jnp.where(resized, 0, equal_steps + accepted).astype(jnp.int32),
                      saved, stats, h_next < 10 * jnp.finfo(dtype).eps * jnp.abs(t_next))

    def unfinished(s: _State):
        attempts = s.stats.num_accepted_steps + s.stats.num_rejected_steps
        return (s.t < t1) & (attempts < max_steps) & ~s.collapsed

    if reverse:
        final = eqxi.while_loop(unfinished, attempt, state, max_steps=max_steps, kind="checkpointed",
                                checkpoints=max_steps)
    else:
        final = jax.lax.while_loop(unfinished, attempt, state)
    status = jnp.where(final.t >= t1, 0, jnp.where(final.collapsed, 2, 1))
    return final.saved, final.stats, status

