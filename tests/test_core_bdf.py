"""`SolverSettings(solver="bdf")` (`snapo_ode._solver.bdf`): against an analytic solution, against
SciPy's BDF (the same formulas, step for step) and a tight Radau reference on Robertson's
problem, reverse- and forward-mode derivatives (through arguments and through values the
vector field closes over) against central bumps, batches, and its refusals and failures."""

import diffrax
import jax
import jax.numpy as jnp
import numpy as np
import pytest
import scipy.integrate
import scipy.linalg

from snapo_ode import InputError, SolverFailed, SolverSettings, call_checked

BDF = SolverSettings(solver="bdf", rtol=1e-10, atol=1e-12)
ROBERTSON_TIMES = np.array([0.0, 0.4, 4.0, 40.0])


def robertson(t, y, log_k1):
    """Robertson's stiff kinetics (rate constants 0.04 e^log_k1, 3e7, 1e4)."""
    k1 = 0.04 * jnp.exp(log_k1)
    return jnp.stack([-k1 * y[0] + 1e4 * y[1] * y[2],
                      k1 * y[0] - 1e4 * y[1] * y[2] - 3e7 * y[1] ** 2,
                      3e7 * y[1] ** 2])


def solve_robertson(log_k1, settings=BDF, times=ROBERTSON_TIMES):
    return settings.solve(robertson, 0.0, times[-1], jnp.array([1.0, 0.0, 0.0]), log_k1,
                          saveat=diffrax.SaveAt(ts=jnp.asarray(times))).ys


def test_bdf_matches_the_analytic_solution_of_a_stiff_linear_system():
    # Eigenvalues -1, -1e2 and -1e4 (stiffness 1e4), a non-diagonal matrix.
    rng = np.random.default_rng(3)
    basis = np.eye(3) + 0.3 * rng.standard_normal((3, 3))
    matrix = basis @ np.diag([-1.0, -1e2, -1e4]) @ np.linalg.inv(basis)
    y0 = np.array([1.0, 0.5, -0.25])
    times = np.array([0.0, 1e-3, 0.1, 1.0, 3.0])
    ys = BDF.solve(lambda t, y, a: jnp.asarray(matrix) @ y, 0.0, 3.0, jnp.asarray(y0),
                   saveat=diffrax.SaveAt(ts=jnp.asarray(times))).ys
    exact = np.stack([scipy.linalg.expm(matrix * t) @ y0 for t in times])
    np.testing.assert_allclose(np.asarray(ys), exact, rtol=1e-7, atol=1e-10)


def test_bdf_takes_scipys_steps_and_meets_a_tight_reference_on_robertson():
    ys = np.asarray(jax.jit(solve_robertson)(0.0))
    # SciPy's BDF implements the same formulas, error test and order selection: the solutions
    # agree far below the tolerance (step decisions identical up to round-off).
    # Compiled once, so SciPy's thousands of calls are not thousands of op-by-op dispatches.
    field, jacobian = jax.jit(robertson), jax.jit(jax.jacfwd(robertson, argnums=1))
    fun = lambda t, y: np.asarray(field(t, y, 0.0))  # noqa: E731
    jac = lambda t, y: np.asarray(jacobian(t, y, 0.0))  # noqa: E731
    scipy_bdf = scipy.integrate.solve_ivp(fun, (0.0, 40.0), [1.0, 0.0, 0.0], method="BDF", t_eval=ROBERTSON_TIMES,
                                          rtol=BDF.rtol, atol=BDF.atol, jac=jac)
    np.testing.assert_allclose(ys, scipy_bdf.y.T, rtol=1e-9, atol=1e-16)
    reference = scipy.integrate.solve_ivp(fun, (0.0, 40.0), [1.0, 0.0, 0.0], method="Radau", t_eval=ROBERTSON_TIMES,
                                          rtol=1e-13, atol=1e-18, jac=jac)
    np.testing.assert_allclose(ys, reference.y.T, rtol=1e-7, atol=1e-14)


