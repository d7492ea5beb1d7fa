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
    the rest of the cake's liquid with wash solvent. The liquor at the end of the crystallization
    is the fed liquor less what the crystals took (API, and with incorporation impurity and
    degradant). Masses [kg per m^3 of liquor]."""

    molar_masses: Vector
    roles: SpeciesRoles = eqx.field(static=True)

    def streams(self, inlet: Slurry, parameters: dict) -> FilterStreams:
        """The cake, the filtrate and the wash (`FilterStreams`)."""
        crystals, roles = inlet.crystals, self.roles
        p, i, d = roles.api, roles.impurity, roles.degradant
        liquid = parameters["cake_liquor"] * crystals.crystal_mass  # [kg] of liquid the cake keeps
        final_liquor = (inlet.liquor.at[p].set(crystals.api)
                        .at[i].add(-crystals.impurity_solid).at[d].add(-crystals.degradant_solid))
        liquor_masses = final_liquor * self.molar_masses
        retained = parameters["wash_residue"] * liquid * liquor_masses / jnp.sum(liquor_masses)  # of the liquor
        wash = liquid - jnp.sum(retained)
        impurity_solid = self.molar_masses[i] * crystals.impurity_solid
        degradant_solid = self.molar_masses[d] * crystals.degradant_solid
        solvents = sum(retained[k] for k in roles.solvents)
        cake = Solids(
            api=crystals.crystal_mass - impurity_solid - degradant_solid + retained[p],
            impurity=impurity_solid + retained[i],
            degradant=degradant_solid + retained[d],
            other=jnp.sum(retained) - retained[p] - retained[i] - retained[d] - solvents,
            solvent=solvents + wash,
        )
        return FilterStreams(cake, liquor_masses - retained, wash)

    def __call__(self, inlet: Slurry, parameters: dict, rates: RateParameters, solver: SolverSettings) -> Solids:
        del rates, solver  # algebraic
        return self.streams(inlet, parameters).cake
