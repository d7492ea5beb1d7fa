"""Cross-checks against Cantera (imported lazily): rates at random states, used by the tests and by
`snapo kinetics check`."""

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
                  temperature=(300.0, 2500.0)) -> RateComparison:
    """Rates of progress and net production rates at `n_states` random states against Cantera."""
    solution = cantera_solution(path, phase)
    temperatures, pressures, fractions = random_states(mechanism.n_species, n_states, seed,
                                                       temperature=temperature)
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
