"""One configuration for every ODE solve in the project: the solver objects (a stiff one and a
non-stiff one), tolerances, step controller and the adjoint that differentiates through the
solve; and the registry that turns a solver's name (the CLI and JSON edge) into its object.

Reactors (chemistry) and the pharma chain take a `SolverSettings`; the reasons behind each
default are written here once.
"""

import dataclasses
import functools
from collections.abc import Callable
from typing import Literal, get_args

import diffrax
import equinox as eqx
import optimistix as optx

from .._ode import diffeqsolve_checked
from .._platform.settings import Settings
from .._platform.validation import InputError, check_choice, check_count, check_range
from .base import AbstractSolver
from .bdf import BDF
from .host import CVODE, ScipyBDF, ScipyLSODA, ScipyRadau
from .rosenbrock import AbstractRosenbrock, Rodas4, Rodas5

SolverName = Literal["rodas4", "rodas5", "bdf", "kvaerno5", "kvaerno4", "kvaerno3", "tsit5", "dopri5",
                     "cvode", "scipy-bdf", "scipy-radau", "scipy-lsoda"]
Differentiation = Literal["reverse", "forward", "backsolve"]
Solver = AbstractSolver | diffrax.AbstractAdaptiveSolver
"""A solver object: one of Diffrax's adaptive solvers (`snapo_ode.Rodas5`, `diffrax.Kvaerno5`,
...) or an `AbstractSolver` of our own (`BDF`, the host peers)."""


@dataclasses.dataclass(frozen=True)
class _Registered:
    make: Callable[[], Solver]
    kind: type
    stiff: bool


_REGISTRY: dict[str, _Registered] = {}


def register_solver(name: str, make: Callable[[], Solver], *, stiff: bool) -> None:
    """Make `make()` (a solver object with its default options) available by `name` wherever a
    solver is chosen by name: `SolverSettings(solver=name)`, the CLI flags and JSON files.
    `stiff`: whether it is meant for stiff problems (`solver_names(stiff=True)`; the host peers
    are, though `STIFF_SOLVERS` lists only the built-ins that run inside a program)."""
    if not name or name != name.strip().lower():
        raise InputError(f"solver name {name!r}: lower case, no surrounding spaces.")
    solver = make()
    if not isinstance(solver, Solver):
        raise InputError(f"solver {name!r}: make() returned {type(solver).__name__}, not a diffrax adaptive solver "
                         "or a snapo_ode AbstractSolver.")
    _REGISTRY[name] = _Registered(make, type(solver), stiff)


def unregister_solver(name: str) -> None:
    """Remove `name` from the registry (a plugin's or a test's own solver)."""
    _REGISTRY.pop(name, None)


def solver_names(*, stiff: bool | None = None) -> tuple[str, ...]:
    """The registered names (all, or only the stiff or non-stiff ones)."""
    return tuple(name for name, entry in _REGISTRY.items() if stiff is None or entry.stiff == stiff)


def solver_from_name(name: str, field: str = "solver") -> Solver:
    """The solver registered as `name`, with its default options."""
    check_choice(field, name, solver_names())
    return _REGISTRY[name].make()


def solver_name(solver: Solver) -> str:
    """The name a solver object is registered under (its class's), or its class name."""
    return next((name for name, entry in _REGISTRY.items() if type(solver) is entry.kind), type(solver).__name__)


def solver_options(solver: Solver) -> dict:
    """A solver object's own options, JSON-ready (numbers and names as they are, other objects
    as their repr; a model's Jacobian function left out)."""
    values = {field.name: getattr(solver, field.name) for field in dataclasses.fields(solver) if field.name != "jacobian"}
    return {name: value if isinstance(value, (bool, int, float, str, type(None))) else " ".join(repr(value).split())
            for name, value in values.items()}


def _as_solver(value, field: str) -> Solver:
    """A solver name (the CLI and JSON edge) or object, as an object."""
    if isinstance(value, str):
        return solver_from_name(value, field)
    if isinstance(value, Solver):
        return value
    raise InputError(f"{field} = {value!r}: not a solver; allowed: a name ({', '.join(solver_names())}) or a "
                     "solver object (a diffrax adaptive solver or a snapo_ode AbstractSolver).")


