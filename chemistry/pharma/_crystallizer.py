"""The seeded cooling crystallizer: van't Hoff solubility, power-law secondary nucleation and
size-independent growth, the method of moments (mu_0 .. mu_4), and impurity incorporation by a
partition coefficient (an effect).

Per m^3 of liquor (its volume taken constant). Scaled state: [c_P [kmol/m^3], m_0 .. m_4] with
mu_j = N_REF L_REF^j m_j, then (with incorporation) the impurity and degradant taken up by the
crystals [kmol/m^3].
"""

from typing import NamedTuple

import equinox as eqx
import jax.numpy as jnp
from jaxtyping import Array, Float

from chemistry import GAS_CONSTANT

from ._profiles import AbstractTemperatureProfile
from ._solver import ChainSolver

N_REF = 1e10  # [1/m^3]
L_REF = 1e-4  # [m]


def solubility(temperature, physical):
    """C*(T) [kmol/m^3], van't Hoff."""
    inverse = 1 / temperature - 1 / physical.solubility_ref_temperature
    return physical.solubility_ref * jnp.exp(-physical.solubility_enthalpy / GAS_CONSTANT * inverse)


def _power_of_positive(x, power):
    """max(x, 0) ** power, with exact zero gradients (also in `power`) where x <= 0."""
    positive = x > 0
    return jnp.where(positive, jnp.where(positive, x, 1.0) ** power, 0.0)


class CrystallizerOutlet(NamedTuple):
    """`api` [kmol/m^3] dissolved at the end; `moments` mu_0 .. mu_4 [m^j/m^3], shape (5,);
    `impurity_solid`, `degradant_solid` [kmol/m^3] incorporated in the crystals; `temperature` [K]."""

    api: Float[Array, ""]
    moments: Float[Array, " 5"]
    impurity_solid: Float[Array, ""]
    degradant_solid: Float[Array, ""]
    temperature: Float[Array, ""]

    def crystal_mass(self, physical):
        """[kg/m^3] of liquor."""
        return physical.crystal_density * physical.shape_factor * self.moments[3]

    def mean_size(self):
        """Volume-weighted mean size D[4,3] = mu_4 / mu_3 [m]."""
        return self.moments[4] / self.moments[3]


class Crystallizer(eqx.Module):
    """The cooling crystallizer; `impurity_incorporation`: whether impurity and degradant enter
    the crystals (partition coefficients), else the crystals are pure API."""

    api_molar_mass: float = eqx.field(static=True)
    impurity_incorporation: bool = eqx.field(static=True)

    def rhs(self, s, state, args):
        profile, duration, physical, impurity0, degradant0 = args
        temperature = profile(s)
        api, scaled = state[0], state[1:6]
        supersaturation = api / solubility(temperature, physical) - 1
        arrhenius = jnp.exp(-physical.growth_activation / GAS_CONSTANT
                            * (1 / temperature - 1 / physical.solubility_ref_temperature))
        growth = physical.growth_rate * arrhenius * _power_of_positive(supersaturation, physical.growth_order)
        crystal_volume = physical.shape_factor * N_REF * L_REF**3 * scaled[3]  # [m^3/m^3]
        nucleation = physical.nucleation_rate * _power_of_positive(supersaturation, physical.nucleation_order) * crystal_volume
        d_moments = jnp.concatenate([
            jnp.reshape(nucleation / N_REF, (1,)),
            jnp.arange(1, 5) * (growth / L_REF) * scaled[:4],
        ])
        # [kmol/m^3/s] of API moving into the crystals (nuclei have negligible volume).
        crystallizing = (physical.crystal_density * physical.shape_factor * N_REF * L_REF**3 / self.api_molar_mass
                         * d_moments[3])
        rates = [jnp.reshape(-crystallizing, (1,)), d_moments]
        if self.impurity_incorporation:
            impurity_liquor = impurity0 - state[6]
            degradant_liquor = degradant0 - state[7]
            rates.append(crystallizing / api * jnp.stack([physical.partition_impurity * impurity_liquor,
                                                          physical.partition_degradant * degradant_liquor]))
        return duration * jnp.concatenate(rates)

    def __call__(self, api, impurity, degradant, profile: AbstractTemperatureProfile, duration, physical,
                 solver: ChainSolver) -> CrystallizerOutlet:
        """Crystallize from liquor with `api`, `impurity`, `degradant` [kmol/m^3] over `duration`
        [s] along the temperature `profile`, seeded with `physical.seed_loading` [kg/m^3] of
        crystals of `physical.seed_size` [m]."""
        seed_count = physical.seed_loading / (physical.crystal_density * physical.shape_factor
                                              * physical.seed_size**3)
        seed_moments = seed_count / N_REF * (physical.seed_size / L_REF) ** jnp.arange(5)
        state = jnp.concatenate([jnp.reshape(api, (1,)), seed_moments])
        if self.impurity_incorporation:
            state = jnp.concatenate([state, jnp.zeros(2)])
        end = solver.solve(self.rhs, state, (profile, duration, physical, impurity, degradant), stiff=False)
        moments = end[1:6] * N_REF * L_REF ** jnp.arange(5)
        solid = end[6:8] if self.impurity_incorporation else jnp.zeros(2)
        return CrystallizerOutlet(end[0], moments, solid[0], solid[1], profile(1.0))
