"""The rate laws of a mechanism's reaction types, each evaluated for all its reactions at once:
the differentiable rate parameters, Blowers-Masel activation energies, three-body efficiencies,
falloff and chemically-activated rates (Lindemann, Troe, Tsang, SRI) and the concentration products
of mass action with their orders."""

import functools
import operator

import equinox as eqx
import jax.numpy as jnp
import numpy as np

from ._types import IndexMatrix, Indices, Mask, Matrix, Vector

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

    log_multiplier: Vector
    temperature_exponent: Vector
    activation_temperature: Vector


class BlowersMasel(eqx.Module):
    """Blowers-Masel reactions, as Cantera's `BlowersMaselRate`: k = A T^b exp(-E_a / (R T)), with
    an activation energy that follows the reaction's enthalpy change dH (the net stoichiometry
    times the species' enthalpies) from the intrinsic E_a0 and the bond energy w:
    E_a = 0 where dH < -4 E_a0, dH where dH > 4 E_a0, and between them
    (w + dH/2) (V_P - 2w + dH)^2 / (V_P^2 - 4w^2 + dH^2) with V_P = 2w (w + E_a0) / (w - E_a0).
    A, b and E_a0 / R are the reactions' entries of the mechanism's `pre_exponential` and
    `RateParameters` (its `activation_temperature` is E_a0 / R for them).

    - `index`: the reactions, shape `(g,)`.
    - `bond_energy`: w / R [K], shape `(g,)`.
    """

    index: Indices
    bond_energy: Vector

    def activation_temperature(self, intrinsic: Vector, enthalpy: Vector) -> Vector:
        """E_a / R [K], shape `(g,)`, from E_a0 / R `intrinsic` [K] and dH / R `enthalpy` [K]."""
        w = self.bond_energy
        vp = 2.0 * w * (w + intrinsic) / (w - intrinsic)
        between = (w + enthalpy / 2.0) * (vp - 2.0 * w + enthalpy) ** 2 / (vp * vp - 4.0 * w * w + enthalpy * enthalpy)
        return jnp.where(enthalpy < -4.0 * intrinsic, 0.0, jnp.where(enthalpy > 4.0 * intrinsic, enthalpy, between))


class ThirdBodies(eqx.Module):
    """Three-body reactions `index` (shape `(t,)`) with collision efficiencies `(t, n_species)`."""

    index: Indices
    efficiencies: Matrix


