"""The filter-dryer's drying stage: first-order solvent removal, Arrhenius in T, and thermal
degradation of the API in the solid (P -> D, same molar mass), at the dryer temperature.

State, per kg of cake solids at the start: [solvent [kg/kg], API degraded [kg/kg]] (the degraded
amount itself, not the API left, so that a small degradation is not the difference of two
numbers near 1).
"""

from typing import NamedTuple

import equinox as eqx
import jax.numpy as jnp
from jaxtyping import Array, Float

from chemistry import GAS_CONSTANT

from ._solver import ChainSolver


def arrhenius(rate, activation, temperature, reference_temperature):
    """rate exp(-E/R (1/T - 1/T_ref)) [units of rate]; `activation` E [J/kmol]."""
    return rate * jnp.exp(-activation / GAS_CONSTANT * (1 / temperature - 1 / reference_temperature))


class DryerOutlet(NamedTuple):
    """`solvent`, `api` and `degradant_formed` [kg per kg of solids at the start]."""

    solvent: Float[Array, ""]
    api: Float[Array, ""]
    degradant_formed: Float[Array, ""]


class Dryer(eqx.Module):
    """The drying stage; `degradation`: whether the API degrades in the solid."""

    degradation: bool = eqx.field(static=True)

    def rhs(self, s, state, args):
        temperature, api, physical = args
        drying = arrhenius(physical.drying_rate, physical.drying_activation, temperature,
                           physical.dryer_ref_temperature)
        rates = [-drying * state[:1]]
        if self.degradation:
            degrading = arrhenius(physical.solid_degradation_rate, physical.solid_degradation_activation,
                                  temperature, physical.dryer_ref_temperature)
            rates.append(degrading * (api - state[1:2]))
        return physical.drying_time * jnp.concatenate(rates)

    def __call__(self, solvent, api, temperature, physical, solver: ChainSolver) -> DryerOutlet:
        """Dry a cake with `solvent` and `api` [kg/kg solids] at `temperature` [K] for
        `physical.drying_time` [s]."""
        if self.degradation:
            end = solver.solve(self.rhs, jnp.stack([solvent, jnp.zeros_like(api)]), (temperature, api, physical),
                               stiff=False)
            return DryerOutlet(end[0], api - end[1], end[1])
        end = solver.solve(self.rhs, jnp.reshape(solvent, (1,)), (temperature, api, physical), stiff=False)
        return DryerOutlet(end[0], api, jnp.zeros_like(api))
