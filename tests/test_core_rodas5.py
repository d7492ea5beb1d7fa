"""`Rodas5` (snapo_ode._rosenbrock): fifth-order convergence (non-autonomous, so the df/dt term
counts), Robertson's stiff kinetics against SciPy's Radau at tight tolerance, reverse- and
forward-mode derivatives against central bumps; and, for both Rosenbrock methods, the
carried f(t0, y0) refreshed after a jump in the vector field."""

import diffrax
import jax
import jax.numpy as jnp
import numpy as np
import pytest

from snapo_ode import diffeqsolve_checked
from snapo_ode._rosenbrock import Rodas4, Rodas5
from test_core_rosenbrock import K, Y0, _central_bumps, _exact, _relaxation, _robertson


def test_fifth_order_convergence_on_a_non_autonomous_problem():
    errors = []
    steps = (0.2, 0.1, 0.05, 0.025)
    for dt in steps:
        solution = diffrax.diffeqsolve(diffrax.ODETerm(_relaxation), Rodas5(), 0.0, 2.0, dt, jnp.array(1.0), 1.0,
                                       stepsize_controller=diffrax.ConstantStepSize(), max_steps=1000)
        errors.append(abs(float(solution.ys[-1]) - _exact(2.0, 1.0, 1.0)))
    slope = np.polyfit(np.log(steps), np.log(errors), 1)[0]
    assert 4.6 < slope < 5.6, (slope, errors)


def _solve(k, adjoint=diffrax.RecursiveCheckpointAdjoint()):
    solution = diffeqsolve_checked(diffrax.ODETerm(_robertson), Rodas5(), 0.0, 1e3, None, Y0, k,
                                   stepsize_controller=diffrax.PIDController(rtol=1e-10, atol=1e-14),
                                   max_steps=20_000, adjoint=adjoint)
    return jnp.stack([solution.ys["a"][-1], solution.ys["b"][-1], solution.ys["c"][-1]])


def test_robertson_matches_radau_at_tight_tolerance():
    from scipy.integrate import solve_ivp

    def rhs(t, y):
        values = _robertson(t, dict(zip("abc", y)), np.asarray(K))
        return [values["a"], values["b"], values["c"]]

    reference = solve_ivp(rhs, (0.0, 1e3), [1.0, 0.0, 0.0], method="Radau", rtol=1e-13, atol=1e-18).y[:, -1]
    y = jax.jit(_solve)(K)
    np.testing.assert_allclose(np.asarray(y), reference, rtol=1e-7)
    assert float(jnp.sum(y)) == pytest.approx(1.0, abs=1e-12)


def test_reverse_and_forward_mode_derivatives_match_central_bumps():
    f = jax.jit(_solve)
    bumps = _central_bumps(f, K)
    reverse = np.asarray(jax.jit(jax.jacrev(_solve))(K))
    forward = np.asarray(jax.jit(jax.jacfwd(lambda k: _solve(k, diffrax.ForwardMode())))(K))
    scale = np.abs(bumps).max(axis=1, keepdims=True)
    assert np.max(np.abs(reverse - bumps) / scale) < 1e-6
    assert np.max(np.abs(forward - bumps) / scale) < 1e-6


@pytest.mark.parametrize("solver", [Rodas4(), Rodas5()], ids=["rodas4", "rodas5"])
def test_a_jump_in_the_vector_field_refreshes_the_carried_rate(solver):
    # y' = s(t) - y with s = 0 before t = 1 and 1 after: y = exp(-t), then 1 + (exp(-1) - 1) exp(1 - t).
    # A step that starts at the jump must not reuse f from before it (off by 1 in y').
    def field(t, y, args):
        return jnp.where(t >= 1.0, 1.0, 0.0) - y

    solution = diffrax.diffeqsolve(diffrax.ODETerm(field), solver, 0.0, 3.0, 0.1, jnp.array(1.0),
                                   stepsize_controller=diffrax.PIDController(rtol=1e-10, atol=1e-12,
                                                                             jump_ts=jnp.array([1.0])))
    exact = 1.0 + (np.exp(-1.0) - 1.0) * np.exp(-2.0)
    assert float(solution.ys[-1]) == pytest.approx(exact, rel=1e-9)
