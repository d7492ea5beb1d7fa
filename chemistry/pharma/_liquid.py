"""R1 (jacketed plug-flow synthesis reactor) and R2 (hold): a liquid batch on the mechanism.

In the frame moving with the fluid, a plug-flow reactor is a batch whose duration is the
residence time. The state is y_k = n_k / V0 [kmol per m^3 of initial volume] (and T / 300 K with
the energy balance); the volume follows the ideal-condensed mixing rule V / V0 = sum_k y_k v_k,
exactly as Cantera's `ConstPressureReactor` treats an `ideal-condensed` phase. Each solve runs
over a normalised time s in [0, 1] with the duration a factor of the right-hand side, so a CPP
that sets a duration is an ordinary differentiable input.
"""

import diffrax
import equinox as eqx
import jax.numpy as jnp

from chemistry import GAS_CONSTANT, Mechanism, RateParameters
from snapo_ode import SolverSettings

from ._profiles import AbstractTemperatureProfile, ConstantTemperature
from ._unit import AbstractUnit, Liquid

TEMPERATURE_SCALE = 300.0  # [K]: the energy balance integrates T / 300 K


class LiquidBatch(eqx.Module):
    """The physics of a liquid batch (shared by R1 and R2).

    - `mechanism`: the `Mechanism` (reduced to the active reactions).
    - `energy_balance`: integrate T with the jacket; otherwise the batch is isothermal at the
      jacket temperature.

    The jacket's U a [W/m^3/K] is per m^3 of the reactor, taken at its inlet: a fluid element of
    inlet volume V_in exchanges U a V_in (T_jacket - T), as Cantera's reactor of volume V_in with
    a wall of area a V_in does. The state is per m^3 of the first feed (V0), which a unit after
    one that changes the volume (a CSTR that shrinks the liquid) no longer enters with, so the
    heat term is scaled by V_in / V0 (`arguments`).
    """

    mechanism: Mechanism
    energy_balance: bool = eqx.field(static=True)

    def production(self, temperature, amounts, rates: RateParameters):
        """dy/dt [kmol/m^3/s] = (V / V0) * net production rates at the actual concentrations."""
        volume_ratio = amounts @ self.mechanism.molar_volumes
        return volume_ratio * self.mechanism.net_production_rates(temperature, amounts / volume_ratio, rates)

    def rhs(self, s, state, args):
        """d state / d s over the normalised time s in [0, 1]."""
        rates, jacket, duration, heat_transfer = args
        if not self.energy_balance:
            return duration * self.production(jacket(s), state, rates)
        amounts, temperature = state[:-1], TEMPERATURE_SCALE * state[-1]
        dy = self.production(temperature, amounts, rates)
        thermo = self.mechanism.thermo
        enthalpy = GAS_CONSTANT * temperature * thermo.h_rt(temperature)  # [J/kmol]
        heat_capacity = amounts @ (GAS_CONSTANT * thermo.cp_r(temperature))  # [J/K per m^3 of V0]
        heating = heat_transfer * (jacket(s) - temperature) - dy @ enthalpy  # [W per m^3 of V0]
        return duration * jnp.append(dy, heating / heat_capacity / TEMPERATURE_SCALE)

    def start(self, inlet: Liquid):
        """The scaled state of `inlet`."""
        if self.energy_balance:
            return jnp.append(inlet.amounts, inlet.temperature / TEMPERATURE_SCALE)
        return inlet.amounts

    def arguments(self, inlet: Liquid, jacket: AbstractTemperatureProfile, duration, rates: RateParameters,
                  jacket_ua):
        """The `rhs`'s arguments for a batch from `inlet` for `duration` [s]: the rates, the
        `jacket`, the duration and the heat transfer U a V_in / V0 [W/K per m^3 of V0] of
        `jacket_ua` [W/m^3/K, per m^3 of the reactor] (see the class docstring)."""
        inlet_volume = inlet.amounts @ self.mechanism.molar_volumes  # V_in / V0
        return rates, jacket, duration, jacket_ua * inlet_volume

    def run(self, inlet: Liquid, jacket: AbstractTemperatureProfile, duration, rates: RateParameters, jacket_ua,
            solver: SolverSettings, *, saveat: diffrax.SaveAt | None = None):
        """Integrate from `inlet` for `duration` [s] with the jacket at `jacket(s)` [K]; `jacket_ua`
        [W/m^3/K], per m^3 of the reactor. Returns the outlet `Liquid`, or with `saveat` the
        `diffrax.Solution` (state as in `rhs`)."""
        solution = solver.solve(self.rhs, 0.0, 1.0, self.start(inlet),
                                self.arguments(inlet, jacket, duration, rates, jacket_ua), saveat=saveat)
        if saveat is not None:
            return solution
        end = solution.ys[-1]
        if self.energy_balance:
            return Liquid(end[:-1], TEMPERATURE_SCALE * end[-1])
        return Liquid(end, jacket(1.0))


class SynthesisReactor(AbstractUnit):
    """A jacketed plug-flow reactor (type `plug_flow_reactor`; the built-in R1): `residence_time`
    [min] with the jacket at `temperature` [K] (or along a learned `jacket` profile), `jacket_ua`
    [W/m^3/K]."""

    batch: LiquidBatch
    jacket: AbstractTemperatureProfile | None = None

    def __call__(self, inlet: Liquid, parameters: dict, rates: RateParameters, solver: SolverSettings, *,
                 saveat: diffrax.SaveAt | None = None) -> Liquid:
        jacket = ConstantTemperature(parameters["temperature"]) if self.jacket is None else self.jacket
        return self.batch.run(inlet, jacket, 60.0 * parameters["residence_time"], rates, parameters["jacket_ua"],
                              solver, saveat=saveat)


class HoldReactor(AbstractUnit):
    """An isothermal batch reactor (type `batch_reactor`; the built-in R2, a hold) at
    `temperature` [K] (or along a learned `jacket` profile) for `time` [s]."""

    batch: LiquidBatch
    jacket: AbstractTemperatureProfile | None = None

    def __call__(self, inlet: Liquid, parameters: dict, rates: RateParameters, solver: SolverSettings) -> Liquid:
        jacket = ConstantTemperature(parameters["temperature"]) if self.jacket is None else self.jacket
        return self.batch.run(inlet, jacket, parameters["time"], rates, 0.0, solver)
