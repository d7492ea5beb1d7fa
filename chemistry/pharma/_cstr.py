"""A continuous stirred-tank reactor at steady state (type `cstr`), isothermal at its jacket
temperature, with the liquid's volume from the ideal-condensed mixing rule (as the batch reactors
and Cantera have it: a reaction that joins two molecules shrinks the liquid). With y the outlet's
amounts per volume of the inlet (y . v = Q_out / Q_in) and tau the residence time (hold-up mass
over mass flow: V / Q at the inlet's density), each species' balance is

    c_in - y + tau (y . v) r(y / (y . v), T) = 0.

Newton (optimistix) to round-off, started from the tank run for `START_RESIDENCE_TIMES` residence
times from the inlet (the dynamic CSTR, whose fixed point the root is: Newton from the inlet
itself did not converge on a stiff network, the built-in's A <=> X); its derivative by the
implicit function theorem, so the adjoint costs one linear solve with the transposed Jacobian,
not a pass through the iterations or the start-up."""

import equinox as eqx
import jax
import jax.numpy as jnp
import optimistix as optx

from chemistry import Mechanism, RateParameters
from snapo_ode import SolverSettings

from ._unit import AbstractUnit, Liquid

START_RESIDENCE_TIMES = 10.0
STEADY_STATE = optx.Newton(rtol=1e-10, atol=1e-12)
"""Newton until its step is below 1e-10 relative (1e-12 absolute), where the residual is at
round-off (Newton converges quadratically): the steady state's mass and element balances, linear
combinations of the residual, close to round-off. A tighter step cannot be met: on the built-in
network (condition number 7e5) the steps bounce at 1e-14."""


class SteadyStateCSTR(AbstractUnit):
    """A CSTR at steady state: `residence_time` [min] at `temperature` [K], on the reduced
    `mechanism` (the active reactions)."""

    mechanism: Mechanism
    max_steps: int = eqx.field(static=True, default=64)

    def __call__(self, inlet: Liquid, parameters: dict, rates: RateParameters, solver: SolverSettings) -> Liquid:
        volumes = self.mechanism.molar_volumes
        volume = inlet.amounts @ volumes  # [m^3 per m^3 of the first feed]
        feed, temperature = inlet.amounts / volume, parameters["temperature"]
        tau = 60.0 * parameters["residence_time"]

        def residual(amounts, args):
            outflow = amounts @ volumes  # [m^3 out per m^3 in]
            return feed - amounts + tau * outflow * self.mechanism.net_production_rates(temperature, amounts / outflow,
                                                                                         rates)

        start = solver.solve(lambda t, amounts, args: START_RESIDENCE_TIMES * residual(amounts, args), 0.0, 1.0, feed,
                             None).ys[-1]  # the tank started full of feed, d y / d(t / tau) = residual
        outlet = optx.root_find(residual, STEADY_STATE, jax.lax.stop_gradient(start), max_steps=self.max_steps,
                                adjoint=optx.ImplicitAdjoint()).value
        return Liquid(outlet * volume, jnp.asarray(temperature, dtype=float))
