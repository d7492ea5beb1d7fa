"""One configuration for every ODE solve in the project: solver, tolerances, step controller,
root finder and the adjoint that differentiates through the solve.

Reactors (chemistry) and the pharma chain take a `SolverSettings`; the reasons behind each
default are written here once.
"""

import dataclasses
from typing import Literal, get_args

import diffrax
import equinox as eqx
import jax
import jax.numpy as jnp
import optimistix as optx
from jax.flatten_util import ravel_pytree

from .bdf import bdf_solve
from .host import HOST_SOLVERS, host_solve
from .._ode import checked_ys, diffeqsolve_checked
from .rosenbrock import Rodas4, Rodas5
from .._platform.validation import InputError, check_choice, check_count, check_range

SolverName = Literal["rodas4", "rodas5", "bdf", "kvaerno5", "kvaerno4", "kvaerno3", "tsit5", "dopri5",
                     "cvode", "scipy-bdf", "scipy-radau", "scipy-lsoda"]
RootFinderName = Literal["newton", "chord"]
Differentiation = Literal["reverse", "forward", "backsolve"]

_ESDIRK = {"kvaerno5": diffrax.Kvaerno5, "kvaerno4": diffrax.Kvaerno4, "kvaerno3": diffrax.Kvaerno3}
_ROSENBROCK = {"rodas4": Rodas4, "rodas5": Rodas5}
_EXPLICIT = {"tsit5": diffrax.Tsit5, "dopri5": diffrax.Dopri5}
STIFF_SOLVERS: tuple[str, ...] = ("rodas4", "rodas5", "bdf", *_ESDIRK)
SOLVERS: tuple[str, ...] = get_args(SolverName)


