"""Cross-checks against Cantera (imported lazily): rates and species thermo at random states, used by
the tests and by `snapo kinetics check`."""

from pathlib import Path
from typing import NamedTuple

import equinox as eqx
import jax
import numpy as np

from ._mechanism import Mechanism

# A net rate smaller than this fraction of its species' gross creation + destruction is the
# difference of nearly equal numbers: its relative error is round-off amplified, not a mismatch.
CANCELLATION = 1e-4


class RateComparison(NamedTuple):
    """Max relative errors against Cantera over `n_states` random states: `rates_of_progress`
    (forward and reverse, every reaction), `net_production` (species whose net rate is not
    cancellation noise), and `n_compared` such species-state pairs."""

    n_states: int
    rates_of_progress: float
    net_production: float
    n_compared: int


def cantera_solution(path: str | Path, phase: str | None = None):
    """A `cantera.Solution` of the same file and phase."""
    import cantera

    return cantera.Solution(str(path), phase or "")


def random_states(n_species: int, n_states: int, seed: int = 0, *, temperature=(300.0, 2500.0),
                  pressure=(1e3, 1e7)):
    """`n_states` random (T [K], P [Pa], mole fractions (n_species,)), one in five species
    absent per state so that zero concentrations are exercised."""
    rng = np.random.default_rng(seed)
    temperatures = rng.uniform(*temperature, n_states)
    pressures = np.exp(rng.uniform(np.log(pressure[0]), np.log(pressure[1]), n_states))
    fractions = rng.random((n_states, n_species)) ** 3 * (rng.random((n_states, n_species)) > 0.2)
    fractions[:, 0] += 1e-3
    return temperatures, pressures, fractions / fractions.sum(axis=1, keepdims=True)


@eqx.filter_jit
def _batched_rates(mechanism: Mechanism, temperatures, concentrations):
    return jax.vmap(mechanism.rates_of_progress)(temperatures, concentrations)


def compare_rates(mechanism: Mechanism, path, phase=None, *, n_states: int = 120, seed: int = 0,
                  temperature=(300.0, 2500.0), pressure=(1e3, 1e7)) -> RateComparison:
    """Rates of progress and net production rates at `n_states` random states (`temperature`
    [K] and `pressure` [Pa] ranges) against Cantera. A phase without reactions compares nothing
    (errors 0, `n_compared` 0).

    **Raises:** `ValueError` if Cantera reads other species or another number of reactions
    from the file: the rates would be compared position by position."""
    solution = cantera_solution(path, phase)
    if tuple(solution.species_names) != mechanism.species_names or solution.n_reactions != mechanism.n_reactions:
        raise ValueError(f"{path} (phase {phase}): Cantera reads {solution.n_species} species and "
                         f"{solution.n_reactions} reactions, we read {mechanism.n_species} and {mechanism.n_reactions}"
                         " (or the species differ).")
    if not mechanism.n_reactions:
        return RateComparison(n_states, 0.0, 0.0, 0)
    temperatures, pressures, fractions = random_states(mechanism.n_species, n_states, seed,
                                                       temperature=temperature, pressure=pressure)
    reference = {"concentrations": [], "forward": [], "reverse": [], "net": [], "gross": []}
    for t, p, x in zip(temperatures, pressures, fractions):
        if mechanism.thermo_model == "ideal-gas":
            solution.TPX = t, p, x
        else:
            solution.TPX = t, None, x
        reference["concentrations"].append(solution.concentrations)
        reference["forward"].append(solution.forward_rates_of_progress)
        reference["reverse"].append(solution.reverse_rates_of_progress)
        reference["net"].append(solution.net_production_rates)
        reference["gross"].append(solution.creation_rates + solution.destruction_rates)
    ref = {key: np.array(value) for key, value in reference.items()}
    forward, reverse = (np.asarray(a) for a in _batched_rates(mechanism, temperatures, ref["concentrations"]))
    progress = max(_relative(forward, ref["forward"]), _relative(reverse, ref["reverse"]))
    net = (forward - reverse) @ np.asarray(mechanism.net_stoichiometry)
    clean = np.abs(ref["net"]) > CANCELLATION * ref["gross"]
    net_error = _relative(net[clean], ref["net"][clean])
    return RateComparison(n_states, progress, net_error, int(clean.sum()))


def _relative(ours, reference) -> float:
    scale = np.abs(reference)
    mask = scale > 0
    mismatch = np.abs(ours - reference)
    if np.any(mismatch[~mask] > 0):
        return float("inf")
    return float(np.max(mismatch[mask] / scale[mask], initial=0.0))


@eqx.filter_jit
def _batched_thermo(mechanism: Mechanism, temperatures):
    thermo = mechanism.thermo
    return jax.vmap(lambda t: (thermo.cp_r(t), thermo.h_rt(t), thermo.s_r(t)))(temperatures)


def compare_thermo(mechanism: Mechanism, path, phase=None, *, n_states: int = 120, seed: int = 0,
                   temperature=(300.0, 2500.0)) -> float:
    """The largest error of the species' reference-state cp/R, h/(R T) and s/R against Cantera's
    at `n_states` random temperatures [K], relative to max(|Cantera's value|, 1): h/(R T) crosses
    zero, where a plain relative error means nothing. It checks what a phase without reactions
    reads, and the thermo behind every reverse rate."""
    solution = cantera_solution(path, phase)
    temperatures = np.random.default_rng(seed).uniform(*temperature, n_states)
    reference = []
    for t in temperatures:
        solution.TP = t, solution.reference_pressure
        reference.append((solution.standard_cp_R, solution.standard_enthalpies_RT, solution.standard_entropies_R))
    ours = np.stack([np.asarray(a) for a in _batched_thermo(mechanism, temperatures)], axis=1)
    reference = np.array(reference)
    return float(np.max(np.abs(ours - reference) / np.maximum(np.abs(reference), 1.0), initial=0.0))