def _kvaerno(method: type) -> Callable[[], Solver]:
    """An ESDIRK method whose stage equations are solved by Newton at the step's tolerances."""
    return lambda: method(root_finder=diffrax.with_stepsize_controller_tols(optx.Newton)())


for _name, _make, _stiff in (
        ("rodas4", Rodas4, True), ("rodas5", Rodas5, True), ("bdf", BDF, True),
        ("kvaerno5", _kvaerno(diffrax.Kvaerno5), True), ("kvaerno4", _kvaerno(diffrax.Kvaerno4), True),
        ("kvaerno3", _kvaerno(diffrax.Kvaerno3), True), ("tsit5", diffrax.Tsit5, False),
        ("dopri5", diffrax.Dopri5, False), ("cvode", CVODE, True), ("scipy-bdf", ScipyBDF, True),
        ("scipy-radau", ScipyRadau, True), ("scipy-lsoda", ScipyLSODA, True)):
    register_solver(_name, _make, stiff=_stiff)
SOLVERS: tuple[str, ...] = get_args(SolverName)
"""The built-in solvers' names (`solver_names()` lists the registered ones, plugins' too)."""
STIFF_SOLVERS: tuple[str, ...] = ("rodas4", "rodas5", "bdf", "kvaerno5", "kvaerno4", "kvaerno3")
"""The built-in stiff solvers that run inside a program (not the host peers)."""


