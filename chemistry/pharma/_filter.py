"""The filter: the crystals and the liquor the cake keeps, washed (algebraic, no solve)."""

from typing import NamedTuple

import equinox as eqx
import jax.numpy as jnp

from chemistry import RateParameters
from snapo_ode import SolverSettings

from ..kinetics._types import Scalar, Vector
from ._crystallizer import Slurry, SpeciesRoles
from ._unit import AbstractUnit, Solids


class FilterStreams(NamedTuple):
    """Everything that leaves the filter, per m^3 of liquor: the washed `cake` (`Solids` [kg]),
    the `filtrate` (mother liquor and the displaced liquor, [kg] of each species, shape
    (n_species,)) and the `wash` solvent it took [kg]."""

    cake: Solids
    filtrate: Vector
    wash: Scalar


class Filter(AbstractUnit):
    """The filter (type `filter`): the cake keeps `cake_liquor` kg of liquid per kg of crystals;
    the displacement wash leaves `wash_residue` of that liquor (its solvent and solutes) and fills
    the rest of the cake's liquid with wash solvent (the process's `solvent` species). The liquor at the end of the crystallization
    is the fed liquor less what the crystals took (API, and with incorporation impurity and
    degradant). Masses [kg per m^3 of liquor]."""

    molar_masses: Vector
    roles: SpeciesRoles = eqx.field(static=True)

    def streams(self, inlet: Slurry, parameters: dict) -> FilterStreams:
        """The cake, the filtrate and the wash (`FilterStreams`)."""
        crystals, roles = inlet.crystals, self.roles
        p, i, d = roles.api, roles.impurity, roles.degradant
        liquid = parameters["cake_liquor"] * crystals.crystal_mass  # [kg] of liquid the cake keeps
        liquor_masses = inlet.final_liquor(roles) * self.molar_masses
        retained = parameters["wash_residue"] * liquid * liquor_masses / jnp.sum(liquor_masses)  # of the liquor
        wash = liquid - jnp.sum(retained)
        held = inlet.crystal_masses(self.molar_masses, roles)
        solvents = sum(retained[k] for k in roles.solvents)
        cake = Solids(
            api=held[p] + retained[p],
            impurity=held[i] + retained[i],
            degradant=held[d] + retained[d],
            other=jnp.sum(retained) - retained[p] - retained[i] - retained[d] - solvents,
            solvent=solvents + wash,
            by_solvent=jnp.stack([retained[k] for k in roles.solvents]).at[0].add(wash),
        )
        return FilterStreams(cake, liquor_masses - retained, wash)

    def __call__(self, inlet: Slurry, parameters: dict, rates: RateParameters, solver: SolverSettings) -> Solids:
        del rates, solver  # algebraic
        return self.streams(inlet, parameters).cake
