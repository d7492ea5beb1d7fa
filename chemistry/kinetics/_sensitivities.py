"""Sensitivities of the temperature of a constant-volume adiabatic ignition to every reaction's
rate multiplier: ours from one reverse pass through the stiff solve, Cantera's from its forward
sensitivities (CVODES), both as d ln T(t) / d ln A_i."""

from pathlib import Path
from typing import NamedTuple

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np

from snapo_ode import SolverSettings

from ._ignition import IgnitionCase
from ._mechanism import Mechanism
from ._reactor import REACTOR_SOLVER, Reactor, simulate


def final_temperature(log_multiplier, mechanism: Mechanism, concentrations, case: IgnitionCase, time,
                      settings: SolverSettings = REACTOR_SOLVER):
    """T(`time`) [K] of the case's constant-volume adiabatic ignition from `concentrations`
    [kmol/m^3] with the rate multipliers exp(`log_multiplier`) (shape `(n_reactions,)`)."""
    return temperature_at(log_multiplier, mechanism, case.temperature, concentrations, time, settings)


def temperature_at(log_multiplier, mechanism: Mechanism, temperature, concentrations, time,
                   settings: SolverSettings = REACTOR_SOLVER):
    """T(`time`) [K] of a constant-volume adiabatic ignition from `temperature` [K] and
    `concentrations` [kmol/m^3] (shape `(n_species,)`) with the rate multipliers
    exp(`log_multiplier`) (shape `(n_reactions,)`); every argument but `mechanism` and
    `settings` may be traced (`jax.vmap` over conditions: `chemistry.final_temperature_batch`)."""
    reactor = Reactor(mechanism, "constant-volume", ("energy",))
    times = jnp.stack([jnp.zeros(()), jnp.asarray(time, float)])
    return simulate(reactor, temperature, concentrations, times, parameters=with_multipliers(mechanism, log_multiplier),
                    settings=settings).temperature[-1]


def with_multipliers(mechanism: Mechanism, log_multiplier):
    """The mechanism's rate parameters with the multipliers exp(`log_multiplier`), shape
    `(n_reactions,)`."""
    return eqx.tree_at(lambda p: p.log_multiplier, mechanism.parameters, log_multiplier)


@eqx.filter_jit
def temperature_sensitivities(mechanism: Mechanism, concentrations, case: IgnitionCase, time,
                              settings: SolverSettings = REACTOR_SOLVER):
    """d ln T(`time`) / d ln A_i for every reaction i, shape `(n_reactions,)`, from one reverse
    pass (diffrax's `RecursiveCheckpointAdjoint`), and T(`time`) [K]."""
    temperature, gradient = jax.value_and_grad(final_temperature)(
        jnp.zeros(mechanism.n_reactions), mechanism, concentrations, case, time, settings)
    return gradient / temperature, temperature


def cantera_sensitivities(path: str | Path, case: IgnitionCase, time: float, *, rtol: float = 1e-11,
                          atol: float = 1e-17, rtol_sensitivity: float = 1e-6, atol_sensitivity: float = 1e-6,
                          reactions=None, phase: str | None = None):
    """Cantera's `IdealGasReactor` forward sensitivities d ln T(`time`) / d ln A_i for
    `reactions` (default: all), shape `(n,)`, and T(`time`) [K]. Cantera normalises by the
    solution (d ln y / d ln p) with the multipliers at 1, which is exactly this quantity.

    The default tolerances matter: with atol 1e-20 and sensitivity tolerances 1e-8 (tighter,
    one would think) Cantera's h2o2 sensitivities at 0.27 ms are far off central bumps of
    Cantera's own solve; with these they agree with those bumps (docs/dev/chemistry_notes.md, Measurements
    behind the design)."""
    import cantera

    from ._crosscheck import cantera_solution

    solution = cantera_solution(path, phase)
    solution.TPX = case.temperature, case.pressure, case.composition
    reactor = cantera.IdealGasReactor(solution, clone=False)
    indices = range(solution.n_reactions) if reactions is None else reactions
    net = cantera.ReactorNet([reactor])
    for i in indices:
        reactor.add_sensitivity_reaction(i)
    net.rtol, net.atol, net.max_steps = rtol, atol, 200_000
    net.rtol_sensitivity, net.atol_sensitivity = rtol_sensitivity, atol_sensitivity
    net.advance(time)
    return np.array([net.sensitivity("temperature", j) for j in range(len(indices))]), reactor.phase.T


class SensitivityComparison(NamedTuple):
    """The `top` largest sensitivities (by Cantera's magnitude): their reaction `indices`,
    `ours` and `cantera` values, the max relative difference among them, and whether both
    rank them in the same order."""

    indices: np.ndarray
    ours: np.ndarray
    cantera: np.ndarray
    max_relative_difference: float
    same_ranking: bool


def compare_sensitivities(ours, reference, top: int = 10) -> SensitivityComparison:
    """Compare the `top` largest of `reference` (Cantera's) with `ours`, each shape `(n,)`."""
    ours, reference = np.asarray(ours), np.asarray(reference)
    indices = np.argsort(-np.abs(reference))[:top]
    our_order = np.argsort(-np.abs(ours))[:top]
    difference = np.max(np.abs(ours[indices] - reference[indices]) / np.abs(reference[indices]))
    return SensitivityComparison(indices, ours[indices], reference[indices], float(difference),
                                 bool(np.array_equal(indices, our_order)))
