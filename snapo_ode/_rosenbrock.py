"""A linearly implicit (Rosenbrock) stiff solver for Diffrax: one Jacobian and one LU
factorisation per step, no Newton iteration.

Diffrax 0.7 ships only implicit Runge-Kutta methods for stiff problems. Each of their stages
runs a root find (a Jacobian and a factorisation per Newton iteration) and, when
differentiated, an implicit-function linear solve that breaks down on rejected steps where
the stage Jacobian is singular (measured on gri30 ignition: the reverse pass gives NaN). A
Rosenbrock step is a fixed sequence of solves with one matrix, so it is cheaper, and its
derivative is the derivative of ordinary arithmetic.
"""

from collections.abc import Callable
from typing import ClassVar

import diffrax
import jax
import jax.numpy as jnp
import jax.scipy.linalg as jsl
import numpy as np
from jax.flatten_util import ravel_pytree

# RODAS4: Hairer & Wanner, Solving ODEs II (2nd ed., 1996), sec. IV.7; the coefficients of
# their code rodas.f. Stage i solves (I / (gamma h) - J) k_i = f(t0 + alpha_i h,
# y0 + sum_j A_ij k_j) + sum_j C_ij k_j / h + gamma_i h df/dt, with J = df/dy at (t0, y0).
# The method is stiffly accurate: y1 = y0 + sum_j A_6j k_j + k_6, and k_6 is the error of the
# embedded third-order solution.
_GAMMA = 0.25
_ALPHA = np.array([0.0, 0.386, 0.21, 0.63, 1.0, 1.0])
_GAMMA_SUM = np.array([0.25, -0.1043, 0.1035, -0.03620000000000023, 0.0, 0.0])
_A = np.array([
    [0.0, 0.0, 0.0, 0.0, 0.0],
    [1.544, 0.0, 0.0, 0.0, 0.0],
    [0.9466785280815826, 0.2557011698983284, 0.0, 0.0, 0.0],
    [3.314825187068521, 2.896124015972201, 0.9986419139977817, 0.0, 0.0],
    [1.221224509226641, 6.019134481288629, 12.53708332932087, -0.687886036105895, 0.0],
    [1.221224509226641, 6.019134481288629, 12.53708332932087, -0.687886036105895, 1.0],
])
_C = np.array([
    [0.0, 0.0, 0.0, 0.0, 0.0],
    [-5.6688, 0.0, 0.0, 0.0, 0.0],
    [-2.430093356833875, -0.2063599157091915, 0.0, 0.0, 0.0],
    [-0.1073529058151375, -9.594562251023355, -20.47028614809616, 0.0, 0.0],
    [7.496443313967647, -10.24680431464352, -33.99990352819905, 11.7089089320616, 0.0],
    [8.083246795921522, -7.981132988064893, -31.52159432874371, 16.31930543123136, -6.058818238834054],
])


@jax.custom_jvp
def _solve(factors, matrix, rhs):
    """`matrix`^-1 `rhs` from `factors` = `jax.scipy.linalg.lu_factor(matrix)`.

    The derivative goes through `matrix`, never through the factorisation: d x = matrix^-1
    (d rhs - d matrix x), so a reverse pass gives the matrix the outer product
    -(matrix^-T x_bar) x^T. Differentiating the LU factorisation instead (JAX's rule for
    `lu`) made a gri30 Rosenbrock step's reverse pass slower (measured: a step's VJP took 8.1 ms
    that way, 4.8 ms this way)."""
    return jsl.lu_solve(factors, rhs)


@_solve.defjvp
def _solve_jvp(primals, tangents):
    factors, matrix, rhs = primals
    _, matrix_dot, rhs_dot = tangents
    solution = jsl.lu_solve(factors, rhs)
    return solution, jsl.lu_solve(factors, rhs_dot - matrix_dot @ solution)


class Rodas4(diffrax.AbstractAdaptiveSolver):
    """RODAS4: a 6-stage, order-4 (embedded order-3), L-stable and stiffly accurate
    Rosenbrock method, for `diffrax.diffeqsolve` with a single `diffrax.ODETerm`.

    Each step evaluates the exact Jacobian `df/dy` (forward-mode, one tangent per state
    component) and `df/dt` (one more tangent, so non-autonomous right-hand sides keep their
    order), factorises `I / (gamma h) - J` once and makes six solves with it. Dense output is
    the cubic Hermite interpolant, as for Diffrax's ESDIRK methods.

    Use it with `diffrax.PIDController`; with `RecursiveCheckpointAdjoint` (reverse mode) or
    `ForwardMode`. The state may be any pytree of float arrays (it is flattened for the
    linear algebra, so keep it to at most a few hundred components).

    **Arguments:**
    - `jacobian`: optional `jacobian(t, y, args)`, the exact `df/dy` as a matrix of shape
      `(n, n)` on the flattened state (`jax.flatten_util.ravel_pytree` order). A model that
      knows its structure can build it cheaper than the default `jax.jacfwd` over the whole
      state: a reactor differentiates its temperature with one tangent, so that the
      temperature-only rate constants are not carried through every concentration tangent
      (measured on gri30: 0.46 ms against 1.0 ms a Jacobian).
    """

    jacobian: Callable | None = None

    term_structure: ClassVar = diffrax.AbstractTerm
    interpolation_cls: ClassVar = diffrax.ThirdOrderHermitePolynomialInterpolation

    def order(self, terms):
        return 4

    def init(self, terms, t0, t1, y0, args):
        return None

    def func(self, terms, t0, y0, args):
        return terms.vf(t0, y0, args)

    def step(self, terms, t0, t1, y0, args, solver_state, made_jump):
        del solver_state, made_jump
        y0_flat, unravel = ravel_pytree(y0)
        dtype = y0_flat.dtype
        h = jnp.asarray(t1 - t0, dtype)
        t0 = jnp.asarray(t0, dtype)

        def rate(t, y_flat):
            return ravel_pytree(terms.vf(t, unravel(y_flat), args))[0]

        f0, dfdt = jax.jvp(lambda t: rate(t, y0_flat), (t0,), (jnp.ones_like(t0),))
        if self.jacobian is None:
            jacobian = jax.jacfwd(rate, argnums=1)(t0, y0_flat)
        else:
            jacobian = self.jacobian(t0, y0, args)
        matrix = jnp.eye(y0_flat.size, dtype=dtype) / (_GAMMA * h) - jacobian
        factors = jsl.lu_factor(jax.lax.stop_gradient(matrix))

        stages = []
        for i in range(len(_ALPHA)):
            if i == 0:
                rate_i = f0
            else:
                y_i = y0_flat + sum(_A[i, j] * stages[j] for j in range(i))
                rate_i = rate(t0 + _ALPHA[i] * h, y_i)
                rate_i = rate_i + sum(_C[i, j] * stages[j] for j in range(i)) / h
            if _GAMMA_SUM[i] != 0.0:
                rate_i = rate_i + (_GAMMA_SUM[i] * h) * dfdt
            stages.append(_solve(factors, matrix, rate_i))
        y1_flat = y0_flat + sum(_A[-1, j] * stages[j] for j in range(len(_ALPHA) - 1)) + stages[-1]
        y1 = unravel(y1_flat)
        # Used only where the solve saves dense output: elsewhere XLA drops it.
        k1 = h * rate(t0 + h, y1_flat)
        dense_info = dict(y0=y0, y1=y1, k0=unravel(h * f0), k1=unravel(k1))
        return y1, unravel(stages[-1]), dense_info, None, diffrax.RESULTS.successful
