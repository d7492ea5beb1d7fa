"""The filter: the crystals and the liquor the cake keeps, washed (algebraic, no solve)."""

import equinox as eqx
import jax.numpy as jnp

from snapo_ode import SolverSettings

from chemistry import RateParameters

from ..kinetics._types import Vector
from ._crystallizer import Slurry, SpeciesRoles
from ._unit import AbstractUnit, Solids


class Filter(AbstractUnit):
    """The filter (type `filter`): the cake keeps `cake_liquor` kg of liquid per kg of crystals; the displacement wash leaves
    `wash_residue` of the liquor's solutes and replaces the rest with solvent. The liquor at the
    end of the crystallization is the fed liquor less what the crystals took (API, and with
    incorporation impurity and degradant). Masses [kg per m^3 of liquor]."""

    molar_masses: Vector
    roles: SpeciesRoles = eqx.field(static=True)

    def __call__(self, inlet: Slurry, parameters: dict, rates: RateParameters, solver: SolverSettings) -> Solids:
        del rates, solver  # algebraic
        crystals, cake_liquor = inlet.crystals, parameters["cake_liquor"]
        p, i, d, s = self.roles.api, self.roles.impurity, self.roles.degradant, self.roles.solvent
        crystal_mass = crystals.crystal_mass
        final_liquor = (inlet.liquor.at[p].set(crystals.api)
                        .at[i].add(-crystals.impurity_solid).at[d].add(-crystals.degradant_solid))
        liquor_masses = final_liquor * self.molar_masses
        retained = parameters["wash_residue"] * cake_liquor * crystal_mass * liquor_masses / jnp.sum(liquor_masses)
        impurity_solid = self.molar_masses[i] * crystals.impurity_solid
        degradant_solid = self.molar_masses[d] * crystals.degradant_solid
        return Solids(
            api=crystal_mass - impurity_solid - degradant_solid + retained[p],
            impurity=impurity_solid + retained[i],
            degradant=degradant_solid + retained[d],
            other=jnp.sum(retained) - retained[p] - retained[i] - retained[d] - retained[s],
            solvent=cake_liquor * crystal_mass,
        )
