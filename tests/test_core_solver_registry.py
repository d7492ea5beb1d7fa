"""Solvers as objects, chosen by name only at the edge: a new solver is one class plus its
registration, and from then on it is a name like the built-in ones (settings, JSON, CLI flags);
each object carries only its own options; a failure is a `SolveResult` with advice."""

import argparse

import diffrax
import jax
import jax.numpy as jnp
import numpy as np
import pytest
from snapo_ode import (
    BDF, InputError, Rodas5, SolverFailed, SolveResult, SolverSettings, call_checked, register_solver,
    solver_from_name, solver_names, unregister_solver)
from snapo_ode._solver.host import AbstractHostSolver


class ScipyRK45(AbstractHostSolver):
    """A solver added the way the family's README says: one class (here SciPy's explicit RK45 on
    the host) and one `register_solver` call."""

    def integrate(self, field, jacobian, t0, ts, y0, rtol, atol, max_steps):
        from scipy.integrate import solve_ivp

        solved = solve_ivp(field, (t0, ts[-1]), y0, method="RK45", t_eval=ts, rtol=rtol, atol=atol)
        return solved.y.T if solved.success else np.full((ts.size, y0.size), np.nan)


@pytest.fixture
def rk45():
    register_solver("scipy-rk45", ScipyRK45, stiff=False)
    yield "scipy-rk45"
    unregister_solver("scipy-rk45")


def test_a_registered_solver_is_a_name_like_the_built_in_ones(rk45):
    assert rk45 in solver_names(stiff=False) and rk45 not in solver_names(stiff=True)
    settings = SolverSettings(solver=rk45, rtol=1e-10, atol=1e-12)
    assert isinstance(settings.solver, ScipyRK45)
    decay = jax.jit(lambda y0: settings.solve(lambda t, y, args: -2.0 * y, 0.0, 1.5, y0).ys[-1])
    assert float(call_checked(decay, jnp.array(3.0))) == pytest.approx(3.0 * np.exp(-3.0), rel=1e-8)
    described = settings.as_dict()
    assert described["solver"] == rk45 and described["solver_options"] == {}
    assert described["step_controller"].startswith("ScipyRK45's own step control")
    # The CLI edge: the pharma verb's --solver takes the new name as it takes "rodas5".
    from chemistry.pharma._cli import chain_from_args
    from chemistry.pharma import CPP_RANGES

    args = argparse.Namespace(rtol=1e-8, atol=1e-10, solver=rk45, nonstiff_solver="tsit5", without=[], process=None,
                              settings=[], **{spec.name: spec.nominal for spec in CPP_RANGES})
    chain, _ = chain_from_args(args)
    assert isinstance(chain.solver.solver, ScipyRK45)


def test_an_unknown_name_is_refused_listing_the_registered_ones(rk45):
    with pytest.raises(InputError, match=r"solver = 'rk45' is not one of: .*'scipy-rk45'"):
        solver_from_name("rk45")
    with pytest.raises(InputError, match="nonstiff_solver = 'Tsit5' is not one of"):
        SolverSettings(nonstiff_solver="Tsit5")
    with pytest.raises(InputError, match="lower case"):
        register_solver("My Solver", ScipyRK45, stiff=False)


def test_each_solver_object_carries_only_its_own_options():
    settings = SolverSettings(solver=Rodas5(unroll_stages=True))
    assert settings.as_dict()["solver_options"] == {"unroll_stages": True}
    chord = diffrax.Kvaerno5(root_finder=diffrax.VeryChord(rtol=1e-6, atol=1e-9, kappa=0.5))
    options = settings.replace(solver=chord).as_dict()["solver_options"]
    assert "kappa=0.5" in options["root_finder"] and "unroll_stages" not in options
    # A name gives the object with its defaults: options do not travel between solvers.
    assert settings.replace(solver="rodas5").solver == Rodas5()
    assert SolverSettings(solver="bdf").solver == BDF()


def test_a_failure_is_a_result_with_its_advice():
    settings = SolverSettings(solver="bdf", rtol=1e-8, atol=1e-10, max_steps=50)
    solve = jax.jit(lambda y0: settings.solve(lambda t, y, args: -1e3 * (y - jnp.cos(t)), 0.0, 10.0, y0).ys[-1])
    with pytest.raises(SolverFailed, match="max_steps"):
        call_checked(solve, jnp.array(0.0))
    assert SolveResult[SolveResult.max_steps_reached].startswith("the ODE solve reached max_steps before t1: raise")
    assert SolveResult[SolveResult.failed].startswith("the ODE solve failed")
