"""A reaction mechanism as arrays: stoichiometric matrices, padded index arrays and rate parameters.

Every reaction type is evaluated for all its reactions at once (one gather, one vector formula);
no Python branch runs per reaction.
"""

from pathlib import Path

import equinox as eqx
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, Float, Int

from ._thermo import SpeciesThermo
from ._units import GAS_CONSTANT

# Cantera's guard against a zero high-pressure rate in the reduced pressure.
_SMALL = 1e-300


class RateParameters(eqx.Module):
    """The differentiable rate parameters, one entry per reaction (shape `(n_reactions,)`).

    k_f = A T^b exp(-T_a / T) exp(log_multiplier); for falloff reactions the multiplier scales
    the whole falloff rate and `temperature_exponent`/`activation_temperature` are the
    high-pressure limit's.

    - `log_multiplier`: ln of Cantera's rate multiplier [-] (0 = as in the file).
    - `temperature_exponent`: b [-].
    - `activation_temperature`: T_a = Ea / R [K].
    """

    log_multiplier: Float[Array, " r"]
    temperature_exponent: Float[Array, " r"]
    activation_temperature: Float[Array, " r"]


class ThirdBodies(eqx.Module):
    """Three-body reactions `index` (shape `(t,)`) with collision efficiencies `(t, n_species)`."""

    index: Int[Array, " t"]
    efficiencies: Float[Array, "t s"]


class Falloff(eqx.Module):
    """Falloff reactions (Lindemann and Troe; Lindemann is Troe with F_cent = 1).

    - `index`: shape `(f,)`; `efficiencies`: `(f, n_species)`.
    - `low_a` [kmol, m^3, s units of one order more than the high-pressure limit], `low_b` [-],
      `low_activation_temperature` [K]: the low-pressure Arrhenius limit.
    - `troe_a` [-], `troe_inv_t3` = 1/T3 [1/K], `troe_inv_t1` = 1/T1 [1/K], `troe_t2` [K],
      `troe_has_t2` (0 or 1): the Troe centring; 1/T = 0 stands for an infinite or absent T.
    """

    index: Int[Array, " f"]
    efficiencies: Float[Array, "f s"]
    low_a: Float[Array, " f"]
    low_b: Float[Array, " f"]
    low_activation_temperature: Float[Array, " f"]
    troe_a: Float[Array, " f"]
    troe_inv_t3: Float[Array, " f"]
    troe_inv_t1: Float[Array, " f"]
    troe_t2: Float[Array, " f"]
    troe_has_t2: Float[Array, " f"]

    def rate(self, temperature, log_t, k_high, concentrations):
        """The falloff rate constants, shape `(f,)`, from the high-pressure limits `k_high`."""
        k_low = self.low_a * jnp.exp(self.low_b * log_t - self.low_activation_temperature / temperature)
        reduced_pressure = (self.efficiencies @ concentrations) * k_low / (k_high + _SMALL)
        f_cent = ((1 - self.troe_a) * jnp.exp(-temperature * self.troe_inv_t3)
                  + self.troe_a * jnp.exp(-temperature * self.troe_inv_t1)
                  + self.troe_has_t2 * jnp.exp(-self.troe_t2 / temperature))
        log_f_cent = jnp.log10(jnp.maximum(f_cent, _SMALL))
        log_pr = jnp.log10(jnp.maximum(reduced_pressure, _SMALL))
        c = -0.4 - 0.67 * log_f_cent
        n = 0.75 - 1.27 * log_f_cent
        f1 = (log_pr + c) / (n - 0.14 * (log_pr + c))
        broadening = 10.0 ** (log_f_cent / (1 + f1 * f1))
        return k_high * reduced_pressure / (1 + reduced_pressure) * broadening


class Orders(eqx.Module):
    """Concentration products prod_j c[index[i, j]] ** order[i, j] over padded slots; a padding
    slot points at an extra entry fixed at 1, so a species absent from a reaction never enters
    its product (and a zero concentration gives exact gradients)."""

    index: Int[Array, "r w"]
    order: Float[Array, "r w"]

    def product(self, padded_concentrations):
        return jnp.prod(padded_concentrations[self.index] ** self.order, axis=-1)


