"""Constant-volume adiabatic ignition, ours and Cantera's, with one definition of the ignition
delay for both: the first time the temperature reaches T0 + `rise` [K], located by bisection on
each solver's own interpolant (our dense output; for Cantera, restarts from the last step before
the crossing), so the delay is accurate to the solve, not to the output grid."""

from pathlib import Path
from typing import NamedTuple

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np

from snapo_ode import InputError, SolverSettings, call_checked, check_range, exported

from ._mechanism import Mechanism
from ._reactor import REACTOR_SOLVER, Reactor, Trajectory, simulate
from ._units import ONE_ATM

IGNITION_RISE = 400.0
"""The temperature rise [K] that defines the ignition delay."""


class IgnitionCase(NamedTuple):
    """A constant-volume adiabatic ignition: the mixture `composition` (Cantera's "A:1,B:2"
    mole ratios) at `temperature` [K] and `pressure` [Pa], integrated to `end_time` [s];
    sensitivities of T are taken at `sensitivity_time` [s] (late in the induction, where they
    are large and the solve is still smooth)."""

    composition: str
    temperature: float
    pressure: float
    end_time: float
    sensitivity_time: float


IGNITION_CASES = {
    "h2o2": IgnitionCase("H2:2,O2:1,N2:3.76", 1000.0, ONE_ATM, 1e-3, 2.7e-4),
    "gri30": IgnitionCase("CH4:1,O2:2,N2:7.52", 1500.0, ONE_ATM, 5e-3, 1.0e-3),
}
"""The built-in cases, keyed by the Cantera mechanism file's stem."""


def initial_concentrations(path: str | Path, case: IgnitionCase, phase: str | None = None) -> np.ndarray:
    """The case's molar concentrations [kmol/m^3], shape `(n_species,)`, as Cantera computes them."""
    from ._crosscheck import cantera_solution

    solution = cantera_solution(path, phase)
    solution.TPX = case.temperature, case.pressure, case.composition
    return solution.concentrations


def ignition_delay(trajectory: Trajectory, initial_temperature, rise: float = IGNITION_RISE,
                   iterations: int = 60):
    """The first time [s] the temperature reaches `initial_temperature` + `rise` [K], by bisection
    on the dense output of `simulate(..., dense=True)` between the two saved times around it.

    **Raises:** `InputError` without dense output; inside jit, if the temperature never gets there.
    """
    if trajectory.solution.interpolation is None:
        raise InputError("ignition_delay needs simulate(..., dense=True).")
    threshold = initial_temperature + rise
    above = trajectory.temperature >= threshold
    first = jnp.argmax(above)
    bracket = trajectory.times[jnp.maximum(first - 1, 0)], trajectory.times[first]

    def halve(_, bracket):
        low, high = bracket
        middle = 0.5 * (low + high)
        hot = trajectory.solution.evaluate(middle)[0] * initial_temperature >= threshold
        return jnp.where(hot, low, middle), jnp.where(hot, middle, high)

    low, high = jax.lax.fori_loop(0, iterations, halve, bracket)
    # On the float delay, not on the boolean `above`: under `snapo_ode.call_checked` a failed
    # check is a NaN mark, which a boolean cannot carry (on the boolean, the check vanished and
    # the delay read 0).
    return eqx.error_if(0.5 * (low + high), ~jnp.any(above), "the temperature never reaches T0 + rise: no "
                        "ignition before the last saved time; integrate longer or lower `rise`.")


class IgnitionResult(NamedTuple):
    """One ignition run: `times` [s] (shape `(n_t,)`), `temperature` [K] (shape `(n_t,)`) and
    the ignition `delay` [s]; `steps`: accepted steps (ours) or CVODES steps (Cantera)."""

    times: np.ndarray
    temperature: np.ndarray
    delay: float
    steps: int


def solve_ignition(mechanism: Mechanism, concentrations, case: IgnitionCase, times, *,
                   settings: SolverSettings = REACTOR_SOLVER, rise: float = IGNITION_RISE):
    """Our constant-volume adiabatic ignition from `concentrations` [kmol/m^3] at
    `case.temperature`, saved at `times` [s]: an `IgnitionResult`.

    **Raises:** `SolverFailed` with advice if the solve fails or the temperature never reaches
    T0 + `rise` before the last of `times`."""
    times = np.asarray(times, float)
    temperature, delay, steps = call_checked(
        _exported_ignition, mechanism, jnp.asarray(concentrations, float), jnp.asarray(case.temperature, float),
        jnp.asarray(times), settings, rise, what="the ignition", causes=(late_ignition(times, rise),))
    return IgnitionResult(times, np.asarray(temperature), float(delay), int(steps))


