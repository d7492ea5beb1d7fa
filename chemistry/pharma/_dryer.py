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

from chemistry import RateParameters

from ..kinetics._types import Scalar
from ._parameters import arrhenius
from ._unit import AbstractUnit, Solids


class DryerOutlet(NamedTuple):
    """`solvent`, `api` and `degradant_formed` [kg per kg of solids at the start]."""

    solvent: Scalar
    api: Scalar
    degradant_formed: Scalar


class Dryer(AbstractUnit):
    """The drying stage (type `dryer`) at `temperature` [K] for `time` [s]; `degradation`:
    whether the API degrades in the solid. The solvent and the antisolvent leave at the one
    `drying_rate`, so each keeps its share of the cake's."""

    degradation: bool = eqx.field(static=True)

    def rhs(self, s, state, args):
        api, p = args
        temperature = p["temperature"]
        drying = arrhenius(p["drying_rate"], p["drying_activation"], temperature, p["reference_temperature"])
        rates = [-drying * state[:1]]
        if self.degradation:
            degrading = arrhenius(p["degradation_rate"], p["degradation_activation"], temperature,
                                  p["reference_temperature"])
            rates.append(degrading * (api - state[1:2]))
        return p["time"] * jnp.concatenate(rates)

    def dry(self, solvent, api, parameters: dict, solver: SolverSettings) -> DryerOutlet:
        """Dry a cake with `solvent` and `api` [kg/kg solids] at the dryer's `parameters`
        (`temperature` [K], `time` [s], ...)."""
        start = jnp.stack([solvent, jnp.zeros_like(api)]) if self.degradation else jnp.reshape(solvent, (1,))
        end = solver.solve(self.rhs, 0.0, 1.0, start, (api, parameters), stiff=False).ys[-1]
        if self.degradation:
            return DryerOutlet(end[0], api - end[1], end[1])
        return DryerOutlet(end[0], api, jnp.zeros_like(api))

    def __call__(self, inlet: Solids, parameters: dict, rates: RateParameters, solver: SolverSettings) -> Solids:
        solids = inlet.solids
        dried = self.dry(inlet.solvent / solids, inlet.api / solids, parameters, solver)
        solvent = solids * dried.solvent
        # One drying rate for the solvent and the antisolvent: each keeps its share of what is left.
        by_solvent = None if inlet.by_solvent is None else inlet.by_solvent * (solvent / inlet.solvent)
        return inlet._replace(api=solids * dried.api, degradant=inlet.degradant + solids * dried.degradant_formed,
                              solvent=solvent, by_solvent=by_solvent)
