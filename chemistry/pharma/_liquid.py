"""R1 (jacketed plug-flow synthesis reactor) and R2 (hold): a liquid batch on the mechanism.

In the frame moving with the fluid, a plug-flow reactor is a batch whose duration is the
residence time. The state is y_k = n_k / V0 [kmol per m^3 of initial volume] (and T / 300 K with
the energy balance); the volume follows the ideal-condensed mixing rule V / V0 = sum_k y_k v_k,
exactly as Cantera's `ConstPressureReactor` treats an `ideal-condensed` phase.
"""

from typing import NamedTuple

import equinox as eqx
import jax.numpy as jnp
from jaxtyping import Array, Float

from chemistry import GAS_CONSTANT, Mechanism, RateParameters

from ._profiles import AbstractTemperatureProfile
from ._solver import ChainSolver

TEMPERATURE_SCALE = 300.0  # [K]: the energy balance integrates T / 300 K


class LiquidOutlet(NamedTuple):
    """`amounts`: y_k [kmol per m^3 of the unit's initial volume], shape (n_species,);
    `temperature` [K] at the outlet."""

    amounts: Float[Array, " s"]
    temperature: Float[Array, ""]

    def concentrations(self, molar_volumes):
        """Molar concentrations [kmol/m^3]."""
        return self.amounts / (self.amounts @ molar_volumes)


class LiquidBatch(eqx.Module):
    """A liquid batch integrated over `duration` [s].

    - `mechanism`: the `Mechanism` (possibly reduced to the active reactions).
    - `energy_balance`: integrate T with the jacket (U a (T_jacket - T), per initial volume);
      otherwise the batch is isothermal at the jacket temperature.
    """

    mechanism: Mechanism
    energy_balance: bool = eqx.field(static=True)

    def production(self, temperature, amounts, rates: RateParameters):
        """dy/dt [kmol/m^3/s] = (V / V0) * net production rates at the actual concentrations."""
        volume_ratio = amounts @ self.mechanism.molar_volumes
        return volume_ratio * self.mechanism.net_production_rates(temperature, amounts / volume_ratio, rates)

    def rhs(self, s, state, args):
        rates, jacket, duration, jacket_ua = args
        if not self.energy_balance:
            return duration * self.production(jacket(s), state, rates)
        amounts, temperature = state[:-1], TEMPERATURE_SCALE * state[-1]
        dy = self.production(temperature, amounts, rates)
        thermo = self.mechanism.thermo
        enthalpy = GAS_CONSTANT * temperature * thermo.h_rt(temperature)  # [J/kmol]
        heat_capacity = amounts @ (GAS_CONSTANT * thermo.cp_r(temperature))  # [J/K per m^3 of V0]
        heating = jacket_ua * (jacket(s) - temperature) - dy @ enthalpy  # [W per m^3 of V0]
        return duration * jnp.append(dy, heating / heat_capacity / TEMPERATURE_SCALE)

    def __call__(self, amounts, temperature, jacket: AbstractTemperatureProfile, duration, rates: RateParameters,
                 jacket_ua, solver: ChainSolver, *, steps: bool = False) -> LiquidOutlet:
        """Integrate from `amounts` [kmol/m^3] at `temperature` [K] for `duration` [s] with the
        jacket at `jacket(s)` [K]; `jacket_ua` [W/m^3/K]. With `steps`: the `diffrax.Solution`
        at every step instead (state as in `rhs`)."""
        args = (rates, jacket, duration, jacket_ua)
        if steps:
            start = jnp.append(amounts, temperature / TEMPERATURE_SCALE) if self.energy_balance else amounts
            return solver.solve(self.rhs, start, args, steps=True)
        if self.energy_balance:
            end = solver.solve(self.rhs, jnp.append(amounts, temperature / TEMPERATURE_SCALE), args)
            return LiquidOutlet(end[:-1], TEMPERATURE_SCALE * end[-1])
        return LiquidOutlet(solver.solve(self.rhs, amounts, args), jacket(1.0))
