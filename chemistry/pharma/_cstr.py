"""A continuous stirred-tank reactor at steady state (type `cstr`), isothermal at its jacket
temperature, with the liquid's volume from the ideal-condensed mixing rule (as the batch reactors
and Cantera have it: a reaction that joins two molecules shrinks the liquid). With y the outlet's
amounts per volume of the inlet (y . v = Q_out / Q_in) and tau the residence time (hold-up mass
over mass flow: V / Q at the inlet's density), each species' balance is

    c_in - y + tau (y . v) r(y / (y . v), T) = 0.

Newton (optimistix) from the inlet, to round-off; its derivative by the implicit function
theorem, so the adjoint costs one linear solve with the transposed Jacobian, not a pass through
the iterations."""

import equinox as eqx
import jax.numpy as jnp
import optimistix as optx

from chemistry import Mechanism, RateParameters
from snapo_ode import SolverSettings

from ._unit import AbstractUnit, Liquid

STEADY_STATE = optx.Newton(rtol=1e-13, atol=1e-15)
"""Newton to round-off: the steady state's mass and element balances then close to round-off
(each is a linear combination of the residual)."""


class SteadyStateCSTR(AbstractUnit):
    """A CSTR at steady state: `residence_time` [min] at `temperature` [K], on the reduced
    `mechanism` (the active reactions)."""

    mechanism: Mechanism
    max_steps: int = eqx.field(static=True, default=64)

    def __call__(self, inlet: Liquid, parameters: dict, rates: RateParameters, solver: SolverSettings) -> Liquid:
        del solver  # algebraic: a root, not a solve in time
        volumes = self.mechanism.molar_volumes
        volume = inlet.amounts @ volumes  # [m^3 per m^3 of the first feed]
        feed, temperature = inlet.amounts / volume, parameters["temperature"]
        tau = 60.0 * parameters["residence_time"]

        def residual(amounts, args):
            outflow = amounts @ volumes  # [m^3 out per m^3 in]
            return feed - amounts + tau * outflow * self.mechanism.net_production_rates(temperature, amounts / outflow,
                                                                                         rates)

        outlet = optx.root_find(residual, STEADY_STATE, feed, max_steps=self.max_steps, adjoint=optx.ImplicitAdjoint()).value
        return Liquid(outlet * volume, jnp.asarray(temperature, dtype=float))
