"""Species reference-state thermodynamics: NASA 7-coefficient polynomials, constant heat capacity
and NASA 9-coefficient polynomials (which also carry Shomate's), evaluated for all species at once."""

import equinox as eqx
import jax.numpy as jnp
from jaxtyping import Array, Float

from ._types import Indices, Mask, Matrix, Scalar, Vector

Coefficients = Float[Array, "m r 9"]
"""NASA9 coefficients: 9 per temperature range per species."""


class Nasa9(eqx.Module):
    """Reference-state cp, h and s of the `m` species with NASA9 polynomials (McBride, Zehe and
    Gordon, NASA TP-2002-211556), each with any number of temperature ranges.

    **Fields:**
    - `index`: the species' positions in the mechanism, shape `(m,)`.
    - `boundaries` [K]: the lower bound of each range but the first, shape `(m, r - 1)` for the
      most ranges `r`, padded with +inf.
    - `coefficients`: a0..a8 of each range, shape `(m, r, 9)`, zero-padded.
    """

    index: Indices
    boundaries: Matrix
    coefficients: Coefficients

    def _terms(self, temperature):
        # Cantera's range: the last whose lower bound is at or below T (the first below the lowest,
        # the last above the highest).
        region = jnp.sum(temperature >= self.boundaries, axis=1)
        a = jnp.take_along_axis(self.coefficients, region[:, None, None], axis=1)[:, 0]
        t = temperature
        # The terms of cp/R in Cantera's order (Nasa9Poly1), so that the sums round alike.
        return a, (a[:, 0] / (t * t), a[:, 1] / t, a[:, 2], a[:, 3] * t, a[:, 4] * t ** 2, a[:, 5] * t ** 3,
                   a[:, 6] * t ** 4)

    def cp_r(self, temperature: Scalar) -> Vector:
        """cp/R [-] at `temperature` [K], shape `(m,)`."""
        _, (c0, c1, c2, c3, c4, c5, c6) = self._terms(temperature)
        return c0 + c1 + c2 + c3 + c4 + c5 + c6

    def h_rt(self, temperature: Scalar) -> Vector:
        """h/(R T) [-] at `temperature` [K], shape `(m,)`."""
        a, (c0, c1, c2, c3, c4, c5, c6) = self._terms(temperature)
        return (-c0 + jnp.log(temperature) * c1 + c2 + 0.5 * c3 + c4 / 3.0 + 0.25 * c5 + 0.2 * c6
                + a[:, 7] / temperature)

    def s_r(self, temperature: Scalar) -> Vector:
        """s/R [-] at `temperature` [K] and the reference pressure, shape `(m,)`."""
        a, (c0, c1, c2, c3, c4, c5, c6) = self._terms(temperature)
        return -0.5 * c0 - c1 + jnp.log(temperature) * c2 + c3 + 0.5 * c4 + c5 / 3.0 + 0.25 * c6 + a[:, 8]


class SpeciesThermo(eqx.Module):
    """Reference-state cp, h and s of `n` species, each NASA7 (two ranges), constant-cp or NASA9.

    **Fields** (shape `(n,)` unless noted):
    - `is_nasa`: which species use NASA7 (the others constant-cp, or NASA9 where `nasa9` names
      them).
    - `nasa_low`, `nasa_high`: shape `(n, 7)`, coefficients below / above `t_mid` [K].
    - `t0` [K], `h0_r` = h0/R [K], `s0_r` = s0/R [-], `cp0_r` = cp0/R [-]: constant-cp data.
    - `nasa9`: the NASA9 species (`Nasa9`; Shomate ones too, rewritten in NASA9 form), or None
      where there are none: a mechanism without them traces no NASA9 code.
    - `max_temperature` [K] (static): the hottest end of any species' fitted ranges (NASA7,
      NASA9, Shomate; inf where none has a range): above it the polynomials extrapolate, and far
      above it they (and the rates built on them) overflow.
    """

    is_nasa: Mask
    t_mid: Vector
    nasa_low: Matrix
    nasa_high: Matrix
    t0: Vector
    h0_r: Vector
    s0_r: Vector
    cp0_r: Vector
    nasa9: Nasa9 | None = None
    max_temperature: float = eqx.field(static=True, default=float("inf"))

    def _nasa(self, temperature):
        # Cantera picks the low range at T <= T_mid.
        return jnp.where((temperature <= self.t_mid)[:, None], self.nasa_low, self.nasa_high)

    def _with_nasa9(self, values, nasa9_values):
        return values if self.nasa9 is None else values.at[self.nasa9.index].set(nasa9_values(), unique_indices=True)

    def cp_r(self, temperature: Scalar) -> Vector:
        """cp/R [-] at `temperature` [K]."""
        a = self._nasa(temperature)
        t = temperature
        nasa = a[:, 0] + t * (a[:, 1] + t * (a[:, 2] + t * (a[:, 3] + t * a[:, 4])))
        return self._with_nasa9(jnp.where(self.is_nasa, nasa, self.cp0_r), lambda: self.nasa9.cp_r(t))

    def h_rt(self, temperature: Scalar) -> Vector:
        """h/(R T) [-] at `temperature` [K]."""
        a = self._nasa(temperature)
        t = temperature
        nasa = (a[:, 0] + t * (a[:, 1] / 2 + t * (a[:, 2] / 3 + t * (a[:, 3] / 4 + t * a[:, 4] / 5)))
                + a[:, 5] / t)
        constant = (self.h0_r + self.cp0_r * (t - self.t0)) / t
        return self._with_nasa9(jnp.where(self.is_nasa, nasa, constant), lambda: self.nasa9.h_rt(t))

    def s_r(self, temperature: Scalar) -> Vector:
        """s/R [-] at `temperature` [K] and the reference pressure."""
        a = self._nasa(temperature)
        t = temperature
        nasa = (a[:, 0] * jnp.log(t) + t * (a[:, 1] + t * (a[:, 2] / 2 + t * (a[:, 3] / 3 + t * a[:, 4] / 4)))
                + a[:, 6])
        constant = self.s0_r + self.cp0_r * jnp.log(t / self.t0)
        return self._with_nasa9(jnp.where(self.is_nasa, nasa, constant), lambda: self.nasa9.s_r(t))

    def g_rt(self, temperature: Scalar) -> Vector:
        """g/(R T) = h/(R T) - s/R [-] at `temperature` [K] and the reference pressure."""
        return self.h_rt(temperature) - self.s_r(temperature)
