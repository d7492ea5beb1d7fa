"""`diffeqsolve_checked`: a failed stiff solve raises with advice, inside the program or (through
`call_checked`) on the host, and never hands back a silent NaN or a truncated solution."""

import diffrax
import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
import pytest

from snapo_ode import InputError, SolverFailed, call_checked, diffeqsolve_checked
from references import robertson_reference


def _robertson(t, y, k):
    """Robertson's stiff kinetics, rate constants `k` (3,)."""
    a, b, c = y
    return jnp.stack([-k[0] * a + k[1] * b * c,
                      k[0] * a - k[1] * b * c - k[2] * b**2,
                      k[2] * b**2])


def _solve(k, *, max_steps, t1=1e3):
    solution = diffeqsolve_checked(
        diffrax.ODETerm(_robertson), diffrax.Kvaerno5(), 0.0, t1, None, jnp.array([1.0, 0.0, 0.0]), k,
        stepsize_controller=diffrax.PIDController(rtol=1e-8, atol=1e-12), max_steps=max_steps)
    return solution.ys[-1]


K = jnp.array([0.04, 1e4, 3e7])


def test_a_successful_solve_conserves_mass_and_matches_scipy():
    y = jax.jit(lambda k: _solve(k, max_steps=4096))(K)
    reference = robertson_reference(K, 1e3, rtol=1e-12, atol=1e-16)
    np.testing.assert_allclose(np.asarray(y), reference, rtol=1e-5, atol=1e-12)
    assert float(jnp.sum(y)) == pytest.approx(1.0, abs=1e-10)


def test_max_steps_raises_with_advice_inside_jit():
    with pytest.raises(eqx.EquinoxRuntimeError, match="max_steps"):
        eqx.filter_jit(lambda k: _solve(k, max_steps=4))(K).block_until_ready()


def test_through_call_checked_the_failure_raises_on_the_host_with_advice():
    with pytest.raises(SolverFailed, match="max_steps"):
        call_checked(jax.jit(lambda k: _solve(k, max_steps=4)), K, what="the Robertson solve")
    good = call_checked(jax.jit(lambda k: _solve(k, max_steps=4096)), K)
    assert np.all(np.isfinite(np.asarray(good)))
    # The same function outside call_checked still raises inside the program.
    with pytest.raises(eqx.EquinoxRuntimeError, match="max_steps"):
        eqx.filter_jit(lambda k: _solve(k, max_steps=4))(K).block_until_ready()


def test_a_models_own_check_is_named_among_the_causes():
    """A domain's `error_if` leaves the same NaN mark as a failed solve; `causes` names it."""
    def fraction_left(k):
        y = _solve(k, max_steps=4096)
        return eqx.error_if(y[0], y[0] > 0.5, "too little converted")

    cause = "less than half of A converted: integrate longer"
    with pytest.raises(SolverFailed, match="max_steps") as failure:
        call_checked(jax.jit(fraction_left), K * 1e-6, what="the conversion", causes=(cause,))
    assert str(failure.value).endswith(f" Or {cause}")
    assert float(call_checked(jax.jit(fraction_left), K, causes=(cause,))) < 0.5


def test_backsolve_and_throw_are_refused_before_compiling():
    with pytest.raises(InputError, match="BacksolveAdjoint"):
        diffeqsolve_checked(diffrax.ODETerm(_robertson), diffrax.Kvaerno5(), 0.0, 1.0, None,
                            jnp.array([1.0, 0.0, 0.0]), K, adjoint=diffrax.BacksolveAdjoint())
    with pytest.raises(InputError, match="throw"):
        diffeqsolve_checked(diffrax.ODETerm(_robertson), diffrax.Kvaerno5(), 0.0, 1.0, None,
                            jnp.array([1.0, 0.0, 0.0]), K, throw=True)