class SolverSettings(Settings):
    """How an ODE is integrated. Static: two settings compile to two programs.

    **Fields:**
    - `rtol`, `atol`: tolerances of the adaptive step (`diffrax.PIDController`, or a solver's own
      error test), on the state as the model scales it (models scale their states to O(1) so
      that one `atol` means the same for every component).
    - `solver`: the solver object for stiff models (or the stiff units of a chain), carrying its
      own options, or a registered name (`solver_names()`), which becomes its object with default
      options: `snapo_ode.Rodas4()` (default: one Jacobian and one LU a step, no Newton
      iteration), `snapo_ode.Rodas5()` (the same with 8 stages and order 5: fewer steps at tight
      tolerances), `snapo_ode.BDF()` (variable-order BDF/NDF whose Newton iteration reuses its
      Jacobian and factorisation across steps, as CVODES does; saves at given times only),
      Diffrax's ESDIRK `diffrax.Kvaerno5(root_finder=...)` (by name: Newton at the step's
      tolerances), 4 and 3, an explicit method ("tsit5", "dopri5", then used for every part), or
      a host peer (`CVODE()`, `ScipyBDF()`, `ScipyRadau()`, `ScipyLSODA()`: values only, no
      derivative or dense output, for comparisons of accuracy and time). Rodas4 is the default
      because it holds up on whole ignitions where an ESDIRK with either root finder stalled or
      hit max_steps, and because its reverse pass has no root finder's implicit derivative,
      which failed on rejected steps of a gri30 ignition.
    - `nonstiff_solver`: for the parts a model declares non-stiff (`solve(..., stiff=False)`),
      e.g. the pharma crystallizer and dryer: `diffrax.Tsit5()` (default: explicit, no Jacobian
      to form or differentiate), or any solver.
    - `pcoeff`, `icoeff`: the PID controller's coefficients (0, 1: a plain integral controller;
      a PID drifted at an ignition front).
    - `max_steps`: the solve raises `SolverFailed` (with advice) if it needs more.
    - `differentiation`: how a derivative goes through the solve:
      - "reverse" (default): `RecursiveCheckpointAdjoint` with `checkpoints` (default
        `max_steps`, a checkpoint at every step, so that no step is recomputed from an earlier
        checkpoint: with fewer, the reverse pass through a stiff solve drifts from forward mode
        at tight tolerances; the memory is `max_steps` states).
      - "forward": `diffrax.ForwardMode`, for `jax.jvp` / `jax.jacfwd` (few inputs, many
        outputs). Diffrax needs a different adjoint for each mode.
      - "backsolve": `diffrax.BacksolveAdjoint`, refused on stiff solves (its backward solve
        diverges there: max_steps, or gradients near 1e297).
    - `checkpoints`: of the reverse adjoint; `None` is `max_steps` (see above).
    """

    rtol: float = eqx.field(static=True, default=1e-8)
    atol: float = eqx.field(static=True, default=1e-10)
    solver: Solver = eqx.field(static=True, default="rodas4", converter=functools.partial(_as_solver, field="solver"))
    nonstiff_solver: Solver = eqx.field(static=True, default="tsit5",
                                        converter=functools.partial(_as_solver, field="nonstiff_solver"))
    pcoeff: float = eqx.field(static=True, default=0.0)
    icoeff: float = eqx.field(static=True, default=1.0)
    max_steps: int = eqx.field(static=True, default=20_000)
    differentiation: Differentiation = eqx.field(static=True, default="reverse")
    checkpoints: int | None = eqx.field(static=True, default=None)

    def __check_init__(self):
        for name in ("rtol", "atol"):
            check_range(name, getattr(self, name), 0.0, 1.0, low_open=True, high_open=True)
        check_choice("differentiation", self.differentiation, get_args(Differentiation))
        check_count("max_steps", self.max_steps, 1)
        if self.checkpoints is not None:
            check_count("checkpoints", self.checkpoints, 1)
        for field in ("solver", "nonstiff_solver"):
            if self.differentiation == "backsolve" and isinstance(getattr(self, field), BDF):
                raise InputError(f"{field} = 'bdf' with differentiation = 'backsolve': the BDF solver "
                                 "differentiates its own steps; use differentiation = 'reverse' or 'forward'.")

    def controller(self) -> diffrax.PIDController:
        return diffrax.PIDController(rtol=self.rtol, atol=self.atol, pcoeff=self.pcoeff, icoeff=self.icoeff)

    def method(self, *, stiff: bool = True, jacobian=None) -> diffrax.AbstractAdaptiveSolver:
        """The Diffrax solver for a stiff (`solver`) or non-stiff (`nonstiff_solver`) part.
        `jacobian(t, y, args)`, a model's exact df/dy, serves a Rosenbrock method that has none."""
        solver = self.solver if stiff else self.nonstiff_solver
        if isinstance(solver, AbstractSolver):
            raise InputError(f"solver = {solver_name(solver)!r} is not a Diffrax method "
                             f"({type(solver).__name__} integrates by itself): call solve().")
        if isinstance(solver, AbstractRosenbrock) and solver.jacobian is None and jacobian is not None:
            return dataclasses.replace(solver, jacobian=jacobian)
        return solver

    def adjoint(self) -> diffrax.AbstractAdjoint:
        """The Diffrax adjoint for `differentiation` (see the class docstring for why)."""
        if self.differentiation == "forward":
            return diffrax.ForwardMode()
        if self.differentiation == "backsolve":
            return diffrax.BacksolveAdjoint()
        return diffrax.RecursiveCheckpointAdjoint(checkpoints=self.checkpoints or self.max_steps)

    def solve(self, vector_field, t0, t1, y0, args=None, *, stiff: bool = True, saveat=None, jacobian=None,
              dt0=None) -> diffrax.Solution:
        """`dy/dt = vector_field(t, y, args)` from `y0` at `t0` to `t1`, through the solver's own
        `solve` or `snapo_ode.diffeqsolve_checked` (a failed solve raises with advice; a
        backsolve adjoint is refused on a stiff solve before any compile). `saveat` defaults to
        the end state."""
        solver, saveat = (self.solver if stiff else self.nonstiff_solver), saveat or diffrax.SaveAt(t1=True)
        if isinstance(solver, AbstractSolver):
            return solver.solve(self, vector_field, t0, t1, y0, args, saveat, jacobian)
        return diffeqsolve_checked(
            diffrax.ODETerm(vector_field), self.method(stiff=stiff, jacobian=jacobian), t0, t1, dt0, y0, args,
            stiff=stiff, saveat=saveat, stepsize_controller=self.controller(), max_steps=self.max_steps,
            adjoint=self.adjoint())

    def as_dict(self) -> dict:
        """The settings, JSON-ready: each solver by its name and its own options, the step
        controller named."""
        fields = super().as_dict()
        controller = (self.solver.controller_description(self) if isinstance(self.solver, AbstractSolver) else
                      f"diffrax.PIDController(rtol, atol, pcoeff={self.pcoeff}, icoeff={self.icoeff})")
        return {**fields, "solver": solver_name(self.solver), "solver_options": solver_options(self.solver),
                "nonstiff_solver": solver_name(self.nonstiff_solver),
                "nonstiff_solver_options": solver_options(self.nonstiff_solver), "step_controller": controller}
