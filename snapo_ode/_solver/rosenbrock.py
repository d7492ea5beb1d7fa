"""Linearly implicit (Rosenbrock) stiff solvers for Diffrax: one Jacobian and one LU
factorisation per step, no Newton iteration.

Diffrax 0.7 ships only implicit Runge-Kutta methods for stiff problems. Each of their stages
runs a root find (a Jacobian and a factorisation per Newton iteration) and, when
differentiated, an implicit-function linear solve that breaks down on rejected steps where
the stage Jacobian is singular (on a gri30 ignition the reverse pass gives NaN). A
Rosenbrock step is a fixed sequence of solves with one matrix, so it is cheaper, and its
derivative is the derivative of ordinary arithmetic.

Both methods here are stiffly accurate (their last stage ends at t1, and y1 is that stage's
state plus its increment, which is also the error estimate), so f(t1, y1), which the dense
output needs anyway, is the next step's f(t0, y0): it is carried from step to step (first
same as last), one evaluation of the vector field a step fewer.
"""

from collections.abc import Callable
from typing import ClassVar, NamedTuple

import diffrax
import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
from jax.flatten_util import ravel_pytree


class RosenbrockTableau(NamedTuple):
    """Stage i solves (I / (gamma h) - J) k_i = f(t0 + alpha_i h, y0 + sum_j a_ij k_j)
    + sum_j c_ij k_j / h + gamma_sum_i h df/dt, with J = df/dy at (t0, y0); then
    y1 = y0 + sum_j a_sj k_j + k_s (s: the last stage), and k_s is the error estimate.
    `a` and `c` have shape `(s, s - 1)` (row i: the stages before i)."""

    order: int
    gamma: float
    alpha: np.ndarray
    gamma_sum: np.ndarray
    a: np.ndarray
    c: np.ndarray


def _lower(rows):
    """A `(s, s - 1)` array from the lower-triangular rows (row i has i entries)."""
    out = np.zeros((len(rows), len(rows) - 1))
    for i, row in enumerate(rows):
        out[i, :len(row)] = row
    return out


# RODAS4: Hairer & Wanner, Solving ODEs II (2nd ed., 1996), sec. IV.7; the coefficients of
# their code rodas.f.
RODAS4_TABLEAU = RosenbrockTableau(
    order=4, gamma=0.25,
    alpha=np.array([0.0, 0.386, 0.21, 0.63, 1.0, 1.0]),
    gamma_sum=np.array([0.25, -0.1043, 0.1035, -0.03620000000000023, 0.0, 0.0]),
    a=_lower([[], [1.544], [0.9466785280815826, 0.2557011698983284],
              [3.314825187068521, 2.896124015972201, 0.9986419139977817],
              [1.221224509226641, 6.019134481288629, 12.53708332932087, -0.687886036105895],
              [1.221224509226641, 6.019134481288629, 12.53708332932087, -0.687886036105895, 1.0]]),
    c=_lower([[], [-5.6688], [-2.430093356833875, -0.2063599157091915],
              [-0.1073529058151375, -9.594562251023355, -20.47028614809616],
              [7.496443313967647, -10.24680431464352, -33.99990352819905, 11.7089089320616],
              [8.083246795921522, -7.981132988064893, -31.52159432874371, 16.31930543123136,
               -6.058818238834054]]),
)

# RODAS5: G. Di Marzo, "RODAS5(4) - Méthodes de Rosenbrock d'ordre 5(4) adaptées aux problèmes
# différentiels-algébriques", master's thesis, Geneva, 1993; 8 stages, order 5 with an embedded
# order-4 solution, stiffly accurate (the coefficients as tabulated in OrdinaryDiffEq.jl).
_RODAS5_A6 = [-14.09640773051259, 6.925207756232704, -41.47510893210728, 2.343771018586405, 24.13215229196062]
RODAS5_TABLEAU = RosenbrockTableau(
    order=5, gamma=0.19,
    alpha=np.array([0.0, 0.38, 0.3878509998321533, 0.4839718937873840, 0.4570477008819580, 1.0, 1.0, 1.0]),
    gamma_sum=np.array([0.19, -0.1823079225333714636, -0.319231832186874912, 0.3449828624725343,
                        -0.377417564392089818, 0.0, 0.0, 0.0]),
    a=_lower([[], [2.0], [3.040894194418781, 1.041747909077569],
              [2.576417536461461, 1.622083060776640, -0.9089668560264532],
              [2.760842080225597, 1.446624659844071, -0.3036980084553738, 0.2877498600325443],
              _RODAS5_A6, [*_RODAS5_A6, 1.0], [*_RODAS5_A6, 1.0, 1.0]]),
    c=_lower([[], [-10.31323885133993], [-21.04823117650003, -7.234992135176716],
              [32.22751541853323, -4.943732386540191, 19.44922031041879],
              [-20.69865579590063, -8.816374604402768, 1.260436877740897, -0.7495647613787146],
              [-46.22004352711257, -17.49534862857472, -289.6389582892057, 93.60855400400906, 318.3822534212147],
              [34.20013733472935, -14.15535402717690, 57.82335640988400, 25.83362985412365, 1.408950972071624,
               -6.551835421242162],
              [42.57076742291101, -13.80770672017997, 93.98938432427124, 18.77919633714503, -31.58359187223370,
               -6.685968952921985, -5.810979938412932]]),
)


