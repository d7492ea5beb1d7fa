"""How each unit of the chain is integrated: an adaptive-step Diffrax solve with the
tolerances exposed, a stiff solver for the stiff units, and the adjoint chosen for the
differentiation mode."""

import dataclasses
from typing import Literal

import diffrax
import equinox as eqx
import optimistix as optx

from snapo_ode import Rodas4, check_choice, check_range
from snapo_ode._ode import diffeqsolve_checked

SolverName = Literal["rodas4", "kvaerno5", "kvaerno4", "kvaerno3", "tsit5", "dopri5"]
DifferentiationMode = Literal["reverse", "forward"]
_ESDIRK = {"kvaerno5": diffrax.Kvaerno5, "kvaerno4": diffrax.Kvaerno4, "kvaerno3": diffrax.Kvaerno3}
_EXPLICIT = {"tsit5": diffrax.Tsit5, "dopri5": diffrax.Dopri5}
STIFF_SOLVERS = ("rodas4",) + tuple(_ESDIRK)
SOLVERS = STIFF_SOLVERS + tuple(_EXPLICIT)


class ChainSolver(eqx.Module):
    """Solver settings shared by the units (each unit is integrated over a normalised time
    [0, 1], its duration a factor of the right-hand side, so a CPP that sets a duration is an
    ordinary differentiable input).

    - `rtol`, `atol`: tolerances of the PID step controller, on the scaled states (concentrations
      [kmol/m^3], T / 300 K, moments scaled to O(1)).
    - `solver`: of the stiff units, R1 and R2 (their Jacobians' largest eigenvalue is ~1e5-1e6
      per unit duration): "rodas4" (default; Rosenbrock, one factorisation a step) or
      "kvaerno5", "kvaerno4", "kvaerno3" (ESDIRK with a Newton stage solver). All L-stable.
    - `nonstiff_solver`: of the crystallizer and the dryer, whose Jacobians' eigenvalues stay
      below ~20 per unit duration at every PAR corner (measured, and tested): "tsit5" (default,
      explicit: no Jacobian to form or differentiate), "dopri5", or any stiff solver's name.
    - `newton_rtol`, `newton_atol`: of the ESDIRK stage equations' Newton iteration
      (`optimistix.Newton`). Looser than the step's: Newton converges quadratically, and
      demanding 1e-10 of it on this stiff system (condition number ~ h * 4e5) meets round-off,
      fails and rejects steps.
    - `max_steps`: per unit; the solve raises with advice if it needs more.
    - `differentiation`: "reverse" (`RecursiveCheckpointAdjoint` with a checkpoint a step, for
      vjp / grad) or "forward" (`diffrax.ForwardMode`, for jvp / jacfwd). Each mode needs its
      own adjoint in Diffrax.
    """

    rtol: float = eqx.field(static=True, default=1e-8)
    atol: float = eqx.field(static=True, default=1e-10)
    solver: str = eqx.field(static=True, default="rodas4")
    nonstiff_solver: str = eqx.field(static=True, default="tsit5")
    max_steps: int = eqx.field(static=True, default=4096)
    differentiation: str = eqx.field(static=True, default="reverse")
    newton_rtol: float = eqx.field(static=True, default=1e-6)
    newton_atol: float = eqx.field(static=True, default=1e-9)

    def __check_init__(self):
        check_range("rtol", self.rtol, 0.0, 1.0, low_open=True, high_open=True)
        check_range("atol", self.atol, 0.0, 1.0, low_open=True, high_open=True)
        check_range("newton_rtol", self.newton_rtol, 0.0, 1.0, low_open=True, high_open=True)
        check_range("newton_atol", self.newton_atol, 0.0, 1.0, low_open=True, high_open=True)
        check_choice("solver", self.solver, STIFF_SOLVERS)
        check_choice("nonstiff_solver", self.nonstiff_solver, SOLVERS)
        check_range("max_steps", self.max_steps, 1)
        check_choice("differentiation", self.differentiation, ("reverse", "forward"))

    def with_differentiation(self, mode: str) -> "ChainSolver":
        return dataclasses.replace(self, differentiation=mode)

    def as_dict(self) -> dict:
        return {"rtol": self.rtol, "atol": self.atol, "solver": self.solver,
                "nonstiff_solver": self.nonstiff_solver, "max_steps": self.max_steps,
                "differentiation": self.differentiation, "newton_rtol": self.newton_rtol,
                "newton_atol": self.newton_atol,
                "step_controller": "diffrax.PIDController(rtol, atol)"}

    def _method(self, name: str) -> diffrax.AbstractAdaptiveSolver:
        if name == "rodas4":
            return Rodas4()
        if name in _EXPLICIT:
            return _EXPLICIT[name]()
        return _ESDIRK[name](root_finder=optx.Newton(rtol=self.newton_rtol, atol=self.newton_atol))

    def solve(self, rhs, y0, args, *, stiff: bool = True, steps: bool = False):
        """The state at normalised time 1 of `dy/ds = rhs(s, y, args)` from `y0` at s = 0, with
        `solver` (`stiff`) or `nonstiff_solver` (with `steps`: the `diffrax.Solution` at every
        accepted step, padded with inf, for checks)."""
        if self.differentiation == "forward":
            adjoint = diffrax.ForwardMode()
        else:
            # A checkpoint at every step: no step is recomputed from an earlier checkpoint. With
            # Diffrax's default (log2(max_steps) checkpoints) the reverse pass through Rodas4 on
            # R1 was off by 1.5e-6 relative at rtol 1e-10, where forward mode and this setting
            # agree to 1e-13 (measured, not understood); the memory is max_steps states per unit.
            adjoint = diffrax.RecursiveCheckpointAdjoint(checkpoints=self.max_steps)
        solution = diffeqsolve_checked(
            diffrax.ODETerm(rhs), self._method(self.solver if stiff else self.nonstiff_solver), 0.0, 1.0, None, y0,
            args, stepsize_controller=diffrax.PIDController(rtol=self.rtol, atol=self.atol),
            saveat=diffrax.SaveAt(steps=steps, t1=not steps), max_steps=self.max_steps, adjoint=adjoint)
        return solution if steps else solution.ys[-1]