class Falloff(eqx.Module):
    """Falloff reactions (Lindemann, Troe, Tsang and SRI): k = k_high Pr / (1 + Pr) F_Troe F_SRI,
    and chemically-activated ones: k = k_low / (1 + Pr) F_Troe F_SRI, with the reduced pressure
    Pr = [M] k_low / k_high, as Cantera's `FalloffRate`. A Troe or Tsang reaction has the SRI
    factor's neutral parameters, an SRI reaction the Troe factor's and a Lindemann reaction both
    (each factor is then exactly 1).

    - `index`: shape `(f,)`; `efficiencies`: `(f, n_species)`.
    - `activated`: True for a chemically-activated reaction, False for a falloff one.
    - `low_a` [kmol, m^3, s units of one order more than the high-pressure limit], `low_b` [-],
      `low_activation_temperature` [K]: the low-pressure Arrhenius limit.
    - `troe_a` [-], `troe_inv_t3` = 1/T3 [1/K], `troe_inv_t1` = 1/T1 [1/K], `troe_t2` [K],
      `troe_has_t2` (0 or 1), `tsang_offset` [-], `tsang_slope` [1/K]: the centring
      F_cent = (1 - A) exp(-T/T3) + A exp(-T/T1) + exp(-T2/T) + tsang_offset + tsang_slope T,
      where 1/T = 0 stands for an infinite or absent T. A Troe reaction has the Tsang terms 0; a
      Tsang one (F_cent = A + B T) has the Troe terms neutral (exactly 1), `tsang_offset` = A - 1
      and `tsang_slope` = B. Neutral: all 0.
    - `sri_a` [-], `sri_b` [K], `sri_c` [K], `sri_d` [-], `sri_e` [-]: F_SRI = d T^e
      [a exp(-b/T) + exp(-T/c)]^X with X = 1 / (1 + log10(Pr)^2) (c = 0: no exp(-T/c) term, as
      in Cantera; the 3-parameter form has d = 1, e = 0). Neutral: a = 1, b = c = 0, d = 1, e = 0.
    """

    index: Indices
    efficiencies: Matrix
    activated: Mask
    low_a: Vector
    low_b: Vector
    low_activation_temperature: Vector
    troe_a: Vector
    troe_inv_t3: Vector
    troe_inv_t1: Vector
    troe_t2: Vector
    troe_has_t2: Vector
    tsang_offset: Vector
    tsang_slope: Vector
    sri_a: Vector
    sri_b: Vector
    sri_c: Vector
    sri_d: Vector
    sri_e: Vector

    def rate(self, temperature, log_t, k_high, collision):
        """The falloff rate constants, shape `(f,)`, from the high-pressure limits `k_high` and
        each reaction's collision partner concentration `collision` (`efficiencies @ c`)."""
        k_low = self.low_a * jnp.exp(self.low_b * log_t - self.low_activation_temperature / temperature)
        reduced_pressure = collision * k_low / (k_high + _SMALL)
        f_cent = ((1 - self.troe_a) * jnp.exp(-temperature * self.troe_inv_t3)
                  + self.troe_a * jnp.exp(-temperature * self.troe_inv_t1)
                  + self.troe_has_t2 * jnp.exp(-self.troe_t2 / temperature)
                  + self.tsang_offset + self.tsang_slope * temperature)
        log_f_cent = jnp.log10(jnp.maximum(f_cent, _SMALL))
        log_pr = jnp.log10(jnp.maximum(reduced_pressure, _SMALL))
        c = -0.4 - 0.67 * log_f_cent
        n = 0.75 - 1.27 * log_f_cent
        f1 = (log_pr + c) / (n - 0.14 * (log_pr + c))
        broadening = 10.0 ** (log_f_cent / (1 + f1 * f1))
        limit = jnp.where(self.activated, k_low, k_high * reduced_pressure)
        return limit / (1 + reduced_pressure) * broadening * self._sri(temperature, log_t, log_pr)

    def _sri(self, temperature, log_t, log_pr):
        """F_SRI of each reaction, shape `(f,)`. c = 0 (no term) goes through a double where, so
        that neither the value nor a derivative divides by zero."""
        no_c = self.sri_c == 0.0
        c_term = jnp.where(no_c, 0.0, jnp.exp(-temperature / jnp.where(no_c, 1.0, self.sri_c)))
        base = self.sri_a * jnp.exp(-self.sri_b / temperature) + c_term
        return self.sri_d * jnp.exp(self.sri_e * log_t) * base ** (1.0 / (1.0 + log_pr * log_pr))


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
    orders (explicit fractional or negative `orders`) use the power where c > 0 and are 0
    where c <= 0, as Cantera computes them (a negative order's factor would be infinite at 0),
    with finite derivatives everywhere. `fractional` says (statically) whether any slot has such an order: when
    none has, the power is not computed at all (on gri30 a general power on every slot was a
    large share of a step: docs/chemistry.md, Speed against Cantera).

    Build with `Orders.of(index, order)`, which sets `fractional` from the orders."""

    index: IndexMatrix
    order: Matrix
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
        # As Cantera: a non-integer (fractional or negative) order's factor is 0 where the
        # concentration is not positive (c ** -0.5 would be infinite at 0). The power's base is 1
        # on the slots that do not use it, so its derivatives stay finite there too.
        power = ~is_integer & (c > 0.0)
        base = jnp.where(power, c, 1.0)
        return (jnp.where(is_integer, integer, jnp.where(power, base**order, 0.0)),
                jnp.where(is_integer, integer_slope, jnp.where(power, order * base ** (order - 1.0), 0.0)))

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
        slots) rather than a dense n_species x r x n_species product or a scatter of whole
        stoichiometry rows, both slower on gri30 (docs/dev/chemistry_notes.md, Measurements behind the
        design)."""
        jacobian = jnp.zeros((n_species + 1, n_species + 1), coefficients.dtype)
        jacobian = jacobian.at[changed_species[:, :, None], self.index[:, None, :]].add(
            changes[:, :, None] * coefficients[:, None, :])
        return jacobian[:-1, :-1]
