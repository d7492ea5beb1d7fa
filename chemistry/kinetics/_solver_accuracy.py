"""`snapo bench accuracy`, study "stiff": error against wall time of stiff solves, one line per
solver, its points the tolerances. Ours (`snapo_ode.Rodas5`, the reactors' default,
`snapo_ode.Rodas4` and the BDF of `snapo_ode._solver.bdf`; Diffrax's Kvaerno5 and Tsit5 through `snapo_ode.SolverSettings`) next to
Cantera's CVODES (`ReactorNet`) and SciPy's BDF, Radau and LSODA on the same right-hand side
(`scaled_problem`, its closed-form Jacobian; the JAX functions compiled once and called from
NumPy):

- Robertson's kinetics to t = 1e5 s (Hairer & Wanner's stiff test; stiffness ratio ~5e8 there);
- h2o2 and gri30 constant-volume ignition (the built-in cases) to their sensitivity times, late
  in the induction: the error of T there;
- the pharma chain (in `chemistry.pharma._accuracy`: its own solvers only).

Each reference is the tightest solve of one method, checked against a second method at the same
tolerance (stated in the panel's notes). Times are medians after compile; a solver that fails
(max steps, a step-size collapse) is a listed failure."""

import pathlib

import diffrax
import equinox as eqx
import jax.numpy as jnp
import numpy as np

from snapo_ode import Panel, Point, Rodas4, agreement, call_checked, timed_point

from ._bench import cantera_seconds
from ._ignition import IGNITION_CASES, initial_concentrations
from ._mechanism import Mechanism
from ._reactor import REACTOR_SOLVER, Reactor, simulate

TARGET = 1e-6
UNROLLED_RODAS4 = Rodas4(unroll_stages=True)
"""Rodas4 with its stages unrolled, as the reactors' Rodas5 (`REACTOR_SOLVER`)."""
CHORD_KVAERNO5 = diffrax.Kvaerno5(root_finder=diffrax.with_stepsize_controller_tols(diffrax.VeryChord)(kappa=0.5))
"""Diffrax's Kvaerno5 as the reactors run it: a chord root finder at the step's tolerances
(Newton takes fewer steps before an ignition but stalls after the front)."""
SOLVERS = {"Rodas5 (ours, default)": REACTOR_SOLVER.solver, "Rodas4 (ours)": UNROLLED_RODAS4, "BDF (ours)": "bdf", "Kvaerno5 (Diffrax)": CHORD_KVAERNO5,
           "Tsit5 (Diffrax, explicit)": "tsit5", "SUNDIALS CVODE (host)": "cvode", "SciPy BDF (host)": "scipy-bdf",
           "SciPy Radau (host)": "scipy-radau", "SciPy LSODA (host)": "scipy-lsoda"}
"""Every solver run through `SolverSettings` on the same model: Diffrax's in the compiled program,
the peers on the host (`snapo_ode._solver.host`)."""
BDF_TIGHT_ATOL = "BDF (ours, atol = rtol x 1e-7)"
HOST_NOTE = ("Host solvers (SUNDIALS CVODE through scikit-sundae, SciPy) call our compiled right-hand side "
             "and Jacobian from Python at every evaluation: their times include that call (tens of "
             "microseconds each), so they overstate what the same method costs in C.")
MAX_STEPS = 20_000


def robertson_panel(rtols, repeats: int) -> Panel:
    """Robertson's kinetics, y = (a, b, c), rate constants (0.04, 1e4, 3e7), to t = 1e5 s."""
    rates = jnp.array([0.04, 1e4, 3e7])
    t1, y0 = 1e5, np.array([1.0, 0.0, 0.0])

    def field(t, y, args=None):
        a, b, c = y[0], y[1], y[2]
        return jnp.stack([-rates[0] * a + rates[1] * b * c, rates[0] * a - rates[1] * b * c - rates[2] * b**2,
                          rates[2] * b**2])

    def solve(settings):
        return eqx.filter_jit(lambda y: settings.solve(field, 0.0, t1, y).ys[-1])

    reference = np.asarray(call_checked(solve(REACTOR_SOLVER.replace(solver="scipy-radau", rtol=1e-13, atol=1e-19)),
                                        jnp.asarray(y0)))

    def error_of(y):
        return agreement(np.asarray(y), reference).max_rel_diff

    rodas4 = REACTOR_SOLVER.replace(solver=UNROLLED_RODAS4, rtol=1e-10, atol=1e-16, max_steps=MAX_STEPS)
    check = error_of(call_checked(solve(rodas4), jnp.asarray(y0)))
    points = []
    for rtol in rtols:
        setting, atol = f"rtol={rtol:g}", rtol * 1e-6
        for method, solver in SOLVERS.items():
            points.append(timed_point(method, setting, solve(REACTOR_SOLVER.replace(
                solver=solver, rtol=rtol, atol=atol, max_steps=MAX_STEPS)), jnp.asarray(y0), error_of, repeats))
    return Panel("stiff_robertson", "Robertson's kinetics to t = 1e5 s (stiffness ratio ~5e8)",
                 "wall time after compile [s]", "max relative error of (a, b, c)", points, target=TARGET,
                 notes=(f"Reference: SciPy Radau at rtol 1e-13 / atol 1e-19; Rodas4 at rtol 1e-10 / atol 1e-16 agrees "
                        f"with it to {check:.1e} (Rodas4 fails here at rtol 1e-11 and tighter: its step size "
                        "collapses on round-off). atol = rtol x 1e-6 for every solver; components below 1e-8 of the "
                        "largest are compared at that scale. " + HOST_NOTE))


