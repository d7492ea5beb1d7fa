"""The rate laws whose rate constant is a function of the pressure itself (not of a collision
partner's concentration): PLOG tables and Chebyshev fits, each evaluated for all its reactions
at once from padded arrays. The pressure is the ideal gas's, R T times the total concentration."""

import math

import equinox as eqx
import jax.numpy as jnp

from ._types import Batch, Indices, Matrix, Vector

# Cantera adds this to a sum of Arrhenius terms before its logarithm (PlogRate).
_SMALL = 1e-300


class Plog(eqx.Module):
    """PLOG (`pressure-dependent-Arrhenius`) reactions: ln k is linear in ln P between the
    tabulated pressures and constant beyond the first and the last, as Cantera's `PlogRate`.

    - `index`: the reactions, shape `(g,)`.
    - `log_pressure` [ln Pa]: the tabulated pressures, ascending, shape `(g, L)`; a reaction with
      fewer than L pressures is padded past its last one (ln P + 1, + 2, ...).
    - `a` [SI: kmol, m^3, s], `b` [-], `activation_temperature` [K]: the Arrhenius terms at each
      pressure, shape `(g, L, M)`; the M terms at one pressure are summed (Cantera's several
      expressions at one pressure), a padding term has `a` = 0, a padding pressure repeats the last.
    - `segment_weight`: 1 for an interval between two tabulated pressures, 0 for a padding one,
      shape `(g, L - 1)`.
    """

    index: Indices
    log_pressure: Matrix
    a: Batch
    b: Batch
    activation_temperature: Batch
    segment_weight: Matrix

    def rate(self, temperature, log_t, log_pressure) -> Vector:
        """k of each reaction, shape `(g,)` [SI], at `temperature` [K] (`log_t` = ln T) and
        `log_pressure` = ln P [ln Pa] (scalars).

        ln k = ln k_0 + sum_i (ln k_(i+1) - ln k_i) clip((ln P - ln P_i) / (ln P_(i+1) - ln P_i), 0, 1):
        the clip is the clamping outside the table, and it has finite derivatives everywhere,
        at a tabulated pressure too (there they average the two intervals' slopes)."""
        terms = self.a * jnp.exp(self.b * log_t - self.activation_temperature / temperature)
        log_k = jnp.log(jnp.sum(terms, axis=-1) + _SMALL)
        lower, upper = self.log_pressure[:, :-1], self.log_pressure[:, 1:]
        fraction = jnp.clip((log_pressure - lower) / (upper - lower), 0.0, 1.0)
        steps = (log_k[:, 1:] - log_k[:, :-1]) * fraction * self.segment_weight
        return jnp.exp(log_k[:, 0] + jnp.sum(steps, axis=-1))


def _chebyshev_polynomials(x: Vector, degree: int) -> Matrix:
    """T_0(x), ..., T_(degree - 1)(x) of each entry of `x` (shape `(g,)`), shape `(g, degree)`."""
    polynomials = [jnp.ones_like(x), x][:degree]
    while len(polynomials) < degree:
        polynomials.append(2.0 * x * polynomials[-1] - polynomials[-2])
    return jnp.stack(polynomials, axis=-1)


class Chebyshev(eqx.Module):
    """Chebyshev reactions: log10 k = sum_(t,p) a_tp T_t(T~) T_p(P~), with the reduced inverse
    temperature T~ = (2/T - 1/T_min - 1/T_max) / (1/T_max - 1/T_min) and the reduced log pressure
    P~ = (2 log10 P - log10 P_min - log10 P_max) / (log10 P_max - log10 P_min), as Cantera's
    `ChebyshevRate` (no clamping: outside the ranges the polynomials are extrapolated).

    - `index`: the reactions, shape `(g,)`.
    - `coefficients`: a_tp for k in SI (Cantera's shift of a_00 by the log10 of the unit
      conversion included), shape `(g, n_T, n_P)`, zero-padded to the largest fit.
    - `inv_t_min`, `inv_t_max` [1/K]; `log10_p_min`, `log10_p_max` [log10 Pa]: the ranges, `(g,)`.
    """

    index: Indices
    coefficients: Batch
    inv_t_min: Vector
    inv_t_max: Vector
    log10_p_min: Vector
    log10_p_max: Vector

    def rate(self, temperature, log_t, log_pressure) -> Vector:
        """k of each reaction, shape `(g,)` [SI], at `temperature` [K] and `log_pressure` = ln P
        [ln Pa] (scalars; `log_t` is unused, there for the common signature with `Plog.rate`)."""
        del log_t
        reduced_t = (2.0 / temperature - self.inv_t_min - self.inv_t_max) / (self.inv_t_max - self.inv_t_min)
        log10_p = log_pressure / math.log(10.0)
        reduced_p = (2.0 * log10_p - self.log10_p_min - self.log10_p_max) / (self.log10_p_max - self.log10_p_min)
        n_t, n_p = self.coefficients.shape[1:]
        log10_k = jnp.einsum("gt,gtp,gp->g", _chebyshev_polynomials(reduced_t, n_t), self.coefficients,
                             _chebyshev_polynomials(reduced_p, n_p))
        return 10.0**log10_k
