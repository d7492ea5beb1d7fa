"""Temperature profiles over a unit's normalised time s in [0, 1]: a constant, a linear ramp, and a
neural profile (an MLP of s bounded to a range)."""

import equinox as eqx
import jax.numpy as jnp

from snapo_ode import MLPPolicy

from ..kinetics._types import Scalar


class AbstractTemperatureProfile(eqx.Module):
    """T(s) [K] at normalised time `s` in [0, 1]."""

    def __call__(self, s: Scalar) -> Scalar:
        raise NotImplementedError


class ConstantTemperature(AbstractTemperatureProfile):
    """T(s) = `value` [K]."""

    value: Scalar

    def __call__(self, s):
        return self.value


class LinearRamp(AbstractTemperatureProfile):
    """T(s) = `start` + (`end` - `start`) s [K]."""

    start: Scalar
    end: Scalar

    def __call__(self, s):
        return self.start + (self.end - self.start) * s


class NeuralTemperature(AbstractTemperatureProfile):
    """T(s) = `policy`(s) [K]: a learned profile, an `MLPPolicy` with one feature (s) and one
    bounded action (the temperature, kept inside e.g. the proven acceptable range)."""

    policy: MLPPolicy

    def __call__(self, s):
        return self.policy(jnp.reshape(s, (1,)))[0]
