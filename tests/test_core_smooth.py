"""Smooth surrogates: convergence to the hard function, documented gaps, monotonicity, and
finite values and gradients at extreme inputs and sharpness up to 1e8."""

import math

import jax
import jax.numpy as jnp
import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

from snapo_ode import smooth

finite = st.floats(min_value=-1e300, max_value=1e300, allow_nan=False, allow_infinity=False)
moderate = st.floats(min_value=-1e3, max_value=1e3, allow_nan=False)
sharpness = st.floats(min_value=1e-2, max_value=1e8)

KNOTS_X = jnp.array([0.0, 0.3, 0.7, 1.0])
KNOTS_Y = jnp.array([1.0, 1.0, 0.6, 0.2])
# Sum of |slope changes| of the table above: 0 -> 0 -> -1 -> -4/3 -> 0.
KINKS = 0.0 + 1.0 + 1 / 3 + 4 / 3

# name -> (one-argument smooth function of (x, k), hard function of x, worst-case |gap| at k)
UNARY = {
    "relu": (lambda x, k: smooth.relu(x, k), lambda x: smooth.relu(x), lambda k: math.log(2) / k),
    "clip": (lambda x, k: smooth.clip(x, -1.0, 2.0, k), lambda x: smooth.clip(x, -1.0, 2.0),
             lambda k: math.log(2) / k),
    "abs": (lambda x, k: smooth.abs(x, k), lambda x: smooth.abs(x), lambda k: 2 * math.log(2) / k),
    "max": (lambda x, k: smooth.maximum(x, 0.5, k), lambda x: smooth.maximum(x, 0.5),
            lambda k: math.log(2) / k),
    "min": (lambda x, k: smooth.minimum(x, 0.5, k), lambda x: smooth.minimum(x, 0.5),
            lambda k: math.log(2) / k),
    "piecewise_linear": (lambda x, k: smooth.piecewise_linear(x, KNOTS_X, KNOTS_Y, k),
                         lambda x: smooth.piecewise_linear(x, KNOTS_X, KNOTS_Y),
                         lambda k: KINKS * math.log(2) / k),
}
MONOTONE = ["relu", "clip", "max", "min"]


@pytest.mark.parametrize("name", sorted(UNARY))
@settings(max_examples=60, deadline=None)
@given(x=moderate, k=sharpness)
def test_gap_within_documented_bound(name, x, k):
    soft, hard, bound = UNARY[name]
    gap = abs(float(soft(x, k)) - float(hard(x)))
    assert gap <= bound(k) * (1 + 1e-9) + 1e-12 * max(1.0, abs(x))


@pytest.mark.parametrize("name", sorted(UNARY))
def test_converges_to_hard_function(name):
    soft, hard, _ = UNARY[name]
    xs = jnp.linspace(-3, 3, 601)
    gaps = [float(jnp.max(jnp.abs(soft(xs, k) - hard(xs)))) for k in (1e1, 1e2, 1e3, 1e4)]
    assert all(b < a for a, b in zip(gaps, gaps[1:], strict=False))
    # The worst gap is at a kink and scales as 1/k: a tenfold sharper surrogate is tenfold closer.
    assert gaps[-1] < gaps[0] * 2e-3


@pytest.mark.parametrize("name", MONOTONE)
@settings(max_examples=60, deadline=None)
@given(a=moderate, b=moderate, k=sharpness)
def test_monotone_where_hard_function_is(name, a, b, k):
    soft, _, _ = UNARY[name]
    lo, hi = min(a, b), max(a, b)
    assert float(soft(lo, k)) <= float(soft(hi, k))


@pytest.mark.parametrize("name", sorted(UNARY) + ["step", "softplus"])
@settings(max_examples=60, deadline=None)
@given(x=finite, k=st.sampled_from([1e-2, 1.0, 1e4, 1e8]))
def test_finite_values_and_gradients_at_extremes(name, x, k):
    fn = {
        "step": lambda x, k: smooth.step(x, k),
        "softplus": smooth.softplus,
    }.get(name) or UNARY[name][0]
    value, grad = jax.value_and_grad(fn)(jnp.float64(x), k)
    assert np.isfinite(float(value)) and np.isfinite(float(grad))


