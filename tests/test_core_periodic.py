"""Periodic state components: wrapping against NumPy's complex angle, the smooth wrapped square's
gap and its derivative (central differences) across the wrap point, invariance under a whole
period, unwrapping, and input errors."""

import math

import jax
import jax.numpy as jnp
import numpy as np
import pytest

import snapo_ode
from snapo_ode import InputError, Periodic, central_differences, cosine_square, wrap, wrapped_square

TAU = 2 * math.pi


def test_wrap_agrees_with_the_complex_angle():
    xs = np.random.default_rng(0).uniform(-50, 50, 1000)
    reference = np.angle(np.exp(1j * xs))  # in (-pi, pi]
    np.testing.assert_allclose(np.asarray(wrap(jnp.asarray(xs), TAU)), reference, atol=1e-12)
    assert float(wrap(math.pi, TAU)) == -math.pi  # [-P/2, P/2), as Gymnasium's angle_normalize


@pytest.mark.parametrize("k", [1.0, 10.0, 1e3])
def test_wrapped_square_gap_is_within_its_bound_and_largest_at_the_wrap(k):
    xs = jnp.linspace(-10, 10, 4001)
    hard = wrapped_square(xs, TAU)
    np.testing.assert_allclose(hard, np.angle(np.exp(1j * np.asarray(xs))) ** 2, atol=1e-11)
    gap = np.asarray(wrapped_square(xs, TAU, k) - hard)
    assert gap.max() <= 1e-12 and gap.min() >= -math.log(2) / k * (1 + 1e-9)
    at_wrap = float(wrapped_square(math.pi, TAU, k)) - math.pi**2
    assert at_wrap == pytest.approx(-math.log(2) / k, rel=1e-9)


@pytest.mark.parametrize("x", [math.pi, -math.pi, math.pi - 1e-3, math.pi + 1e-3, 3 * math.pi, 0.3, -2.0])
def test_smooth_wrapped_square_derivative_matches_central_differences_across_the_wrap(x):
    k = 5.0
    adjoint = float(jax.grad(wrapped_square)(jnp.float64(x), TAU, k))
    bumped = central_differences(lambda v: wrapped_square(v, TAU, k), jnp.float64(x), relative_step=1e-6)
    assert adjoint == pytest.approx(float(bumped[0]), rel=1e-6, abs=1e-8)


def test_the_smooth_derivative_passes_through_zero_where_the_hard_one_jumps():
    grad_hard = jax.grad(wrapped_square)
    grad_smooth = jax.grad(wrapped_square)
    below, above = math.pi - 1e-9, math.pi + 1e-9
    assert float(grad_hard(below, TAU)) == pytest.approx(TAU) and float(grad_hard(above, TAU)) == pytest.approx(-TAU)
    assert abs(float(grad_smooth(below, TAU, 10.0))) < 1e-6 and abs(float(grad_smooth(above, TAU, 10.0))) < 1e-6
    xs = jnp.linspace(math.pi - 0.5, math.pi + 0.5, 10001)
    slopes = np.asarray(jax.vmap(grad_smooth, in_axes=(0, None, None))(xs, TAU, 10.0))
    assert np.max(np.abs(np.diff(slopes))) < 0.1  # steps of 1e-4: no jump (the hard one jumps by 4 pi)


def test_cosine_square_is_the_square_to_fourth_order():
    xs = jnp.linspace(-0.1, 0.1, 201)
    np.testing.assert_allclose(cosine_square(xs, TAU), xs**2 - xs**4 / 12 + xs**6 / 360, atol=1e-12)
    np.testing.assert_allclose(cosine_square(xs, TAU), 2 * (1 - jnp.cos(xs)), rtol=1e-12)
    assert float(cosine_square(3.0, 6.0)) == pytest.approx(36 / math.pi**2)


def test_features_and_errors_are_invariant_under_a_whole_period():
    periodic = Periodic((TAU, None, 1.0))
    x = jnp.array([[0.4, -2.0, 0.3], [-3.0, 5.0, 0.9]])
    shifted = x + jnp.array([TAU, 0.0, -3.0])
    assert periodic.n_features == 5
    assert periodic.feature_names(("theta", "omega", "phase")) == (
        "sin theta", "cos theta", "omega", "sin phase", "cos phase")
    np.testing.assert_allclose(periodic.features(shifted), periodic.features(x), atol=1e-12)
    np.testing.assert_allclose(periodic.features(x)[:, :3],
                               np.stack([np.sin(x[:, 0]), np.cos(x[:, 0]), x[:, 1]], -1), rtol=1e-15)
    for form in ("wrapped", "cosine"):
        np.testing.assert_allclose(periodic.squared_error(shifted, 0.1, 3.0, form=form),
                                   periodic.squared_error(x, 0.1, 3.0, form=form), atol=1e-12)
    np.testing.assert_allclose(periodic.squared_error(x)[:, 1], x[:, 1] ** 2, rtol=1e-15)
    np.testing.assert_allclose(periodic.wrap(shifted), periodic.wrap(x), atol=1e-12)


def test_unwrap_restores_a_continuous_trajectory():
    t = jnp.linspace(0, 4, 401)
    trajectory = jnp.stack([3.0 * t - 1.0, jnp.sin(t)], -1)  # the angle makes about two turns
    periodic = Periodic((TAU, None))
    wrapped = periodic.wrap(trajectory)
    assert float(jnp.max(jnp.abs(jnp.diff(wrapped[:, 0])))) > 6  # wrapping made jumps
    np.testing.assert_allclose(periodic.unwrap(wrapped), trajectory, atol=1e-12)
    batch = jnp.stack([trajectory, trajectory + jnp.array([0.5, 0.0])], 1)  # (time, batch, 2)
    np.testing.assert_allclose(periodic.unwrap(periodic.wrap(batch), axis=0), batch, atol=1e-12)


def test_bad_declarations_and_shapes_raise_input_errors():
    with pytest.raises(InputError, match=r"periods\[1\] = -1.0 must be a finite positive period"):
        Periodic((TAU, -1.0))
    with pytest.raises(InputError, match="must end in 2 components"):
        Periodic((TAU, None)).features(jnp.zeros(3))
    with pytest.raises(InputError, match="form = 'square'"):
        Periodic((TAU,)).squared_error(jnp.zeros(1), form="square")
    assert snapo_ode.Periodic is Periodic
