"""Species reference-state thermodynamics: NASA 7-coefficient polynomials and constant heat capacity,
evaluated for all species at once."""

import equinox as eqx
import jax.numpy as jnp
from ._types import Mask, Matrix, Scalar, Vector


class SpeciesThermo(eqx.Module):
    """Reference-state cp, h and s of `n` species, each NASA7 (two ranges) or constant-cp.

    **Fields** (shape `(n,)` unless noted):
    - `is_nasa`: which species use NASA7 (the others constant-cp).
    - `nasa_low`, `nasa_high`: shape `(n, 7)`, coefficients below / above `t_mid` [K].
    - `t0` [K], `h0_r` = h0/R [K], `s0_r` = s0/R [-], `cp0_r` = cp0/R [-]: constant-cp data.
    """

    is_nasa: Mask
    t_mid: Vector
    nasa_low: Matrix
    nasa_high: Matrix
    t0: Vector
    h0_r: Vector
    s0_r: Vector
    cp0_r: Vector

    def _nasa(self, temperature):
        # Cantera picks the low range at T <= T_mid.
        return jnp.where((temperature <= self.t_mid)[:, None], self.nasa_low, self.nasa_high)

    def cp_r(self, temperature: Scalar) -> Vector:
        """cp/R [-] at `temperature` [K]."""
        a = self._nasa(temperature)
        t = temperature
        nasa = a[:, 0] + t * (a[:, 1] + t * (a[:, 2] + t * (a[:, 3] + t * a[:, 4])))
        return jnp.where(self.is_nasa, nasa, self.cp0_r)

    def h_rt(self, temperature: Scalar) -> Vector:
        """h/(R T) [-] at `temperature` [K]."""
        a = self._nasa(temperature)
        t = temperature
        nasa = (a[:, 0] + t * (a[:, 1] / 2 + t * (a[:, 2] / 3 + t * (a[:, 3] / 4 + t * a[:, 4] / 5)))
                + a[:, 5] / t)
        constant = (self.h0_r + self.cp0_r * (t - self.t0)) / t
        return jnp.where(self.is_nasa, nasa, constant)

    def s_r(self, temperature: Scalar) -> Vector:
        """s/R [-] at `temperature` [K] and the reference pressure."""
        a = self._nasa(temperature)
        t = temperature
        nasa = (a[:, 0] * jnp.log(t) + t * (a[:, 1] + t * (a[:, 2] / 2 + t * (a[:, 3] / 3 + t * a[:, 4] / 4)))
                + a[:, 6])
        constant = self.s0_r + self.cp0_r * jnp.log(t / self.t0)
        return jnp.where(self.is_nasa, nasa, constant)

    def g_rt(self, temperature: Scalar) -> Vector:
        """g/(R T) = h/(R T) - s/R [-] at `temperature` [K] and the reference pressure."""
        return self.h_rt(temperature) - self.s_r(temperature)
