"""What every solver outside Diffrax is: an `AbstractSolver` that integrates a vector field
from `t0` to `t1` under a `SolverSettings` and returns a `diffrax.Solution` (values at given
times, no dense output). Diffrax's own solvers (`diffrax.Kvaerno5`, `snapo_ode.Rodas5`, ...)
need no wrapper: `SolverSettings` runs them through `diffeqsolve_checked`.
"""

import abc

import diffrax
import equinox as eqx
import jax.numpy as jnp

from .._platform.validation import InputError


class AbstractSolver(eqx.Module):
    """A solver that is not a Diffrax solver (the BDF, the host peers). Subclasses carry their
    own options as fields and implement `solve`."""

    @abc.abstractmethod
    def solve(self, settings, vector_field, t0, t1, y0, args, saveat: diffrax.SaveAt, jacobian) -> diffrax.Solution:
        """`dy/dt = vector_field(t, y, args)` from `y0` at `t0` to `t1`, saved where `saveat` says,
        with the `SolverSettings` `settings`' tolerances, `max_steps` and `differentiation`;
        `jacobian(t, y, args)`: the model's exact df/dy or None. A failure raises as
        `diffeqsolve_checked`'s do."""

    def controller_description(self, settings) -> str:
        """How the step size is chosen, for reports."""
        return f"{type(self).__name__}'s own error test (rtol {settings.rtol:g}, atol {settings.atol:g})"


def output_times(solver, saveat: diffrax.SaveAt, t1):
    """The times a solver without dense output saves at: `saveat`'s ts, or t1 alone."""
    subs = saveat.subs
    if saveat.dense or subs.steps or subs.t0 or (subs.ts is None) == (not subs.t1):
        raise InputError(f"solver = {type(solver).__name__} saves at t1 or at given ts only (no dense output, "
                         "steps or t0).")
    return subs.ts if subs.ts is not None else jnp.atleast_1d(jnp.asarray(t1, float))


def solution(t0, t1, ts, ys, stats: dict) -> diffrax.Solution:
    """A `diffrax.Solution` of a solver outside Diffrax: values at `ts`, no interpolation."""
    return diffrax.Solution(t0=t0, t1=t1, ts=ts, ys=ys, interpolation=None, stats=stats,
                            result=diffrax.RESULTS.successful, solver_state=None, controller_state=None,
                            made_jump=None, event_mask=None)
