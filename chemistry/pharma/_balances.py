"""Mass balances of every unit of a process, each a relative residual that is round-off when the
unit conserves what it should: a reactor its total mass and every element (reactions move atoms,
they do not make them), the crystallizer each species between the liquor and the crystals, the
filter each species group between the slurry and wash and the cake and filtrate, the dryer the
solids (the API it degrades stays in the product as degradant). A reviewer reads them first;
`snapo report pharma` states them and the tests hold them to round-off on every shipped process
and on random ones."""

import functools

import cantera
import equinox as eqx
import jax.numpy as jnp
import numpy as np

from ._chain import PharmaChain
from ._crystallizer import Slurry, seed_mass
from ._filter import Filter
from ._parameters import ChainInputs
from ._unit import Liquid, Solids
from ._unit_catalogue import UNIT_ROLES

CONSERVED = {
    "reactor": "total mass and every element, inlet to outlet",
    "crystallizer": "the crystals' growth (the seeds aside) against the API, impurity and degradant the liquor lost",
    "filter": "API, impurity, degradant, other solutes and solvent: slurry and wash against cake and filtrate",
    "dryer": "the solids (the API it degrades stays as degradant); the solvent only leaves",
}
"""What the balance of a unit of each role holds (`mass_balances`), as the report states it."""


@functools.cache
def element_matrix(mechanism: str, phase: str | None) -> np.ndarray:
    """Atoms of each element in each species, shape (n_elements, n_species) (Cantera's)."""
    solution = cantera.Solution(mechanism, phase or "")
    return np.array([[solution.n_atoms(k, e) for k in range(solution.n_species)] for e in range(solution.n_elements)])


def _relative(difference, scale):
    return jnp.max(jnp.abs(difference)) / jnp.maximum(jnp.max(jnp.abs(scale)), 1e-300)


def _groups(masses, roles) -> jnp.ndarray:
    """[api, impurity, degradant, other, solvents] masses of a per-species mass vector."""
    solvents = sum(masses[k] for k in roles.solvents)
    tracked = masses[roles.api] + masses[roles.impurity] + masses[roles.degradant] + solvents
    return jnp.stack([masses[roles.api], masses[roles.impurity], masses[roles.degradant],
                      jnp.sum(masses) - tracked, solvents])


def _solids(solids: Solids) -> jnp.ndarray:
    return jnp.stack([solids.api, solids.impurity, solids.degradant, solids.other, solids.solvent])


@eqx.filter_jit
def mass_balances(chain: PharmaChain, inputs: ChainInputs) -> dict[str, jnp.ndarray]:
    """unit name -> its largest relative residual (see the module docstring), at `inputs`."""
    result = chain.simulate(inputs)
    parameters, masses, roles = chain.unit_parameters(inputs), chain.molar_masses, chain.roles
    elements = jnp.asarray(element_matrix(chain.process.mechanism, chain.process.phase))
    residuals, inlet = {}, chain.feed(inputs)
    for name, unit in chain.units(inputs):
        outlet = result.outlets[name]
        if isinstance(outlet, Liquid):
            before, after = inlet.amounts, outlet.amounts
            residuals[name] = jnp.maximum(_relative(after @ masses - before @ masses, before @ masses),
                                          _relative(elements @ (after - before), elements @ before))
        elif isinstance(outlet, Slurry):
            # The crystals' growth (the seeds aside) is the API, impurity and degradant the liquor lost
            # (the impurity and degradant are counted as they leave it: `impurity_solid`).
            crystals, held = outlet.crystals, outlet.crystal_masses(masses, roles)
            seeds = seed_mass(unit, parameters[name])
            lost = (outlet.liquor[roles.api] - crystals.api) * masses[roles.api] + held[roles.impurity] + held[roles.degradant]
            residuals[name] = _relative(crystals.crystal_mass - seeds - lost, crystals.crystal_mass)
        elif isinstance(unit, Filter):
            streams = unit.streams(inlet, parameters[name])
            into = _groups(inlet.crystal_masses(masses, roles) + inlet.final_liquor(roles) * masses, roles)
            into = into.at[4].add(streams.wash)
            residuals[name] = _relative(_solids(streams.cake) + _groups(streams.filtrate, roles) - into, into)
        else:  # a dryer: the solids stay, the solvent only leaves
            before, after = _solids(inlet), _solids(outlet)
            residuals[name] = jnp.maximum(_relative(jnp.sum(after[:4]) - jnp.sum(before[:4]), jnp.sum(before[:4])),
                                          jnp.maximum(after[4] - before[4], 0.0) / before[4])
        inlet = outlet
    return residuals


def balance_table(chain: PharmaChain, inputs: ChainInputs) -> list[dict]:
    """The report's mass-balance table, one row per unit the scene builds in the process's order:
    its `unit` name, `type`, what its balance holds (`conserved`, `CONSERVED`) and its largest
    relative `residual` (`mass_balances`)."""
    residuals = mass_balances(chain, inputs)  # keys sorted, as jit returns a dict
    return [{"unit": unit.name, "type": unit.type, "conserved": CONSERVED.get(UNIT_ROLES[unit.type], ""),
             "residual": float(residuals[unit.name])} for unit in chain.process.units if unit.name in residuals]
