"""A reaction mechanism as arrays: stoichiometric matrices, padded index arrays and rate parameters.

Every reaction type is evaluated for all its reactions at once (one gather, one vector formula);
no Python branch runs per reaction.
"""

import functools
import operator
from pathlib import Path

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
from jax.custom_derivatives import SymbolicZero
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

    def rate(self, temperature, log_t, k_high, collision):
        """The falloff rate constants, shape `(f,)`, from the high-pressure limits `k_high` and
        each reaction's collision partner concentration `collision` (`efficiencies @ c`)."""
        k_low = self.low_a * jnp.exp(self.low_b * log_t - self.low_activation_temperature / temperature)
        reduced_pressure = collision * k_low / (k_high + _SMALL)
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


def _integer_slots(order):
    """Where `order` (a NumPy or JAX array) is 0, 1, 2 or 3: the slots computed as products."""
    return (order == order.round()) & (order >= 0.0) & (order <= 3.0)


class Orders(eqx.Module):
    """Concentration products prod_j c[index[i, j]] ** order[i, j] over padded slots; a padding
    slot points at an extra entry fixed at 1, so a species absent from a reaction never enters
    its product.

    Orders 0 to 3 are evaluated as products (c, c * c, ...), not as `c ** order`: the power's
    second derivative at c = 0 is 0 * inf = NaN, and the reverse pass of a Rosenbrock solve
    (which differentiates the Jacobian) meets it at every species that starts at zero. Other
    orders (explicit fractional `orders`) use the power, its derivatives singular at c = 0 as
    the rate law's are. `fractional` says (statically) whether any slot has such an order: when
    none has, the power is not computed at all (gri30: a general power on every slot was 40% of
    a Rosenbrock step, measured).

    Build with `Orders.of(index, order)`, which sets `fractional` from the orders."""

    index: Int[Array, "r w"]
    order: Float[Array, "r w"]
    fractional: bool = eqx.field(static=True)

    @classmethod
    def of(cls, index, order) -> "Orders":
        """`Orders` of the species `index` (shape `(r, w)`) with `order`, shape `(r, w)`."""
        order = np.asarray(order, float)
        return cls(jnp.asarray(index), jnp.asarray(order), not bool(np.all(_integer_slots(order))))

    def _factors(self, padded_concentrations):
        """Each slot's c ** order and its derivative, shape `(r, w)` each."""
        c = padded_concentrations[self.index]
        order = self.order
        squared = c * c
        integer = jnp.where(order == 0.0, 1.0, jnp.where(order == 1.0, c, jnp.where(
            order == 2.0, squared, squared * c)))
        integer_slope = jnp.where(order == 0.0, 0.0, jnp.where(order == 1.0, 1.0, jnp.where(
            order == 2.0, 2.0 * c, 3.0 * squared)))
        if not self.fractional:
            return integer, integer_slope
        is_integer = _integer_slots(order)
        # The power of a base set to 1 on the integer slots, so its derivatives there are finite.
        base = jnp.where(is_integer, 1.0, c)
        return (jnp.where(is_integer, integer, base**order),
                jnp.where(is_integer, integer_slope, order * base ** (order - 1.0)))

    def product(self, padded_concentrations):
        """prod_j c_j ** order_j of each reaction, shape `(r,)`."""
        factors, _ = self._factors(padded_concentrations)
        return functools.reduce(operator.mul, [factors[:, j] for j in range(factors.shape[1])])

    def partials(self, padded_concentrations):
        """d product / d c at each slot (the slot's species `index[i, j]`), shape `(r, w)`."""
        factors, slopes = self._factors(padded_concentrations)
        width = factors.shape[1]
        others = [[factors[:, i] for i in range(width) if i != j] for j in range(width)]
        return jnp.stack([functools.reduce(operator.mul, [slopes[:, j], *others[j]]) for j in range(width)], axis=1)

    def contract(self, changed_species, changes, coefficients, n_species: int):
        """sum_r,i,j changes[r, i] coefficients[r, j] e_{changed_species[r, i]} e_{index[r, j]}^T,
        shape `(n_species, n_species)`: the net stoichiometry times a matrix that is non-zero only
        at the slots, as one scatter of r x q x w entries (q species changed by a reaction, w
        slots) rather than a dense n_species x r x n_species product (gri30: 150 us on this
        CPU) or a scatter of whole stoichiometry rows (100 us)."""
        jacobian = jnp.zeros((n_species + 1, n_species + 1), coefficients.dtype)
        jacobian = jacobian.at[changed_species[:, :, None], self.index[:, None, :]].add(
            changes[:, :, None] * coefficients[:, None, :])
        return jacobian[:-1, :-1]


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
    - `changed_species`: the species each reaction changes (non-zero net stoichiometry), shape
      `(n_reactions, q)`, padded with `n_species`.
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
    changed_species: Int[Array, "r q"]
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

    def _rate_constants(self, temperature, activities, p: RateParameters, *, with_slopes: bool = False):
        """k of every reaction, shape `(n_reactions,)` [SI]; with `with_slopes` also d k / d
        (collision partner concentration) of the three-body and of the falloff reactions,
        shapes `(t,)` and `(f,)` (the partner concentration is `efficiencies @ activities`)."""
        log_t = jnp.log(temperature)
        k = self.pre_exponential * jnp.exp(p.temperature_exponent * log_t - p.activation_temperature / temperature)
        multiplier = jnp.exp(p.log_multiplier)
        slopes = [jnp.zeros(0, k.dtype), jnp.zeros(0, k.dtype)]
        three_body = self.three_body
        if three_body.index.size:
            slopes[0] = k[three_body.index] * multiplier[three_body.index]
            k = k.at[three_body.index].multiply(three_body.efficiencies @ activities, unique_indices=True)
        falloff = self.falloff
        if falloff.index.size:
            k_high = k[falloff.index]
            collision = falloff.efficiencies @ activities
            if with_slopes:
                k_falloff, by_collision = jax.jvp(lambda m: falloff.rate(temperature, log_t, k_high, m), (collision,),
                                                  (jnp.ones_like(collision),))
                slopes[1] = by_collision * multiplier[falloff.index]
            else:
                k_falloff = falloff.rate(temperature, log_t, k_high, collision)
            k = k.at[falloff.index].set(k_falloff)
        return k * multiplier, tuple(slopes)

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
        return forward @ self.net_stoichiometry - reverse @ self.net_stoichiometry[self.reversible_index]

    def concentration_jacobian(self, temperature, concentrations, parameters: RateParameters | None = None):
        """d (net production rates) / d concentrations [1/s], shape `(n_species, n_species)`, in
        closed form: the mass-action products' derivatives and the three-body and falloff rate
        constants' dependence on their collision partners. It is what a Jacobian-vector product
        in the concentrations costs: one matrix product, however many tangents (a stiff solver's
        Jacobian is 55 of them on gri30)."""
        p = self.parameters if parameters is None else parameters
        n = self.n_species
        activities = self.activity_concentrations(concentrations)
        k, (three_body_slope, falloff_slope) = self._rate_constants(temperature, activities, p, with_slopes=True)
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
        for group, slope in ((self.three_body, three_body_slope), (self.falloff, falloff_slope)):
            if group.index.size:
                weights = (slope * net_product[group.index])[:, None] * group.efficiencies
                jacobian = jacobian + stoichiometry[group.index].T @ weights
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
`concentration_jacobian`. Below, forward mode through the rate law is as fast or faster
(measured: a gri30 reactor Jacobian 0.29 ms against 0.76 ms; h2o2 the same; the 7-species
pharma chain's 20 sensitivities 21 ms against 13 ms at rtol 1e-6)."""


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