class Mechanism(eqx.Module):
    """A kinetics mechanism read from a Cantera YAML file (see `Mechanism.from_yaml`).

    **Fields:**
    - `species_names`, `reaction_equations`: names, in the file's order.
    - `thermo`: `SpeciesThermo` of the species.
    - `thermo_model`: "ideal-gas" or "ideal-condensed"; `activity_basis`: how concentrations
      become the activity concentrations the rates use ("concentration" for a gas; for a
      condensed phase Cantera's "unity", "species-molar-volume" or "solvent-molar-volume").
    - `molar_volumes` [m^3/kmol], shape `(n_species,)` (zeros for a gas).
    - `reference_pressure` [Pa].
    - `pre_exponential`: A of each reaction, SI (kmol, m^3, s); may be negative on a duplicate.
    - `net_stoichiometry`: products minus reactants, shape `(n_reactions, n_species)`.
    - `forward`: `Orders` of the forward rates; `reverse`: `Orders` of the reversible reactions'
      reverse rates (their products' stoichiometry), which are `reversible_index`.
    - `three_body`, `falloff`: the pressure-dependent reactions.
    - `parameters`: the differentiable `RateParameters`.
    """

    species_names: tuple[str, ...] = eqx.field(static=True)
    reaction_equations: tuple[str, ...] = eqx.field(static=True)
    thermo_model: str = eqx.field(static=True)
    activity_basis: str = eqx.field(static=True)
    reference_pressure: float = eqx.field(static=True)
    thermo: SpeciesThermo
    molar_volumes: Float[Array, " s"]
    pre_exponential: Float[Array, " r"]
    net_stoichiometry: Float[Array, "r s"]
    forward: Orders
    reverse: Orders
    reversible_index: Int[Array, " v"]
    three_body: ThirdBodies
    falloff: Falloff
    parameters: RateParameters

    @classmethod
    def from_yaml(cls, path: str | Path, phase: str | None = None) -> "Mechanism":
        """Read phase `phase` (default: the first) of the Cantera YAML file at `path`.

        Supported: NASA7 and constant-cp thermo; ideal-gas or ideal-condensed phases; elementary
        (reversible or not, explicit `orders`, negative A on duplicates), three-body with
        efficiencies, falloff (Lindemann, Troe). Transport data are not needed.

        **Raises:** `InputError` naming the reaction (index, line, equation) and its type for an
        unsupported reaction, and naming the field for unsupported thermo or units.
        """
        from ._reader import read_mechanism

        return read_mechanism(cls, path, phase)

    @property
    def n_species(self) -> int:
        return len(self.species_names)

    @property
    def n_reactions(self) -> int:
        return len(self.reaction_equations)

    def species_index(self, name: str) -> int:
        """The index of species `name`."""
        from snapo_ode import InputError

        if name not in self.species_names:
            raise InputError(f"species {name!r} is not in the mechanism; species: "
                             f"{', '.join(self.species_names)}.")
        return self.species_names.index(name)

    def activity_concentrations(self, concentrations: Float[Array, " s"]) -> Float[Array, " s"]:
        """The concentrations the rate laws use [kmol/m^3, or mole fractions on the "unity"
        basis], from molar concentrations [kmol/m^3], shape `(n_species,)`."""
        if self.activity_basis == "concentration":
            return concentrations
        fractions = concentrations / jnp.sum(concentrations)
        if self.activity_basis == "unity":
            return fractions
        if self.activity_basis == "species-molar-volume":
            return fractions / self.molar_volumes
        return fractions / self.molar_volumes[-1]

    def equilibrium_constants(self, temperature: Float[Array, ""]) -> Float[Array, " v"]:
        """K_c of the reversible reactions in concentration units, shape `(n_reversible,)`, at
        `temperature` [K], from the species' standard Gibbs energies as Cantera computes it."""
        stoichiometry = self.net_stoichiometry[self.reversible_index]
        delta_g_rt = stoichiometry @ self.thermo.g_rt(temperature)
        delta_n = jnp.sum(stoichiometry, axis=-1)
        log_standard = jnp.log(self.reference_pressure / (GAS_CONSTANT * temperature))
        return jnp.exp(-delta_g_rt + delta_n * log_standard)

    def rates_of_progress(self, temperature, concentrations, parameters: RateParameters | None = None):
        """Forward and reverse rates of progress [kmol/m^3/s], each shape `(n_reactions,)`, at
        `temperature` [K] (scalar) and molar `concentrations` [kmol/m^3] (shape `(n_species,)`)."""
        p = self.parameters if parameters is None else parameters
        activities = self.activity_concentrations(concentrations)
        log_t = jnp.log(temperature)
        k = self.pre_exponential * jnp.exp(p.temperature_exponent * log_t
                                           - p.activation_temperature / temperature)
        if self.three_body.index.size:
            collision = self.three_body.efficiencies @ activities
            k = k.at[self.three_body.index].multiply(collision, unique_indices=True)
        if self.falloff.index.size:
            k_high = k[self.falloff.index]
            k = k.at[self.falloff.index].set(self.falloff.rate(temperature, log_t, k_high, activities))
        k = k * jnp.exp(p.log_multiplier)
        padded = jnp.concatenate([activities, jnp.ones(1, activities.dtype)])
        forward = k * self.forward.product(padded)
        reverse = jnp.zeros_like(forward)
        if self.reversible_index.size:
            k_reverse = k[self.reversible_index] / self.equilibrium_constants(temperature)
            reverse = reverse.at[self.reversible_index].set(k_reverse * self.reverse.product(padded))
        return forward, reverse

    def net_production_rates(self, temperature, concentrations, parameters: RateParameters | None = None):
        """Net molar production rate of each species [kmol/m^3/s], shape `(n_species,)`.

        **Arguments:** `temperature` [K] (scalar), `concentrations` [kmol/m^3] (shape
        `(n_species,)`), `parameters` (default: the mechanism's own `RateParameters`).
        Differentiable in all three.
        """
        forward, reverse = self.rates_of_progress(temperature, concentrations, parameters)
        return (forward - reverse) @ self.net_stoichiometry