def _factorise(matrix):
    """(lu, permutation) of `matrix` (`jax.lax.linalg.lu`). The row permutation is formed here,
    once a step: `jax.scipy.linalg.lu_solve` forms it from the pivots at every call, a loop
    over the rows that, for the small systems of a kinetics step, cost more than the solve."""
    lu, _, permutation = jax.lax.linalg.lu(matrix)
    return lu, permutation


def _lu_solve(factors, rhs):
    """`matrix`^-1 `rhs` (a vector) from `factors` = `_factorise(matrix)`."""
    lu, permutation = factors
    x = rhs[permutation][:, None]
    x = jax.lax.linalg.triangular_solve(lu, x, left_side=True, lower=True, unit_diagonal=True)
    return jax.lax.linalg.triangular_solve(lu, x, left_side=True, lower=False)[:, 0]


@jax.custom_jvp
def _solve(factors, matrix, rhs):
    """`matrix`^-1 `rhs` from `factors` = `_factorise(matrix)`.

    The derivative goes through `matrix`, never through the factorisation: d x = matrix^-1
    (d rhs - d matrix x), so a reverse pass gives the matrix the outer product
    -(matrix^-T x_bar) x^T. Differentiating the LU factorisation instead (JAX's rule for
    `lu`) makes a large system's reverse step slower."""
    return _lu_solve(factors, rhs)


@_solve.defjvp
def _solve_jvp(primals, tangents):
    factors, matrix, rhs = primals
    _, matrix_dot, rhs_dot = tangents
    solution = _lu_solve(factors, rhs)
    # A rejected trial step may solve for NaN; its cotangent is 0, and 0 * NaN would reach the
    # matrix (the step's Jacobian) in a reverse pass. A finite solution is used as it is.
    finite = jnp.where(jnp.isfinite(solution), solution, 0.0)
    return solution, _lu_solve(factors, rhs_dot - matrix_dot @ finite)


