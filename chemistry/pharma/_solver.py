"""How each unit of the chain is integrated: a stiff ESDIRK solver with an adaptive step, the
tolerances exposed, and the adjoint chosen for the differentiation mode."""

import dataclasses
from typing import Literal

import diffrax
import equinox as eqx
import optimistix as optx

from snapo_ode import check_choice, check_range
from snapo_ode._ode import diffeqsolve_checked

SolverName = Literal["kvaerno5", "kvaerno4", "kvaerno3"]
DifferentiationMode = Literal["reverse", "forward"]
_SOLVERS = {"kvaerno5": diffrax.Kvaerno5, "kvaerno4": diffrax.Kvaerno4, "kvaerno3": diffrax.Kvaerno3}


class ChainSolver(eqx.Module):
    """Solver settings shared by the units (each unit is integrated over a normalised time
    [0, 1], its duration a factor of the right-hand side, so a CPP that sets a duration is an
    ordinary differentiable input).

    - `rtol`, `atol`: tolerances of the PID step controller, on the scaled states (concentrations
      [kmol/m^3], T / 300 K, moments scaled to O(1)).
    - `newton_rtol`, `newton_atol`: of the stage equations' Newton iteration (`optimistix.Newton`).
      Looser than the step's: Newton converges quadratically, and demanding 1e-10 of it on this
      stiff system (condition number ~ h * 4e5) meets round-off, fails and rejects steps.
    - `solver`: "kvaerno5" (default), "kvaerno4" or "kvaerno3" (ESDIRK, L-stable).
    - `max_steps`: per unit; the solve raises with advice if it needs more.
    - `differentiation`: "reverse" (`RecursiveCheckpointAdjoint`, for vjp / grad) or "forward"
      (`diffrax.ForwardMode`, for jvp / jacfwd). Each mode needs its own adjoint in Diffrax.
    """

    rtol: float = eqx.field(static=True, default=1e-8)
    atol: float = eqx.field(static=True, default=1e-10)
    solver: str = eqx.field(static=True, default="kvaerno5")
    max_steps: int = eqx.field(static=True, default=4096)
    differentiation: str = eqx.field(static=True, default="reverse")
    newton_rtol: float = eqx.field(static=True, default=1e-6)
    newton_atol: float = eqx.field(static=True, default=1e-9)

    def __check_init__(self):
        check_range("rtol", self.rtol, 0.0, 1.0, low_open=True, high_open=True)
        check_range("atol", self.atol, 0.0, 1.0, low_open=True, high_open=True)
        check_range("newton_rtol", self.newton_rtol, 0.0, 1.0, low_open=True, high_open=True)
        check_range("newton_atol", self.newton_atol, 0.0, 1.0, low_open=True, high_open=True)
        check_choice("solver", self.solver, tuple(_SOLVERS))
        check_range("max_steps", self.max_steps, 1)
        check_choice("differentiation", self.differentiation, ("reverse", "forward"))

    def with_differentiation(self, mode: str) -> "ChainSolver":
        return dataclasses.replace(self, differentiation=mode)

    def as_dict(self) -> dict:
        return {"rtol": self.rtol, "atol": self.atol, "solver": self.solver, "max_steps": self.max_steps,
                "differentiation": self.differentiation, "newton_rtol": self.newton_rtol,
                "newton_atol": self.newton_atol,
                "step_controller": "diffrax.PIDController(rtol, atol)"}

    def solve(self, rhs, y0, args, *, steps: bool = False):
        """The state at normalised time 1 of `dy/ds = rhs(s, y, args)` from `y0` at s = 0 (with
        `steps`: the `diffrax.Solution` at every accepted step, padded with inf, for checks)."""
        root_finder = optx.Newton(rtol=self.newton_rtol, atol=self.newton_atol)
        adjoint = diffrax.ForwardMode() if self.differentiation == "forward" else diffrax.RecursiveCheckpointAdjoint()
        solution = diffeqsolve_checked(
            diffrax.ODETerm(rhs), _SOLVERS[self.solver](root_finder=root_finder), 0.0, 1.0, None, y0, args,
            stepsize_controller=diffrax.PIDController(rtol=self.rtol, atol=self.atol),
            saveat=diffrax.SaveAt(steps=steps, t1=not steps), max_steps=self.max_steps, adjoint=adjoint)
        return solution if steps else solution.ys[-1]