@settings(max_examples=60, deadline=None)
@given(x=st.floats(min_value=-1e150, max_value=1e150), k=st.sampled_from([1e-2, 1.0, 1e8]))
def test_penalties_finite_wherever_their_square_is(x, k):
    for penalty in (smooth.penalty_below, smooth.penalty_above):
        value, grad = jax.value_and_grad(penalty)(jnp.float64(x), 0.0, k)
        assert np.isfinite(float(value)) and np.isfinite(float(grad))


def test_softplus_gradient_is_sigmoid_at_the_kink_and_wrt_sharpness():
    assert float(jax.grad(smooth.softplus)(0.0, 1e8)) == 0.5
    k, x, h = 3.0, 0.2, 1e-6
    central = (smooth.softplus(x, k + h) - smooth.softplus(x, k - h)) / (2 * h)
    assert float(jax.grad(smooth.softplus, argnums=1)(x, k)) == pytest.approx(float(central), rel=1e-7)


def test_smooth_clip_never_leaves_the_interval():
    xs = jnp.linspace(-50, 50, 1001)
    clipped = smooth.clip(xs, -1.0, 2.0, 5.0)
    assert bool(jnp.all(clipped >= -1.0)) and bool(jnp.all(clipped <= 2.0))


def test_step_and_penalties_against_hard_forms():
    xs = jnp.array([-2.0, -0.1, 0.1, 2.0])
    np.testing.assert_allclose(smooth.step(xs, 1e3), smooth.step(xs), atol=1e-40)
    np.testing.assert_allclose(smooth.penalty_below(xs, 0.0), [4.0, 0.01, 0.0, 0.0], rtol=1e-15)
    np.testing.assert_allclose(smooth.penalty_above(xs, 0.0), [0.0, 0.0, 0.01, 4.0], rtol=1e-15)
    np.testing.assert_allclose(smooth.penalty_below(xs, 0.0, 1e6), smooth.penalty_below(xs, 0.0), atol=1e-6)


def test_clip_is_its_two_softplus_forms_to_the_bit():
    """`clip` evaluates only the two hinges of the form it returns; the values are those of both
    forms written out with four softplus calls, bit for bit."""
    xs, low, high, k = jnp.linspace(-3, 4, 2001), -1.0, 2.0, 7.0
    from_low = low + smooth.softplus(xs - low, k) - smooth.softplus(xs - high, k)
    from_high = high - smooth.softplus(high - xs, k) + smooth.softplus(low - xs, k)
    np.testing.assert_array_equal(smooth.clip(xs, low, high, k), jnp.where(xs < (low + high) / 2, from_low, from_high))


@pytest.mark.parametrize("x", [-1.3, -0.9, 0.2, 0.51, 1.9, 2.6])
def test_clip_and_piecewise_gradients_match_central_differences(x):
    """Every argument, the sharpness included, against central differences."""
    def central(fn, args, i, h=1e-6):
        up, down = list(args), list(args)
        up[i], down[i] = args[i] + h, args[i] - h
        return (fn(*up) - fn(*down)) / (2 * h)

    clip_args = (x, -1.0, 2.0, 4.0)
    for i in range(4):
        assert float(jax.grad(smooth.clip, argnums=i)(*clip_args)) == pytest.approx(
            float(central(smooth.clip, clip_args, i)), rel=1e-6, abs=1e-9)
    fill, k = (x + 1.5) / 4.5, 30.0
    table = lambda fill, y1, k: smooth.piecewise_linear(fill, KNOTS_X, KNOTS_Y.at[1].set(y1), k)  # noqa: E731
    for i, args in enumerate([(fill, 1.0, k)] * 3):
        assert float(jax.grad(table, argnums=i)(*args)) == pytest.approx(float(central(table, args, i)),
                                                                         rel=1e-6, abs=1e-9)