def late_ignition(times, rise: float) -> str:
    """The advice on a NaN delay for `snapo_ode.call_checked`'s `causes`: the temperature did not
    reach T0 + `rise` [K] before the last of `times` [s]."""
    return (f"the temperature never reached T0 + {rise:g} K before the last saved time ({float(times[-1]):g} s): "
            "integrate longer or lower `rise`.")


@eqx.filter_jit
def _ignition(mechanism: Mechanism, concentrations, temperature, times, settings: SolverSettings, rise: float):
    """`solve_ignition`'s program: the temperature at `times`, the delay and the accepted steps."""
    reactor = Reactor(mechanism, "constant-volume", ("energy",))
    trajectory, delay = trajectory_and_delay(reactor, temperature, concentrations, times, settings, rise)
    return trajectory.temperature, delay, trajectory.solution.stats["num_accepted_steps"]


_exported_ignition = exported(_ignition, name="kinetics-ignition")
"""Kept on disk traced (`snapo_ode.exported`) and run through `snapo_ode.call_checked`, whose
runtime checks are NaN marks rather than host callbacks, so that the compilation cache keeps its
executable: traced with callbacks it was compiled again in every process, a large share of a
warm `snapo kinetics check h2o2.yaml` (docs/dev/chemistry_notes.md, Measurements behind the design)."""


def trajectory_and_delay(reactor: Reactor, temperature, concentrations, times, settings: SolverSettings,
                         rise: float, parameters=None) -> tuple[Trajectory, jax.Array]:
    """The `simulate` trajectory (dense) from `temperature` [K] and `concentrations` [kmol/m^3]
    and its ignition delay [s]; any argument but `reactor`, `settings` and `rise` may be traced
    (`solve_ignition_batch` maps it over conditions)."""
    trajectory = simulate(reactor, temperature, concentrations, times, parameters=parameters, settings=settings,
                          dense=True)
    return trajectory, ignition_delay(trajectory, temperature, rise)


def cantera_ignition(path: str | Path, case: IgnitionCase, times, *, rtol: float = 1e-12,
                     atol: float = 1e-20, rise: float = IGNITION_RISE, phase: str | None = None,
                     iterations: int = 60) -> IgnitionResult:
    """Cantera's `IdealGasReactor` (constant volume, adiabatic) from the case, temperature at
    `times` [s], and the ignition delay: step to the first CVODES step past T0 + `rise`, then
    bisect in that step by restarting from its start."""
    import cantera

    from ._crosscheck import cantera_solution

    check_range("rise", rise, 0.0, low_open=True)
    solution = cantera_solution(path, phase)
    solution.TPX = case.temperature, case.pressure, case.composition

    def network(start_time):
        reactor = cantera.IdealGasReactor(solution, clone=False)
        net = cantera.ReactorNet([reactor])
        net.rtol, net.atol = rtol, atol
        net.initial_time = start_time
        return reactor, net

    reactor, net = network(0.0)
    temperatures = []
    for t in np.asarray(times):
        net.advance(float(t)) if t > 0 else None
        temperatures.append(reactor.phase.T)
    threshold = case.temperature + rise
    solution.TPX = case.temperature, case.pressure, case.composition
    reactor, net = network(0.0)
    steps, before = 0, (0.0, solution.TDY)
    while reactor.phase.T < threshold:
        before = (net.time, reactor.phase.TDY)
        net.step()
        steps += 1
        if net.time > times[-1]:
            raise InputError("Cantera's temperature never reaches T0 + rise before the end time.")
    low, high = before[0], net.time
    for _ in range(iterations):
        middle = 0.5 * (low + high)
        solution.TDY = before[1]
        reactor, net = network(before[0])
        net.advance(middle)
        low, high = (low, middle) if reactor.phase.T >= threshold else (middle, high)
    return IgnitionResult(np.asarray(times), np.asarray(temperatures), 0.5 * (low + high), steps)
