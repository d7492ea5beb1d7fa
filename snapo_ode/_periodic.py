"""Periodic state components: angles and phases, declared once, so that neither a policy nor a
gradient ever sees the jump where a wrapped coordinate goes from +P/2 to -P/2.

A model keeps its periodic coordinates unwrapped (an angle may count whole turns); `Periodic`
says which components are periodic and with which period, and gives the three periodic-safe
views of a state:

- `features`: each periodic component x as (sin(2 pi x / P), cos(2 pi x / P)), the others as
  they are: continuous across the wrap, and equal for x and x + P.
- `squared_error`: the squared distance to a target along the circle. Hard (`sharpness=None`) it
  is `wrap(x - target)^2`, whose derivative jumps from +P to -P at the wrap point; smooth it is
  a soft minimum over the two nearest images (`wrapped_square`), or `cosine_square`.
- `wrap` and `unwrap`: coordinates into [-P/2, P/2), and back to continuous trajectories (for
  phase portraits).

Gaps of the smooth forms (smooth minus hard), at sharpness k [1/unit of x^2]:

| function | gap |
| --- | --- |
| `wrapped_square` | in [-log(2)/k, 0], largest in magnitude at the wrap point x = +-P/2 |
| `cosine_square` | (P^2 / 2 pi^2)(1 - cos(2 pi x / P)) - x^2 in [-(1 - 2/pi^2) P^2/4, 0]: exact to O(x^4) |
"""

import math
from collections.abc import Sequence

import equinox as eqx
import jax.numpy as jnp

from . import smooth
from ._platform.validation import InputError

__all__ = ["Periodic", "wrap", "wrapped_square", "cosine_square"]


def wrap(x, period: float):
    """x mapped into [-period/2, period/2): `((x + P/2) mod P) - P/2` (Gymnasium's
    `angle_normalize` for P = 2 pi)."""
    half = period / 2
    return (x + half) % period - half


def wrapped_square(x, period: float, sharpness: float | None = None):
    """The squared distance from x to the nearest multiple of `period`: `wrap(x)^2`, or with a
    `sharpness` the soft minimum (`smooth.minimum`) of the squares of the two nearest images,
    wrap(x) and wrap(x) -+ P.

    The two images trade places where `wrap` jumps, and the soft minimum is symmetric, so the
    smooth form and its derivative are continuous there (the derivative passes through 0 at
    x = +-P/2, where the hard one jumps from +P to -P). Gap in [-log(2)/k, 0].
    """
    near = wrap(x, period)
    if sharpness is None:
        return near**2
    far = jnp.where(near >= 0, near - period, near + period)
    return smooth.minimum(near**2, far**2, sharpness)


def cosine_square(x, period: float):
    """(P^2 / 2 pi^2)(1 - cos(2 pi x / P)): periodic, smooth everywhere, and x^2 - O(x^4) near 0
    (for P = 2 pi, 2(1 - cos x)). Below `wrapped_square` away from 0: at x = P/2 it is P^2/pi^2
    instead of P^2/4."""
    return period**2 / (2 * math.pi**2) * (1 - jnp.cos(2 * math.pi * x / period))


class Periodic(eqx.Module):
    """Which components of a state vector (the last axis) are periodic, and their periods.

    **Arguments:**
    - `periods`: one entry per component: the period (> 0, in the component's unit) or `None`
      for an ordinary component. E.g. a pendulum's (theta, theta_dot): `(2 * math.pi, None)`.

    Every method works on arrays of shape (..., n) with n = `len(periods)`.
    """

    periods: tuple[float | None, ...] = eqx.field(static=True)

    def __init__(self, periods: Sequence[float | None]):
        periods = tuple(None if p is None else float(p) for p in periods)
        for index, period in enumerate(periods):
            if period is not None and not (math.isfinite(period) and period > 0):
                raise InputError(f"periods[{index}] = {period!r} must be a finite positive period or None.")
        if not periods:
            raise InputError("periods = () must name at least one component.")
        self.periods = periods

    @property
    def n_features(self) -> int:
        """Length of `features`: two per periodic component, one per other component."""
        return sum(1 if p is None else 2 for p in self.periods)

    def feature_names(self, names: Sequence[str]) -> tuple[str, ...]:
        """Names of the `features`, from the components' `names`: "sin NAME", "cos NAME" or NAME."""
        if len(names) != len(self.periods):
            raise InputError(f"names has {len(names)} entries; there are {len(self.periods)} components.")
        return tuple(part for name, p in zip(names, self.periods)
                     for part in ((name,) if p is None else (f"sin {name}", f"cos {name}")))

    def _components(self, x):
        x = jnp.asarray(x)
        if x.shape[-1:] != (len(self.periods),):
            raise InputError(f"state shape {x.shape} must end in {len(self.periods)} components.")
        return [x[..., i] for i in range(len(self.periods))]

    def features(self, x):
        """The policy's view of the state: (sin, cos) of 2 pi x / P for a periodic component, the
        component itself otherwise, in component order; shape (..., n_features)."""
        parts = []
        for value, period in zip(self._components(x), self.periods):
            if period is None:
                parts.append(value)
            else:
                phase = 2 * math.pi / period * value
                parts += [jnp.sin(phase), jnp.cos(phase)]
        return jnp.stack(parts, axis=-1)

    def wrap(self, x):
        """Periodic components into [-P/2, P/2), the others unchanged."""
        return jnp.stack([value if p is None else wrap(value, p)
                          for value, p in zip(self._components(x), self.periods)], axis=-1)

    def unwrap(self, x, axis: int = 0):
        """Periodic components made continuous along `axis` (a trajectory's time axis): jumps
        larger than P/2 are taken for wraps and removed, as `numpy.unwrap`. `axis` counts the
        leading axes only (the components are the last)."""
        if axis < 0:
            axis -= 1
        return jnp.stack([value if p is None else jnp.unwrap(value, axis=axis, period=p)
                          for value, p in zip(self._components(x), self.periods)], axis=-1)

    def squared_error(self, x, target=0.0, sharpness: float | None = None, *, form: str = "wrapped"):
        """Per component, the squared distance from x to `target`: along the circle for a
        periodic component (`wrapped_square`, exact at `sharpness=None`; or `form="cosine"`,
        `cosine_square`, the same with or without sharpness), (x - target)^2 otherwise.
        Shape (..., n); weight and sum the components for a cost."""
        if form not in ("wrapped", "cosine"):
            raise InputError(f"form = {form!r} must be one of 'wrapped', 'cosine'.")
        error = jnp.asarray(x) - target
        parts = []
        for value, period in zip(self._components(error), self.periods):
            if period is None:
                parts.append(value**2)
            elif form == "cosine":
                parts.append(cosine_square(value, period))
            else:
                parts.append(wrapped_square(value, period, sharpness))
        return jnp.stack(parts, axis=-1)
