"""Peer solvers on the host, on the same vector field: SUNDIALS CVODE (BDF, through
scikit-sundae) and SciPy's BDF, Radau and LSODA. `SolverSettings(solver=CVODE())` (or "cvode", ...) runs a
model's solves with them instead of Diffrax, so that the model, its algebra and its right-hand
side are the same and only the integrator differs: what `snapo bench accuracy` compares.

The vector field is compiled once (its closed-over values made explicit with `jax.make_jaxpr`)
and called from the host solver through `jax.pure_callback`, with its exact Jacobian
(`jax.jacfwd`). Values only: a host solve has no derivative, and no dense output. A failed host
solve returns NaN, which `call_checked` turns into `SolverFailed`.
"""

import abc
from typing import ClassVar

import diffrax
import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
from jax.flatten_util import ravel_pytree

from .base import AbstractSolver, output_times, solution


class AbstractHostSolver(AbstractSolver):
    """A peer solver on the host: values at given times only, no derivative."""

    @abc.abstractmethod
    def integrate(self, field, jacobian, t0: float, ts: np.ndarray, y0: np.ndarray, rtol: float, atol: float,
                  max_steps: int) -> np.ndarray:
        """States at `ts` (shape (len(ts), n)) from `y0` at `t0`; NaN where the solve failed."""

    def solve(self, settings, vector_field, t0, t1, y0, args, saveat, jacobian) -> diffrax.Solution:
        ts = output_times(self, saveat, t1)
        ys = host_solve(self, vector_field, t0, t1, y0, args, ts, rtol=settings.rtol, atol=settings.atol,
                        max_steps=settings.max_steps)
        return solution(t0, t1, ts, ys, {})

    def controller_description(self, settings) -> str:
        return f"{type(self).__name__}'s own step control on the host (rtol {settings.rtol:g}, atol {settings.atol:g})"


class CVODE(AbstractHostSolver):
    """SUNDIALS CVODE (BDF, Newton with a dense direct solver), through scikit-sundae."""

    def integrate(self, field, jacobian, t0, ts, y0, rtol, atol, max_steps):
        from sksundae.cvode import CVODE as Sundials

        def rhs(t, y, yp):
            yp[:] = field(t, y)

        def jac(t, y, yp, matrix):
            matrix[:, :] = jacobian(t, y)

        # scikit-sundae steps without a step limit when given two times: always give it three or
        # more (a midpoint when only t1 is asked for), so that max_num_steps bounds each interval.
        times = np.concatenate([[t0], ts]) if ts[0] > t0 else ts
        if times.size < 3:
            times = np.array([times[0], 0.5 * (times[0] + times[-1]), times[-1]])
        solved = Sundials(rhs, method="BDF", rtol=rtol, atol=atol, jacfn=jac, max_num_steps=max_steps).solve(times, y0)
        return solved.y[-ts.size:] if solved.success and solved.y.shape[0] == times.size else _failed(ts, y0)


class AbstractScipySolver(AbstractHostSolver):
    """`scipy.integrate.solve_ivp` with `method` and the exact Jacobian."""

    method: eqx.AbstractClassVar[str]

    def integrate(self, field, jacobian, t0, ts, y0, rtol, atol, max_steps):
        from scipy.integrate import solve_ivp

        solved = solve_ivp(field, (t0, ts[-1]), y0, method=self.method, t_eval=ts, rtol=rtol, atol=atol, jac=jacobian)
        return solved.y.T if solved.success else _failed(ts, y0)


class ScipyBDF(AbstractScipySolver):
    """SciPy's variable-order BDF."""

    method: ClassVar[str] = "BDF"


class ScipyRadau(AbstractScipySolver):
    """SciPy's Radau IIA (order 5)."""

    method: ClassVar[str] = "Radau"


class ScipyLSODA(AbstractScipySolver):
    """SciPy's LSODA (switches between Adams and BDF)."""

    method: ClassVar[str] = "LSODA"


def _failed(ts, y0) -> np.ndarray:
    return np.full((ts.size, y0.size), np.nan)


def host_solve(solver: AbstractHostSolver, vector_field, t0, t1, y0, args, ts, *, rtol: float, atol: float,
               max_steps: int):
    """The states of `dy/dt = vector_field(t, y, args)` at `ts` (None: at `t1` only), shape
    `(len(ts), *y0)` as a pytree like `y0`, by the host `solver`."""
    flat0, unravel = ravel_pytree(y0)

    def flat_field(t, y):
        return ravel_pytree(vector_field(t, unravel(y), args))[0]

    # Every value the field closes over (`args`, the model's traced parameters, integer tables
    # too, which `jax.closure_convert` would leave behind) becomes a constant of its jaxpr,
    # handed to the host as an array.
    closed = jax.make_jaxpr(flat_field)(jnp.asarray(t0, float), flat0)

    def converted(t, y, *constants):
        return jax.core.eval_jaxpr(closed.jaxpr, constants, t, y)[0]

    constants = closed.consts
    field = jax.jit(converted)
    jacobian = jax.jit(jax.jacfwd(converted, argnums=1))
    times = jnp.atleast_1d(jnp.asarray(t1 if ts is None else ts, float))

    def on_host(t0, times, y0, *constants):
        return solver.integrate(lambda t, y: np.asarray(field(t, y, *constants)),
                          lambda t, y: np.asarray(jacobian(t, y, *constants)), float(t0), np.asarray(times),
                          np.asarray(y0), rtol, atol, max_steps).astype(np.asarray(y0).dtype)

    shape = jax.ShapeDtypeStruct((times.size, flat0.size), flat0.dtype)
    ys = jax.pure_callback(on_host, shape, jnp.asarray(t0, float), times, flat0, *constants)
    return jax.vmap(unravel)(ys)