def ignition_panel(name: str, rtols, repeats: int) -> Panel:
    """Constant-volume adiabatic ignition of the built-in case `name` ("h2o2", "gri30"): the
    relative error of T at the case's sensitivity time."""
    import cantera

    path = pathlib.Path(cantera.__file__).parent / "data" / f"{name}.yaml"
    case = IGNITION_CASES[name]
    mechanism = Mechanism.from_yaml(path)
    reactor = Reactor(mechanism, "constant-volume", ("energy",))
    concentrations = jnp.asarray(initial_concentrations(path, case))
    t1 = case.sensitivity_time
    times = jnp.array([0.0, t1])

    def solve(settings):
        return eqx.filter_jit(lambda c: simulate(reactor, case.temperature, c, times, settings=settings).temperature[-1])

    rodas4 = REACTOR_SOLVER.replace(solver=UNROLLED_RODAS4, rtol=1e-13, atol=1e-16, max_steps=MAX_STEPS)
    reference = float(call_checked(solve(rodas4), concentrations))
    _, cantera_reference = cantera_seconds(path, case, t1, False, 1, rtol=1e-13, atol=1e-20)

    def error_of(temperature):
        return abs(float(temperature) / reference - 1.0)

    points = []
    for rtol in rtols:
        setting, atol = f"rtol={rtol:g}", rtol * 1e-3
        for method, solver in SOLVERS.items():
            points.append(timed_point(method, setting, solve(REACTOR_SOLVER.replace(
                solver=solver, rtol=rtol, atol=atol, max_steps=MAX_STEPS)), concentrations, error_of, repeats))
        # A BDF's error follows atol more than a Rosenbrock method's (on h2o2 at our atol factor its
        # error levels off at a floor: docs/chemistry.md, The BDF): also at Cantera's atol factor.
        points.append(timed_point(BDF_TIGHT_ATOL, setting, solve(REACTOR_SOLVER.replace(
            solver="bdf", rtol=rtol, atol=rtol * 1e-7, max_steps=MAX_STEPS)), concentrations, error_of, repeats))
        seconds, temperature = cantera_seconds(path, case, t1, False, min(repeats, 3), rtol=rtol, atol=rtol * 1e-7)
        points.append(Point("Cantera CVODES (C++)", setting, seconds, error_of(temperature)))
    return Panel(f"stiff_{name}_ignition", f"{name} ignition ({case.temperature:g} K, {case.composition}): T at "
                 f"{t1 * 1e3:g} ms", "wall time after compile [s]", "relative error of T", points, target=TARGET,
                 notes=(f"Reference: Rodas4 at rtol 1e-13 / atol 1e-16; Cantera's CVODES at rtol 1e-13 / atol 1e-20 "
                        f"agrees with it to {abs(cantera_reference / reference - 1):.1e}. Every solver but Cantera solves "
                        "our scaled state [T / T0, N_k / N0] with atol = rtol x 1e-3; Cantera its own state [m, V, T, "
                        "Y_k] with atol = rtol x 1e-7, in C++: its time is a whole run (nothing to compile); "
                        f"'{BDF_TIGHT_ATOL}' is our BDF at Cantera's atol factor. " + HOST_NOTE))


def stiff_study(*, quick: bool):
    """The "stiff" study (`snapo bench accuracy --only stiff`); the pharma chain's panel comes
    from `chemistry.pharma`."""
    from snapo_ode import AccuracyStudy

    from ..pharma._accuracy import chain_solver_panel

    # --quick (CI's check of the page) keeps the ends of the tolerance range and one timed call.
    rtols = (1e-4, 1e-8) if quick else (1e-3, 1e-4, 1e-5, 1e-6, 1e-7, 1e-8, 1e-9, 1e-10)
    repeats = 1 if quick else 5
    panels = [robertson_panel(rtols, repeats), ignition_panel("h2o2", rtols, repeats),
              chain_solver_panel((1e-6, 1e-8) if quick else rtols[2:], repeats)]
    if not quick:
        panels.insert(2, ignition_panel("gri30", (1e-6, 1e-8, 1e-10), 3))
    text = ("What a given accuracy costs with each stiff solver. Our Rosenbrock methods Rodas5 (order 5, "
            "8 stages; the reactors' default) and Rodas4 (order 4, 6 stages), each one Jacobian and one LU a "
            "step and no Newton iteration, and our variable-order BDF (a Newton iteration reusing its Jacobian "
            "and factorisation across steps, as CVODES does), against Diffrax's ESDIRK Kvaerno5 and explicit Tsit5, "
            "Cantera's CVODES (variable-order BDF) and SciPy's BDF, Radau and LSODA on the same right-hand side. "
            "The peers' times are their own (Cantera in C++, SciPy in Python calling our compiled right-hand side "
            "and Jacobian).")
    return [AccuracyStudy("stiff", "Stiff solves: error against wall time", panels, text)]