class SolverSettings(eqx.Module):
    """How an ODE is integrated. Static: two settings compile to two programs.

    **Fields:**
    - `rtol`, `atol`: tolerances of the adaptive step (`diffrax.PIDController`), on the state
      as the model scales it (models scale their states to O(1) so that one `atol` means the
      same for every component).
    - `solver`: for stiff models (or the stiff units of a chain): "rodas4" (default,
      `snapo_ode.Rodas4`: one Jacobian and one LU a step, no Newton iteration), "rodas5" (the
      same with 8 stages and order 5: fewer steps at tight tolerances, the reactors' default),
      "bdf" (`snapo_ode._solver.bdf`: variable-order BDF/NDF with a Newton iteration that reuses its
      Jacobian and factorisation across steps, as CVODES does; on the ignition benchmark 2-5x
      faster than Rodas5 forward; its error follows atol more than Rodas5's; saves at given
      times only; derivatives with the corrector differentiated implicitly, by
      `differentiation` "reverse" (recorded steps replayed) or "forward" (`jax.jvp`,
      `jax.jacfwd`; under "reverse" forward mode raises JAX's custom_vjp error)) or the ESDIRK
      "kvaerno5", "kvaerno4", "kvaerno3". Rodas4 is the default because it is the one that
      holds up (measured on whole ignitions at rtol 1e-8: h2o2 in 910 accepted + 61 rejected
      steps, where Kvaerno5 with a chord root finder took 3,642 + 4,481 and, after a change at
      round-off level in the rates, hit max_steps), and because its reverse pass has no root
      finder's implicit derivative, which failed on rejected steps of a gri30 ignition. An
      explicit name ("tsit5", "dopri5") is allowed and is then used for every part. The peers
      "cvode" (SUNDIALS, BDF), "scipy-bdf", "scipy-radau" and "scipy-lsoda" integrate the same
      vector field on the host (`snapo_ode._solver.host`): values only (no derivative, no dense
      output), for comparisons of accuracy and time.
    - `nonstiff_solver`: for the parts a model declares non-stiff (`solve(..., stiff=False)`),
      e.g. the pharma crystallizer and dryer, whose Jacobians' eigenvalues stay below ~20 per
      unit duration: "tsit5" (default: explicit, no Jacobian to form or differentiate), "dopri5",
      or any stiff solver's name.
    - `root_finder` (ESDIRK only): "newton" (`optimistix.Newton`) or "chord"
      (`diffrax.VeryChord` with `kappa`). Newton takes fewer steps before an ignition front but
      can stall after it; the chord finder held up on whole ignitions.
    - `root_rtol`, `root_atol` (ESDIRK only): the stage equations' tolerances; `None` uses the
      step's. Looser than the step's can be right: Newton converges quadratically, and asking
      1e-10 of it on a stiff system (condition number ~ h * 4e5 on the pharma R1) meets
      round-off, fails and rejects steps.
    - `kappa` (chord only): its convergence rate threshold.
    - `pcoeff`, `icoeff`: the PID controller's coefficients (0, 1: a plain integral controller;
      a PID drifted at an ignition front).
    - `max_steps`: the solve raises `SolverFailed` (with advice) if it needs more.
    - `differentiation`: how a derivative goes through the solve:
      - "reverse" (default): `RecursiveCheckpointAdjoint` with `checkpoints` (default
        `max_steps`, a checkpoint at every step, so that no step is recomputed from an earlier
        checkpoint: with Diffrax's default log2(max_steps) checkpoints the reverse pass through
        Rodas4 on the pharma R1 drifted 1.5e-6 relative from forward mode at rtol 1e-10, where
        forward mode and a checkpoint a step agree to 1e-13; the memory is `max_steps` states).
      - "forward": `diffrax.ForwardMode`, for `jax.jvp` / `jax.jacfwd` (few inputs, many
        outputs). Diffrax needs a different adjoint for each mode.
      - "backsolve": `diffrax.BacksolveAdjoint`, refused on stiff solves (its backward solve
        diverges there: max_steps, or gradients near 1e297).
    - `checkpoints`: of the reverse adjoint; `None` is `max_steps` (see above).
    - `unroll_stages` (Rosenbrock only): False (default) runs the middle stages of a step in a
      loop, traced and compiled once (25-40% less time to the first result); True writes every
      stage out, which runs reverse passes of small systems 10% faster and without the loop's
      occasional 2x slowdown on two CPU threads
      (measured: `snapo_ode._solver.rosenbrock.AbstractRosenbrock`).
    """

    rtol: float = eqx.field(static=True, default=1e-8)
    atol: float = eqx.field(static=True, default=1e-10)
    solver: SolverName = eqx.field(static=True, default="rodas4")
    nonstiff_solver: SolverName = eqx.field(static=True, default="tsit5")
    root_finder: RootFinderName = eqx.field(static=True, default="newton")
    root_rtol: float | None = eqx.field(static=True, default=None)
    root_atol: float | None = eqx.field(static=True, default=None)
    kappa: float = eqx.field(static=True, default=0.5)
    pcoeff: float = eqx.field(static=True, default=0.0)
    icoeff: float = eqx.field(static=True, default=1.0)
    max_steps: int = eqx.field(static=True, default=20_000)
    differentiation: Differentiation = eqx.field(static=True, default="reverse")
    checkpoints: int | None = eqx.field(static=True, default=None)
    unroll_stages: bool = eqx.field(static=True, default=False)

    def __check_init__(self):
        for name in ("rtol", "atol") + (("root_rtol",) if self.root_rtol is not None else ()) + (
                ("root_atol",) if self.root_atol is not None else ()):
            check_range(name, getattr(self, name), 0.0, 1.0, low_open=True, high_open=True)
        check_choice("solver", self.solver, SOLVERS)
        check_choice("nonstiff_solver", self.nonstiff_solver, SOLVERS)
        check_choice("root_finder", self.root_finder, get_args(RootFinderName))
        check_choice("differentiation", self.differentiation, get_args(Differentiation))
        check_range("kappa", self.kappa, 0.0, 1.0, low_open=True)
        check_count("max_steps", self.max_steps, 1)
        check_choice("unroll_stages", self.unroll_stages, (False, True))
        if self.checkpoints is not None:
            check_count("checkpoints", self.checkpoints, 1)

    def replace(self, **changes) -> "SolverSettings":
        """A copy with `changes` (validated again)."""
        return dataclasses.replace(self, **changes)

    def controller(self) -> diffrax.PIDController:
        return diffrax.PIDController(rtol=self.rtol, atol=self.atol, pcoeff=self.pcoeff, icoeff=self.icoeff)

    def method(self, *, stiff: bool = True, jacobian=None) -> diffrax.AbstractAdaptiveSolver:
        """The Diffrax solver for a stiff (`solver`) or non-stiff (`nonstiff_solver`) part.
        `jacobian(t, y, args)`, a model's exact df/dy on the flattened state, serves Rodas4."""
        name = self.solver if stiff else self.nonstiff_solver
        if name in HOST_SOLVERS:
            raise InputError(f"solver = {name!r} runs on the host and has no Diffrax method: call solve().")
        if name == "bdf":
            raise InputError("solver = 'bdf' is its own loop (snapo_ode._solver.bdf), not a Diffrax method: call solve().")
        if name in _ROSENBROCK:
            return _ROSENBROCK[name](jacobian=jacobian, unroll_stages=self.unroll_stages)
        if name in _EXPLICIT:
            return _EXPLICIT[name]()
        rtol = self.rtol if self.root_rtol is None else self.root_rtol
        atol = self.atol if self.root_atol is None else self.root_atol
        if self.root_finder == "newton":
            return _ESDIRK[name](root_finder=optx.Newton(rtol=rtol, atol=atol))
        return _ESDIRK[name](root_finder=diffrax.VeryChord(rtol=rtol, atol=atol, kappa=self.kappa))

    def adjoint(self) -> diffrax.AbstractAdjoint:
        """The Diffrax adjoint for `differentiation` (see the class docstring for why)."""
        if self.differentiation == "forward":
            return diffrax.ForwardMode()
        if self.differentiation == "backsolve":
            return diffrax.BacksolveAdjoint()
        return diffrax.RecursiveCheckpointAdjoint(checkpoints=self.checkpoints or self.max_steps)

    def solve(self, vector_field, t0, t1, y0, args=None, *, stiff: bool = True, saveat=None, jacobian=None,
              dt0=None) -> diffrax.Solution:
        """`dy/dt = vector_field(t, y, args)` from `y0` at `t0` to `t1`, through
        `snapo_ode.diffeqsolve_checked` (a failed solve raises with advice; a backsolve adjoint
        is refused on a stiff solve before any compile). `saveat` defaults to the end state."""
        name = self.solver if stiff else self.nonstiff_solver
        if name in HOST_SOLVERS:
            return self._host_solution(name, vector_field, t0, t1, y0, args, saveat or diffrax.SaveAt(t1=True))
        if name == "bdf":
            return self._bdf_solution(vector_field, t0, t1, y0, args, saveat or diffrax.SaveAt(t1=True), jacobian)
        return diffeqsolve_checked(
            diffrax.ODETerm(vector_field), self.method(stiff=stiff, jacobian=jacobian), t0, t1, dt0, y0, args,
            stiff=stiff, saveat=saveat or diffrax.SaveAt(t1=True),
            stepsize_controller=self.controller(), max_steps=self.max_steps, adjoint=self.adjoint())

    def _host_solution(self, name, vector_field, t0, t1, y0, args, saveat) -> diffrax.Solution:
        """A `diffrax.Solution` (ts, ys; no interpolation) from the host solver `name`."""
        ts = _output_times(name, saveat, t1)
        ys = host_solve(name, vector_field, t0, t1, y0, args, ts, rtol=self.rtol, atol=self.atol,
                        max_steps=self.max_steps)
        return _solution(t0, t1, ts, ys, {})

    def _bdf_solution(self, vector_field, t0, t1, y0, args, saveat, jacobian) -> diffrax.Solution:
        """A `diffrax.Solution` (ts, ys, stats; no interpolation) from `snapo_ode._solver.bdf.bdf_solve`,
        whose failures raise as `diffeqsolve_checked`'s do."""
        if self.differentiation == "backsolve":
            raise InputError("solver = 'bdf' with differentiation = 'backsolve': the BDF solver differentiates "
                             "its own steps; use differentiation = 'reverse' or 'forward'.")
        ts = jnp.asarray(_output_times("bdf", saveat, t1), float)
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

        ys, stats, status = bdf_solve(rate, jacobian_flat, jnp.asarray(t0, float), jnp.asarray(t1, float), y0_flat,
                                      args, ts, rtol=self.rtol, atol=self.atol, max_steps=self.max_steps,
                                      reverse=self.differentiation == "reverse", checkpoints=self.checkpoints)
        ys = eqx.error_if(ys, status == 3, "solver = 'bdf': t1 must exceed t0 and every output time lie within "
                                            "[t0, t1]; these traced times do not.")
        ys = checked_ys(ys, (status == 1) | (status == 2), status == 1)
        return _solution(t0, t1, ts, jax.vmap(unravel)(ys), stats._asdict())

    def as_dict(self) -> dict:
        """The settings, JSON-ready (the step controller named)."""
        fields = {field.name: getattr(self, field.name) for field in dataclasses.fields(self)}
        controller = (f"diffrax.PIDController(rtol, atol, pcoeff={self.pcoeff}, icoeff={self.icoeff})"
                      if self.solver != "bdf" else "the BDF's own error test and order selection (snapo_ode._solver.bdf)")
        return {**fields, "step_controller": controller}


def _output_times(name: str, saveat: diffrax.SaveAt, t1):
    """The times a solver without dense output saves at: `saveat`'s ts, or t1 alone."""
    subs = saveat.subs
    if saveat.dense or subs.steps or subs.t0 or (subs.ts is None) == (not subs.t1):
        raise InputError(f"solver = {name!r} saves at t1 or at given ts only (no dense output, steps or t0).")
    return subs.ts if subs.ts is not None else jnp.atleast_1d(jnp.asarray(t1, float))


def _solution(t0, t1, ts, ys, stats: dict) -> diffrax.Solution:
    """A `diffrax.Solution` of a solver outside Diffrax: values at `ts`, no interpolation."""
    return diffrax.Solution(t0=t0, t1=t1, ts=ts, ys=ys, interpolation=None, stats=stats,
                            result=diffrax.RESULTS.successful, solver_state=None, controller_state=None,
                            made_jump=None, event_mask=None)
