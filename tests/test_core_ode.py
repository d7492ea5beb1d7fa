"""`diffeqsolve_checked`: a failed stiff solve raises with advice, in either failure mode, and
never hands back a silent NaN or a truncated solution."""

import diffrax
import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
import pytest

from snapo_ode import InputError, SolverFailed, diffeqsolve_checked, raise_if_failed


def _robertson(t, y, k):
    """Robertson's stiff kinetics, rate constants `k` (3,)."""
    a, b, c = y
    return jnp.stack([-k[0] * a + k[1] * b * c,
                      k[0] * a - k[1] * b * c - k[2] * b**2,
                      k[2] * b**2])


def _solve(k, *, max_steps, on_failure="raise", t1=1e3):
    solution = diffeqsolve_checked(
        diffrax.ODETerm(_robertson), diffrax.Kvaerno5(), 0.0, t1, None, jnp.array([1.0, 0.0, 0.0]), k,
        stepsize_controller=diffrax.PIDController(rtol=1e-8, atol=1e-12), max_steps=max_steps,
        on_failure=on_failure)
    return solution.ys[-1]


K = jnp.array([0.04, 1e4, 3e7])


def test_a_successful_solve_conserves_mass_and_matches_scipy():
    from scipy.integrate import solve_ivp

    y = jax.jit(lambda k: _solve(k, max_steps=4096))(K)
    reference = solve_ivp(lambda t, y: np.asarray(_robertson(t, y, np.asarray(K))), (0.0, 1e3),
                          [1.0, 0.0, 0.0], method="Radau", rtol=1e-12, atol=1e-16).y[:, -1]
    np.testing.assert_allclose(np.asarray(y), reference, rtol=1e-5, atol=1e-12)
    assert float(jnp.sum(y)) == pytest.approx(1.0, abs=1e-10)


def test_max_steps_raises_with_advice_inside_jit():
    with pytest.raises(eqx.EquinoxRuntimeError, match="max_steps"):
        eqx.filter_jit(lambda k: _solve(k, max_steps=4))(K).block_until_ready()


def test_nan_mode_marks_the_failure_and_the_host_check_raises_with_advice():
    y = jax.jit(lambda k: _solve(k, max_steps=4, on_failure="nan"))(K)
    assert np.all(np.isnan(np.asarray(y)))
    with pytest.raises(SolverFailed, match="max_steps"):
        raise_if_failed(y, "the Robertson solve")
    good = jax.jit(lambda k: _solve(k, max_steps=4096, on_failure="nan"))(K)
    raise_if_failed(good)  # nothing to report


def test_backsolve_and_unknown_modes_are_refused_before_compiling():
    with pytest.raises(InputError, match="BacksolveAdjoint"):
        diffeqsolve_checked(diffrax.ODETerm(_robertson), diffrax.Kvaerno5(), 0.0, 1.0, None,
                            jnp.array([1.0, 0.0, 0.0]), K, adjoint=diffrax.BacksolveAdjoint())
    with pytest.raises(InputError, match="on_failure"):
        _solve(K, max_steps=16, on_failure="ignore")
