"""A reaction mechanism as arrays: stoichiometric matrices, padded index arrays and rate parameters.

Every reaction type is evaluated for all its reactions at once (one gather, one vector formula);
no Python branch runs per reaction.
"""

from pathlib import Path

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
from jax.custom_derivatives import SymbolicZero

from snapo_ode import InputError, require_float64

from ._pressure_rates import Chebyshev, Plog
from ._rate_laws import BlowersMasel, Falloff, Orders, RateParameters, ThirdBodies
from ._reader import read_mechanism
from ._thermo import SpeciesThermo
from ._units import GAS_CONSTANT
from ._types import IndexMatrix, Indices, Matrix, Scalar, Vector


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
    - `pre_exponential`: A of each reaction, SI (kmol, m^3, s); may be negative on a duplicate;
      0 (unused) on PLOG and Chebyshev reactions.
    - `net_stoichiometry`: products minus reactants, shape `(n_reactions, n_species)`.
    - `changed_species`: the species each reaction changes (non-zero net stoichiometry), shape
      `(n_reactions, q)`, padded with `n_species`.
    - `forward`: `Orders` of the forward rates; `reverse`: `Orders` of the reversible reactions'
      reverse rates (their products' stoichiometry), which are `reversible_index`.
    - `blowers_masel`: the reactions whose activation energy depends on their enthalpy change.
    - `three_body`, `falloff`: the reactions whose rate depends on a collision partner's
      concentration; `plog`, `chebyshev`: those whose rate depends on the pressure, which is the
      ideal gas's R T sum(concentrations), as in Cantera.
    - `parameters`: the differentiable `RateParameters`.
    """

    species_names: tuple[str, ...] = eqx.field(static=True)
    reaction_equations: tuple[str, ...] = eqx.field(static=True)
    thermo_model: str = eqx.field(static=True)
    activity_basis: str = eqx.field(static=True)
    reference_pressure: float = eqx.field(static=True)
    thermo: SpeciesThermo
    molar_volumes: Vector
    pre_exponential: Vector
    net_stoichiometry: Matrix
    changed_species: IndexMatrix
    forward: Orders
    reverse: Orders
    reversible_index: Indices
    blowers_masel: BlowersMasel
    three_body: ThirdBodies
    falloff: Falloff
    plog: Plog
    chebyshev: Chebyshev
    parameters: RateParameters

    @classmethod
    def from_yaml(cls, path: str | Path, phase: str | None = None) -> "Mechanism":
        """Read phase `phase` (default: the first) of the Cantera YAML file at `path` (a bare
        file name such as `gri30.yaml` is found as `cantera.Solution` finds it).

        Supported: NASA7, NASA9, Shomate and constant-cp thermo; ideal-gas or ideal-condensed phases, with species
        and reactions from other files (`gri30.yaml/species: [...]`); elementary (reversible or
        not, explicit `orders`, negative A on duplicates), three-body with efficiencies, falloff
        and chemically-activated (Lindemann, Troe, Tsang, SRI), and in ideal-gas phases PLOG
        (`pressure-dependent-Arrhenius`), Chebyshev and Blowers-Masel. Transport data are not
        needed.

        **Raises:** `InputError` naming the reaction (index, line, equation) and its type for an
        unsupported reaction, and naming the field for unsupported thermo or units.
        """
        require_float64("kinetics mechanisms")
        try:
            return read_mechanism(cls, path, phase)
        except InputError:
            raise
        except (KeyError, TypeError, ValueError, AttributeError, IndexError) as error:
            # A structure the reader does not expect (a field of the wrong type, a missing key):
            # name the file rather than show a traceback from deep inside the reader.
            raise InputError(f"mechanism file {path}: malformed or unsupported content "
                             f"({type(error).__name__}: {error}).") from error

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

    def activity_concentrations(self, concentrations: Vector) -> Vector:
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

    def equilibrium_constants(self, temperature: Scalar) -> Vector:
        """K_c of the reversible reactions in concentration units, shape `(n_reversible,)`, at
        `temperature` [K], from the species' standard Gibbs energies as Cantera computes it."""
        stoichiometry = self.net_stoichiometry[self.reversible_index]
        delta_g_rt = stoichiometry @ self.thermo.g_rt(temperature)
        delta_n = jnp.sum(stoichiometry, axis=-1)
        log_standard = jnp.log(self.reference_pressure / (GAS_CONSTANT * temperature))
        return jnp.exp(-delta_g_rt + delta_n * log_standard)

    def _rate_constants(self, temperature, activities, p: RateParameters, *, with_slopes: bool = False):
        """k of every reaction, shape `(n_reactions,)` [SI]; with `with_slopes` also, for each
        non-empty group of reactions whose k depends on the activities (three-body, falloff,
        PLOG, Chebyshev), `(index, slope, efficiencies)`: d k / d (partner concentration
        `efficiencies @ activities`), shape `(g,)`, with `efficiencies` `(g, n_species)` (for the
        pressure-dependent groups, whose partner is the total concentration, `(1, n_species)` ones)."""
        log_t = jnp.log(temperature)
        activation = p.activation_temperature
        blowers_masel = self.blowers_masel
        if blowers_masel.index.size:
            enthalpy = self.net_stoichiometry[blowers_masel.index] @ self.thermo.h_rt(temperature) * temperature
            activation = activation.at[blowers_masel.index].set(blowers_masel.activation_temperature(
                activation[blowers_masel.index], enthalpy))
        k = self.pre_exponential * jnp.exp(p.temperature_exponent * log_t - activation / temperature)
        multiplier = jnp.exp(p.log_multiplier)
        slopes = []
        three_body = self.three_body
        if three_body.index.size:
            slopes.append((three_body.index, k[three_body.index], three_body.efficiencies))
            k = k.at[three_body.index].multiply(three_body.efficiencies @ activities, unique_indices=True)
        k_high = k[self.falloff.index]
        groups = [(self.falloff, self.falloff.efficiencies, lambda m: self.falloff.rate(temperature, log_t, k_high, m))]
        total = jnp.ones((1, activities.shape[0]), activities.dtype)
        for group in (self.plog, self.chebyshev):
            groups.append((group, total, lambda m, group=group: group.rate(
                temperature, log_t, jnp.log(m * GAS_CONSTANT * temperature))))
        for group, efficiencies, rate in groups:
            if not group.index.size:
                continue
            partner = efficiencies @ activities
            if with_slopes:
                k_group, by_partner = jax.jvp(rate, (partner,), (jnp.ones_like(partner),))
                slopes.append((group.index, by_partner, efficiencies))
            else:
                k_group = rate(partner)
            k = k.at[group.index].set(k_group)
        return k * multiplier, [(index, slope * multiplier[index], eff) for index, slope, eff in slopes]

    def _rates(self, temperature, concentrations, parameters: RateParameters):
        """Forward rates of progress, shape `(n_reactions,)`, and reverse rates of the reversible
        reactions, shape `(n_reversible,)` [kmol/m^3/s]."""
        activities = self.activity_concentrations(concentrations)
        k, _ = self._rate_constants(temperature, activities, parameters)
        padded = jnp.concatenate([activities, jnp.ones(1, activities.dtype)])
        forward = k * self.forward.product(padded)
        if not self.reversible_index.size:
            return forward, jnp.zeros(0, forward.dtype)
        k_reverse = k[self.reversible_index] / self.equilibrium_constants(temperature)
        return forward, k_reverse * self.reverse.product(padded)

    def rates_of_progress(self, temperature, concentrations, parameters: RateParameters | None = None):
        """Forward and reverse rates of progress [kmol/m^3/s], each shape `(n_reactions,)`, at
        `temperature` [K] (scalar) and molar `concentrations` [kmol/m^3] (shape `(n_species,)`)."""
        parameters = self.parameters if parameters is None else parameters
        forward, reverse = self._rates(temperature, concentrations, parameters)
        return forward, jnp.zeros_like(forward).at[self.reversible_index].set(reverse)

    def _net_production(self, temperature, concentrations, parameters: RateParameters):
        forward, reverse = self._rates(temperature, concentrations, parameters)
        # One product with the forward and reverse stoichiometry stacked, not two: each matrix
        # product is an operation of its own on the CPU (a vector-field evaluation is ~20 of them).
        stoichiometry = jnp.concatenate([self.net_stoichiometry, self.net_stoichiometry[self.reversible_index]])
        return jnp.concatenate([forward, -reverse]) @ stoichiometry

    def concentration_jacobian(self, temperature, concentrations, parameters: RateParameters | None = None):
        """d (net production rates) / d concentrations [1/s], shape `(n_species, n_species)`, in
        closed form: the mass-action products' derivatives and the three-body, falloff, PLOG and
        Chebyshev rate constants' dependence on their collision partners (the total concentration,
        through the pressure, for the last two). It is what a Jacobian-vector product
        in the concentrations costs: one matrix product, however many tangents (a stiff solver's
        Jacobian is 55 of them on gri30)."""
        p = self.parameters if parameters is None else parameters
        n = self.n_species
        activities = self.activity_concentrations(concentrations)
        k, slopes = self._rate_constants(temperature, activities, p, with_slopes=True)
        padded = jnp.concatenate([activities, jnp.ones(1, activities.dtype)])
        stoichiometry = self.net_stoichiometry
        padded_stoichiometry = jnp.concatenate([stoichiometry, jnp.zeros((stoichiometry.shape[0], 1))], axis=1)
        changes = jnp.take_along_axis(padded_stoichiometry, self.changed_species, axis=1)
        jacobian = self.forward.contract(self.changed_species, changes, k[:, None] * self.forward.partials(padded), n)
        # Net (forward minus reverse) mass-action product of each reaction, which a change of its
        # rate constant multiplies.
        net_product = self.forward.product(padded)
        if self.reversible_index.size:
            rev = self.reversible_index
            equilibrium = self.equilibrium_constants(temperature)
            jacobian = jacobian - self.reverse.contract(
                self.changed_species[rev], changes[rev],
                (k[rev] / equilibrium)[:, None] * self.reverse.partials(padded), n)
            net_product = net_product.at[rev].add(-self.reverse.product(padded) / equilibrium)
        for index, slope, efficiencies in slopes:
            jacobian = jacobian + stoichiometry[index].T @ ((slope * net_product[index])[:, None] * efficiencies)
        if self.activity_basis == "concentration":
            return jacobian
        return jacobian @ jax.jacfwd(self.activity_concentrations)(concentrations)

    def net_production_rates(self, temperature, concentrations, parameters: RateParameters | None = None):
        """Net molar production rate of each species [kmol/m^3/s], shape `(n_species,)`.

        **Arguments:** `temperature` [K] (scalar), `concentrations` [kmol/m^3] (shape
        `(n_species,)`), `parameters` (default: the mechanism's own `RateParameters`).
        Differentiable in all of them (and in the mechanism's arrays); with at least
        `CLOSED_FORM_MIN_SPECIES` species a derivative in the concentrations goes through
        `concentration_jacobian`.
        """
        parameters = self.parameters if parameters is None else parameters
        if self.n_species < CLOSED_FORM_MIN_SPECIES:
            return self._net_production(temperature, concentrations, parameters)
        return _net_production_rates(self, temperature, concentrations, parameters)


CLOSED_FORM_MIN_SPECIES = 20
"""From this many species on, concentration tangents of `net_production_rates` go through
`concentration_jacobian`, which is the faster there (gri30); below, forward mode through the rate
law is as fast or faster (h2o2, the 7-species pharma chain; the measurement: docs/dev/chemistry_notes.md,
Measurements behind the design)."""


@jax.custom_jvp
def _net_production_rates(mechanism: Mechanism, temperature, concentrations, parameters: RateParameters):
    return mechanism._net_production(temperature, concentrations, parameters)


def _instantiate(tangent, primal):
    if not isinstance(tangent, SymbolicZero):
        return tangent
    if jnp.issubdtype(jnp.result_type(primal), jnp.inexact):
        return jnp.zeros(jnp.shape(primal), jnp.result_type(primal))
    return np.zeros(jnp.shape(primal), jax.dtypes.float0)


def _net_production_rates_jvp(primals, tangents):
    """Concentration tangents through the closed-form Jacobian (one matrix product for any
    number of them); the others (temperature, rate parameters, the mechanism's arrays) through
    ordinary forward mode, skipped when they are zero."""
    mechanism, temperature, concentrations, parameters = primals
    mechanism_dot, temperature_dot, concentrations_dot, parameters_dot = tangents
    value = mechanism._net_production(temperature, concentrations, parameters)
    tangent = jnp.zeros_like(value)
    others = (mechanism_dot, temperature_dot, parameters_dot)
    is_zero = lambda x: isinstance(x, SymbolicZero)  # noqa: E731
    if not all(is_zero(leaf) for leaf in jax.tree.leaves(others, is_leaf=is_zero)):
        dots = jax.tree.map(_instantiate, others, (mechanism, temperature, parameters), is_leaf=is_zero)
        _, tangent = jax.jvp(lambda m, t, p: m._net_production(t, concentrations, p),
                             (mechanism, temperature, parameters), dots)
    if not is_zero(concentrations_dot):
        jacobian = mechanism.concentration_jacobian(temperature, concentrations, parameters)
        tangent = tangent + jacobian @ concentrations_dot
    return value, tangent


_net_production_rates.defjvp(_net_production_rates_jvp, symbolic_zeros=True)
