"""Smooth surrogates of hard constraints, each with its exact counterpart.

Every function takes `sharpness` [1/unit of x]: `None` gives the exact (hard) function, a
positive float the smooth surrogate. One model function therefore evaluates smooth for
training (`sharpness=k`) and hard for reporting (`sharpness=None`), and the gap between the
two is the smoothing error. All are finite, with finite gradients, for any finite input and
any sharpness up to 1e8: nothing exponentiates a positive argument. (The squared penalties
are finite wherever their square is, i.e. for |x| below about 1e150.)

Worst-case gaps (smooth minus hard), with k the sharpness:

| function | gap |
| --- | --- |
| `softplus`, `relu`, `maximum` | in (0, log(2)/k], largest at the kink |
| `minimum` | in [-log(2)/k, 0) |
| `clip` | at most log(2)/k in absolute value; the result never leaves [low, high] |
| `abs` | in (0, 2 log(2)/k] |
| `step` | at most 1/2 (at 0), and below exp(-k abs(x)) elsewhere |
| `piecewise_linear` | at most log(2)/k times the sum of the absolute slope changes |
| `penalty_below`, `penalty_above` | the square of the `relu` gap plus twice it times the hard hinge |
"""

import jax
import jax.numpy as jnp

__all__ = [
    "softplus",
    "relu",
    "maximum",
    "minimum",
    "clip",
    "abs",
    "step",
    "piecewise_linear",
    "penalty_below",
    "penalty_above",
]

_abs = jnp.abs


def _tail(x, sharpness):
    """exp(-k|x|) and log1p(exp(-k|x|)) / k: the transcendental part of softplus(x), which its
    slope shares."""
    decay = jnp.exp(-sharpness * _abs(x))
    return decay, jnp.log1p(decay) / sharpness


def _logistic(x, decay):
    """sigmoid(k x) from `decay` = exp(-k|x|), without another exponential."""
    return jnp.where(x >= 0, 1.0, decay) / (1 + decay)


@jax.custom_jvp
def softplus(x, sharpness: float):
    """log(1 + exp(k x)) / k, computed as max(x, 0) + log1p(exp(-k|x|)) / k so that no
    exponential overflows. Converges to max(x, 0) from above; gap at most log(2)/k.

    The derivative is defined explicitly (sigmoid(k x) in x), so it is right at x = 0 too,
    where the kinks of max and abs inside the stable form would give automatic
    differentiation a one-sided answer; it reuses the value's exponential.
    """
    x = jnp.asarray(x)
    return jnp.maximum(x, 0) + _tail(x, sharpness)[1]


@softplus.defjvp
def _softplus_jvp(primals, tangents):
    x, sharpness = primals
    dx, dsharpness = tangents
    x = jnp.asarray(x)
    decay, tail = _tail(x, sharpness)
    y, slope = jnp.maximum(x, 0) + tail, _logistic(x, decay)
    return y, slope * dx + (x * slope - y) / sharpness * dsharpness


def relu(x, sharpness: float | None = None):
    """max(x, 0), or its `softplus` surrogate."""
    return jnp.maximum(x, 0) if sharpness is None else softplus(x, sharpness)


def maximum(a, b, sharpness: float | None = None):
    """max(a, b), or b + softplus(a - b)."""
    return jnp.maximum(a, b) if sharpness is None else b + softplus(a - b, sharpness)


def minimum(a, b, sharpness: float | None = None):
    """min(a, b), or a - softplus(a - b)."""
    return jnp.minimum(a, b) if sharpness is None else a - softplus(a - b, sharpness)


def clip(x, low, high, sharpness: float | None = None):
    """Clip x to [low, high] (low <= high), or low + softplus(x - low) - softplus(x - high),
    which is increasing in x and never leaves [low, high]."""
    if sharpness is None:
        return jnp.clip(x, low, high)
    # Two forms of the same function (softplus(z) = z + softplus(-z)); each is used on the side
    # where it saturates to its bound exactly, so round-off never carries x past low or high.
    # softplus(s (x - low)) and softplus(s (x - high)) with s = +1 below the midpoint, -1 above
    # it: the two hinges of whichever form is used, and no others.
    below = x < (low + high) / 2
    sign = jnp.where(below, 1.0, -1.0)
    at_low, at_high = softplus(sign * (x - low), sharpness), softplus(sign * (x - high), sharpness)
    from_low = low + at_low - at_high
    from_high = high - at_high + at_low
    return jnp.where(below, from_low, from_high)


def abs(x, sharpness: float | None = None):  # noqa: A001  (mirrors jnp.abs)
    """|x|, or softplus(x) + softplus(-x)."""
    if sharpness is None:
        return _abs(x)
    return softplus(x, sharpness) + softplus(-x, sharpness)


def step(x, sharpness: float | None = None):
    """The Heaviside step (1 for x > 0, else 0), or the logistic sigmoid(k x)."""
    if sharpness is None:
        return jnp.where(x > 0, 1.0, 0.0)
    return jax.nn.sigmoid(sharpness * x)


def piecewise_linear(x, knots_x, knots_y, sharpness: float | None = None):
    """The piecewise-linear interpolant through (knots_x, knots_y), flat outside the knots
    (as `jnp.interp`), or the same function with every kink rounded by a `softplus`.

    **Arguments:** `knots_x` strictly increasing, shape (m,); `knots_y` shape (m,).
    """
    knots_x = jnp.asarray(knots_x)
    knots_y = jnp.asarray(knots_y)
    if sharpness is None:
        return jnp.interp(x, knots_x, knots_y)
    slopes = jnp.diff(knots_y) / jnp.diff(knots_x)
    zero = jnp.zeros((1,), slopes.dtype)
    kinks = jnp.diff(jnp.concatenate([zero, slopes, zero]))
    # One hinge per knot, summed knot by knot: elementwise work only (a reduction over a short
    # trailing axis of knots is several times slower on a CPU, its reverse pass most).
    value = knots_y[0]
    for knot in range(knots_x.shape[0]):
        value = value + kinks[knot] * softplus(x - knots_x[knot], sharpness)
    return value


def penalty_below(x, floor, sharpness: float | None = None):
    """Squared shortfall below `floor`: relu(floor - x)^2 (zero when x >= floor)."""
    return relu(floor - x, sharpness) ** 2


def penalty_above(x, cap, sharpness: float | None = None):
    """Squared excess above `cap`: relu(x - cap)^2 (zero when x <= cap)."""
    return relu(x - cap, sharpness) ** 2