@pytest.mark.parametrize("closure", [False, True], ids=["args", "closure"])
def test_bdf_derivatives_in_both_modes_match_central_bumps(closure):
    """d y(40) / d log k1 by one reverse pass (a checkpoint a step) and by `jax.jacfwd`, through
    the BDF loop, against central differences of the same solve at a tighter tolerance (float64);
    log k1 passed as the solve's args, or closed over by the vector field as a model's
    parameters are."""
    settings = BDF.replace(rtol=1e-12, atol=1e-16, max_steps=50_000)

    def final(log_k1, settings):
        if closure:
            return settings.solve(lambda t, y, args: robertson(t, y, log_k1), 0.0, 40.0, jnp.array([1.0, 0.0, 0.0]),
                                  saveat=diffrax.SaveAt(ts=jnp.asarray(ROBERTSON_TIMES))).ys[-1]
        return solve_robertson(log_k1, settings)[-1]

    reverse = np.asarray(jax.jit(jax.jacrev(lambda p: final(p, settings)))(0.0))
    forward = np.asarray(jax.jit(jax.jacfwd(lambda p: final(p, settings.replace(differentiation="forward"))))(0.0))
    values = jax.jit(lambda p: final(p, settings))
    step = 1e-3
    bumped = (np.asarray(values(step)) - np.asarray(values(-step))) / (2 * step)
    np.testing.assert_allclose(reverse, bumped, rtol=1e-6, atol=1e-12)
    np.testing.assert_allclose(forward, reverse, rtol=1e-8)  # one linear map, transposed: round-off of I - c J
    assert np.all(np.abs(reverse) > 1e-6)  # every component moves


@pytest.mark.parametrize("differentiation", ["reverse", "forward"])
def test_bdf_derivatives_through_a_field_that_closes_over_traced_integers(differentiation):
    """A vector field that closes over an integer array traced by an outer `jit` (as a model's
    index arrays are, passed to a jitted function): `jax.closure_convert` left it closed over and
    the lowering failed on a leaked tracer. Its derivative against central bumps."""
    settings = BDF.replace(rtol=1e-12, atol=1e-16, max_steps=50_000, differentiation=differentiation)

    @jax.jit
    def final(log_k1, species):
        field = lambda t, y, args: robertson(t, y[species], log_k1)[species]  # noqa: E731 - a relabelling
        return settings.solve(field, 0.0, 40.0, jnp.array([0.0, 1.0, 0.0]), saveat=diffrax.SaveAt(t1=True)).ys[-1]

    species = jnp.array([1, 0, 2])  # species 0 is stored second
    differentiate = jax.jacrev if differentiation == "reverse" else jax.jacfwd
    derivative = np.asarray(jax.jit(differentiate(final))(0.0, species))
    step = 1e-3
    bumped = (np.asarray(final(step, species)) - np.asarray(final(-step, species))) / (2 * step)
    np.testing.assert_allclose(derivative, bumped, rtol=1e-6, atol=1e-12)
    assert np.all(np.abs(derivative) > 1e-6)


@pytest.mark.parametrize("differentiation", ["reverse", "forward"])
def test_bdf_takes_python_numbers_in_args_under_jit_and_derivatives(differentiation):
    """args = 1.5 (a Python float, as a model's float field is) under `jit` and through a
    derivative: the solve of dy/dt = -k y against exp(-k t) and its derivative in y0."""
    settings = BDF.replace(differentiation=differentiation)

    def final(y0):
        return settings.solve(lambda t, y, k: -k * y, 0.0, 1.0, y0, 1.5, saveat=diffrax.SaveAt(t1=True)).ys[-1]

    y0 = jnp.array([1.0, 2.0])
    differentiate = jax.jacrev if differentiation == "reverse" else jax.jacfwd
    np.testing.assert_allclose(np.asarray(jax.jit(final)(y0)), np.exp(-1.5) * np.asarray(y0), rtol=1e-8)
    np.testing.assert_allclose(np.asarray(jax.jit(differentiate(final))(y0)), np.exp(-1.5) * np.eye(2), rtol=1e-8,
                               atol=1e-14)


def test_bdf_batch_equals_single_solves():
    log_k1 = jnp.array([-0.5, 0.0, 0.7])
    batch = np.asarray(jax.jit(jax.vmap(solve_robertson))(log_k1))
    single = np.stack([np.asarray(jax.jit(solve_robertson)(p)) for p in log_k1])
    np.testing.assert_allclose(batch, single, rtol=1e-12, atol=1e-18)


