"""The filter-dryer's drying stage: first-order solvent removal, Arrhenius in T, and thermal
degradation of the API in the solid (P -> D, same molar mass), at the dryer temperature.

State, per kg of cake solids at the start: [solvent [kg/kg], API degraded [kg/kg]] (the degraded
amount itself, not the API left, so that a small degradation is not the difference of two
numbers near 1).
"""

from typing import NamedTuple

import equinox as eqx
import jax.numpy as jnp

from snapo_ode import SolverSettings

from ..kinetics._types import Scalar
from ._parameters import ChainInputs, arrhenius
from ._unit import AbstractUnit, Solids


class DryerOutlet(NamedTuple):
    """`solvent`, `api` and `degradant_formed` [kg per kg of solids at the start]."""

    solvent: Scalar
    api: Scalar
    degradant_formed: Scalar


class Dryer(AbstractUnit):
    """The drying stage at `dryer_temperature` [K] for `drying_time` [s]; `degradation`: whether
    the API degrades in the solid."""

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

    def dry(self, solvent, api, temperature, physical, solver: SolverSettings) -> DryerOutlet:
        """Dry a cake with `solvent` and `api` [kg/kg solids] at `temperature` [K] for
        `physical.drying_time` [s]."""
        start = jnp.stack([solvent, jnp.zeros_like(api)]) if self.degradation else jnp.reshape(solvent, (1,))
        end = solver.solve(self.rhs, 0.0, 1.0, start, (temperature, api, physical), stiff=False).ys[-1]
        if self.degradation:
            return DryerOutlet(end[0], api - end[1], end[1])
        return DryerOutlet(end[0], api, jnp.zeros_like(api))

    def __call__(self, inlet: Solids, inputs: ChainInputs, solver: SolverSettings) -> Solids:
        solids = inlet.solids
        dried = self.dry(inlet.solvent / solids, inlet.api / solids, inputs.cpps.dryer_temperature, inputs.physical,
                         solver)
        return inlet._replace(api=solids * dried.api, degradant=inlet.degradant + solids * dried.degradant_formed,
                              solvent=solids * dried.solvent)