class AbstractRosenbrock(diffrax.AbstractAdaptiveSolver):
    """A stiffly accurate Rosenbrock method of `tableau`, for `diffrax.diffeqsolve` with a
    single `diffrax.ODETerm`.

    Each step evaluates the exact Jacobian `df/dy` (forward-mode, one tangent per state
    component, or the model's own `jacobian`) and `df/dt` (one more tangent, so
    non-autonomous right-hand sides keep their order), factorises `I / (gamma h) - J` once and
    makes one solve per stage with it. Dense output is the cubic Hermite interpolant, as for
    Diffrax's ESDIRK methods. The solver state is f(t0, y0), carried from the last step.

    Use it with `diffrax.PIDController`; with `RecursiveCheckpointAdjoint` (reverse mode) or
    `ForwardMode`. The state may be any pytree of float arrays (it is flattened for the
    linear algebra, so keep it to at most a few hundred components).

    **Arguments:**
    - `jacobian`: optional `jacobian(t, y, args)`, the exact `df/dy` as a matrix of shape
      `(n, n)` on the flattened state (`jax.flatten_util.ravel_pytree` order). A model that
      knows its structure can build it cheaper than the default `jax.jacfwd` over the whole
      state: a reactor differentiates its temperature with one tangent, so that the
      temperature-only rate constants are not carried through every concentration tangent
      (about half the time a Jacobian on gri30).
    - `unroll_stages`: False (default): the stages between the first and the last run in a
      `jax.lax.fori_loop` over the tableau's rows, so the vector field is traced and compiled
      once for them, not once per stage. True: every stage written out in the program. The
      values are the same; the loop traces and compiles faster, the unrolled stages run reverse
      passes of small systems faster and without the loop's occasional slowdown when XLA's CPU
      threads contend over it. Unroll for long sweeps of gradients, where the run outweighs the
      compile (the measurements: docs/architecture.md, Measurements behind the design).
    """

    jacobian: eqx.AbstractVar[Callable | None]
    unroll_stages: eqx.AbstractVar[bool]
    tableau: eqx.AbstractClassVar[RosenbrockTableau]

    term_structure: ClassVar = diffrax.AbstractTerm
    interpolation_cls: ClassVar = diffrax.ThirdOrderHermitePolynomialInterpolation

    def order(self, terms):
        return self.tableau.order

    def init(self, terms, t0, t1, y0, args):
        return ravel_pytree(terms.vf(t0, y0, args))[0]

    def func(self, terms, t0, y0, args):
        return terms.vf(t0, y0, args)

    def step(self, terms, t0, t1, y0, args, solver_state, made_jump):
        tableau = self.tableau
        y0_flat, unravel = ravel_pytree(y0)
        dtype = y0_flat.dtype
        h = jnp.asarray(t1 - t0, dtype)
        t0 = jnp.asarray(t0, dtype)
        # Under jax.vmap, Diffrax's loop goes on stepping a member that has finished, from t1 to
        # t1, and discards the result. With h = 0, I / (gamma h) is inf and the stages NaN,
        # which a reverse pass multiplies by the discard's zero cotangent (every gradient of a
        # batch member that finished before the slowest was NaN). Such a step is
        # taken with a step of one ulp of t0 instead (every stage finite), and returns y0.
        still = h == 0.0
        h = jnp.where(still, jnp.finfo(dtype).eps * jnp.maximum(jnp.abs(t0), 1.0), h)

        def rate(t, y_flat):
            return ravel_pytree(terms.vf(t, unravel(y_flat), args))[0]

        # After a jump in the vector field the carried f(t0, y0) is stale. Diffrax's made_jump
        # is a Python False unless the controller has jump times: then nothing is traced.
        f0 = solver_state
        if made_jump is not False:
            f0 = jax.lax.cond(made_jump, lambda: rate(t0, y0_flat), lambda: solver_state)
        # The primal of this JVP is unused (dead code for XLA); an autonomous field gives 0.
        dfdt = jax.jvp(lambda t: rate(t, y0_flat), (t0,), (jnp.ones_like(t0),))[1]
        if self.jacobian is None:
            jacobian = jax.jacfwd(rate, argnums=1)(t0, y0_flat)
        else:
            jacobian = self.jacobian(t0, y0, args)
        matrix = jnp.eye(y0_flat.size, dtype=dtype) / (tableau.gamma * h) - jacobian
        factors = _factorise(jax.lax.stop_gradient(matrix))

        def stage_rate(alpha, gamma_sum, y_i, combined):
            """The right-hand side of a stage's solve at t0 + `alpha` h and `y_i`, given
            sum_j c_ij k_j (`combined`); a stage whose `gamma_sum` is a literal 0 skips df/dt."""
            rate_i = rate(t0 + alpha * h, y_i) + combined / h
            if isinstance(gamma_sum, float) and gamma_sum == 0.0:
                return rate_i
            return rate_i + (gamma_sum * h) * dfdt

        last = len(tableau.alpha) - 1
        first = _solve(factors, matrix, f0 + (tableau.gamma_sum[0] * h) * dfdt)
        if self.unroll_stages:
            stages = [first]
            for i in range(1, last + 1):
                y_i = y0_flat + sum(tableau.a[i, j] * stages[j] for j in range(i))
                combined = sum(tableau.c[i, j] * stages[j] for j in range(i))
                rhs = stage_rate(tableau.alpha[i], tableau.gamma_sum[i], y_i, combined)
                stages.append(_solve(factors, matrix, rhs))
            y_last, k_last = y_i, stages[last]
        else:
            # The middle stages in a loop over rows of the tableau: the vector field is traced
            # once for them instead of once per stage (see `AbstractRosenbrock`).
            a, c, alpha, gamma_sum = (jnp.asarray(x, dtype) for x in (tableau.a, tableau.c, tableau.alpha,
                                                                       tableau.gamma_sum))

            def middle_stage(i, stages):
                rhs = stage_rate(alpha[i], gamma_sum[i], y0_flat + a[i] @ stages, c[i] @ stages)
                return stages.at[i].set(_solve(factors, matrix, rhs))

            stages = jnp.zeros((last, y0_flat.size), dtype).at[0].set(first)
            stages = jax.lax.fori_loop(1, last, middle_stage, stages)
            y_last = y0_flat + a[last] @ stages
            k_last = _solve(factors, matrix, stage_rate(tableau.alpha[last], tableau.gamma_sum[last], y_last,
                                                        c[last] @ stages))
        y1_flat = y_last + k_last
        y1_flat = jnp.where(still, y0_flat, y1_flat)
        y1 = unravel(y1_flat)
        f1 = rate(t0 + h, y1_flat)
        error = jnp.where(still, 0.0, k_last)
        dense_info = dict(y0=y0, y1=y1, k0=unravel(h * f0), k1=unravel(h * f1))
        return y1, unravel(error), dense_info, f1, diffrax.RESULTS.successful


class Rodas4(AbstractRosenbrock):
    """RODAS4 (`RODAS4_TABLEAU`): 6 stages, order 4 with an embedded order-3 solution, L-stable
    and stiffly accurate (Hairer & Wanner). Arguments: as `AbstractRosenbrock`."""

    jacobian: Callable | None = None
    unroll_stages: bool = eqx.field(static=True, default=False)
    tableau: ClassVar[RosenbrockTableau] = RODAS4_TABLEAU


class Rodas5(AbstractRosenbrock):
    """RODAS5 (`RODAS5_TABLEAU`): 8 stages, order 5 with an embedded order-4 solution, stiffly
    accurate (Di Marzo): two more stages a step than `Rodas4`, fewer steps at tight tolerances.
    Arguments: as `AbstractRosenbrock`."""

    jacobian: Callable | None = None
    unroll_stages: bool = eqx.field(static=True, default=False)
    tableau: ClassVar[RosenbrockTableau] = RODAS5_TABLEAU