def test_bdf_refuses_backsolve_and_dense_output_before_any_compile():
    with pytest.raises(InputError, match="differentiation = 'backsolve'"):
        solve_robertson(0.0, BDF.replace(differentiation="backsolve"))
    with pytest.raises(InputError, match="BDF saves at t1 or at given ts only"):
        BDF.solve(robertson, 0.0, 1.0, jnp.array([1.0, 0.0, 0.0]), 0.0, saveat=diffrax.SaveAt(t1=True, dense=True))
    with pytest.raises(InputError, match="not a Diffrax method"):
        BDF.method()
    with pytest.raises(InputError, match=r"t0 < t1.*spans 0 to 50"):
        solve_robertson(0.0, times=np.array([0.0, 50.0, 40.0]))


def test_bdf_that_runs_out_of_steps_raises_with_advice_and_reports_its_counts():
    with pytest.raises(SolverFailed, match="max_steps"):
        call_checked(jax.jit(lambda p: solve_robertson(p, BDF.replace(max_steps=10))), 0.0)
    solution = jax.jit(lambda p: BDF.solve(robertson, 0.0, 40.0, jnp.array([1.0, 0.0, 0.0]), p))(0.0)
    stats = {name: int(value) for name, value in solution.stats.items()}
    assert stats["num_accepted_steps"] > 50 and stats["num_jacobians"] >= 1
    # Jacobians and factorisations are reused across steps: far fewer than the steps.
    assert stats["num_jacobians"] < stats["num_accepted_steps"] / 5
    assert stats["num_factorisations"] < stats["num_accepted_steps"]


@pytest.mark.parametrize("differentiation", ["reverse", "forward"])
def test_bdf_derivatives_in_the_start_and_end_times_are_the_solutions(differentiation):
    """y' = -k y / t from y(t0) = y0: y(t1) = y0 (t0 / t1)^k, so d y(t1) / d t1 = -k y(t1) / t1
    and d y(t1) / d t0 = k y(t1) / t0 (the solve holds its times fixed; these come from f)."""
    settings = BDF.replace(differentiation=differentiation)

    def end(times):
        return settings.solve(lambda t, y, args: -1.5 * y / t, times[0], times[1], jnp.array([2.0])).ys[-1, 0]

    times = jnp.array([1.0, 3.0])
    derivative = jax.jacrev if differentiation == "reverse" else jax.jacfwd
    exact = 2.0 * (1.0 / 3.0) ** 1.5
    np.testing.assert_allclose(np.asarray(jax.jit(derivative(end))(times)), [1.5 * exact / 1.0, -1.5 * exact / 3.0],
                               rtol=1e-7)


def test_bdf_vmapped_gradients_stay_finite_for_members_that_finish_first_or_never_start():
    """A batch whose members end at different times, one at its start (t1 = t0): each member's
    gradient equals its single solve's (the replay runs on past a finished member's last step,
    at its start, where f = -k y / t is finite and a never-written record row's t = 0 is not)."""
    def end(log_k, t1):
        return BDF.solve(lambda t, y, args: -jnp.exp(args) * y / t, 1.0, t1, jnp.array([2.0]), log_k).ys[-1, 0]

    gradient = jax.jit(jax.grad(end))
    t1 = jnp.array([2.0, 30.0, 1.0])
    batched = np.asarray(jax.jit(jax.vmap(jax.grad(end)))(jnp.zeros(3), t1))
    single = np.array([float(gradient(0.0, t)) for t in t1])
    assert np.all(np.isfinite(batched))
    np.testing.assert_allclose(batched, single, rtol=1e-10, atol=1e-14)
    np.testing.assert_allclose(single, [-2.0 * np.log(t) * t ** -1.0 for t in np.asarray(t1)], rtol=1e-7, atol=1e-14)


def test_bdf_with_traced_times_out_of_order_raises_and_integer_states_are_promoted():
    def end(t1):
        return BDF.solve(lambda t, y, args: -y, 1.0, t1, jnp.array([2.0])).ys[-1]

    with pytest.raises(Exception, match="t1 must exceed t0"):
        jax.block_until_ready(jax.jit(end)(0.5))
    ys = BDF.solve(lambda t, y, args: -y, 0.0, 1.0, jnp.array([2, 1])).ys[-1]
    np.testing.assert_allclose(np.asarray(ys), np.array([2.0, 1.0]) * np.exp(-1.0), rtol=1e-8)
