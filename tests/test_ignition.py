"""Constant-volume adiabatic ignition and its sensitivities against Cantera's ReactorNet, and our
reverse-pass sensitivities against central bumps of our own solve."""

from pathlib import Path

import cantera
import equinox as eqx
import jax.numpy as jnp
import numpy as np
import pytest
from snapo_ode import Rodas5, SolverFailed

from chemistry import (
    IGNITION_CASES,
    REACTOR_SOLVER,
    Mechanism,
    cantera_ignition,
    cantera_sensitivities,
    compare_sensitivities,
    final_temperature,
    initial_concentrations,
    solve_ignition,
    temperature_sensitivities,
)

CANTERA_DATA = Path(cantera.__file__).parent / "data"
# The reactors' Rodas5 with its stages in a loop: the same method as their unrolled stages (tested in
# test_core_rosenbrock), whose gradient compiles in about half the time.
BEFORE_IGNITION = REACTOR_SOLVER.replace(solver=Rodas5(), rtol=1e-10, atol=1e-14)


@pytest.mark.parametrize("name", ["h2o2", "gri30"])
def test_ignition_delay_and_temperature_history_match_cantera(name):
    path, case = CANTERA_DATA / f"{name}.yaml", IGNITION_CASES[name]
    times = np.linspace(0.0, case.end_time, 51)
    reference = cantera_ignition(path, case, times)
    ours = solve_ignition(Mechanism.from_yaml(path), initial_concentrations(path, case), case, times)
    assert case.end_time / 10 < reference.delay < case.end_time / 2
    assert abs(ours.delay / reference.delay - 1) < 1e-4
    assert np.max(np.abs(ours.temperature / reference.temperature - 1)) < 1e-3
    assert ours.temperature[-1] > case.temperature + 1000.0


def test_no_ignition_before_the_last_time_raises_with_advice():
    path, case = CANTERA_DATA / "h2o2.yaml", IGNITION_CASES["h2o2"]
    early = np.linspace(0.0, case.end_time / 100, 51)  # the delay is ~0.3 ms of 1 ms
    with pytest.raises(SolverFailed, match="never reached T0 \\+ 400 K before the last saved time"):
        solve_ignition(Mechanism.from_yaml(path), initial_concentrations(path, case), case, early)


# gri30's Rodas5 gradient compiles for ~50 s on CI's 2 cores: under `make test-slow`; h2o2 runs the
# same code. The BDF's (`REACTOR_BDF_SOLVER`, one reverse pass through its replay) compiles in ~11 s.
@pytest.fixture(scope="module", params=["h2o2", "h2o2-bdf", pytest.param("gri30", marks=pytest.mark.slow),
                                        "gri30-bdf"])
def sensitivities(request):
    name, _, solver = request.param.partition("-")
    # The BDF at tighter tolerances: central bumps of an adaptive solve cross its step decisions, and
    # at rtol 1e-10 / atol 1e-14 (T within 6e-7 of converged) that noise reached 1.2e-5 relative.
    settings = BEFORE_IGNITION.replace(solver=solver, rtol=1e-12, atol=1e-16) if solver else BEFORE_IGNITION
    path, case = CANTERA_DATA / f"{name}.yaml", IGNITION_CASES[name]
    mechanism = Mechanism.from_yaml(path)
    concentrations = jnp.asarray(initial_concentrations(path, case))
    ours, temperature = temperature_sensitivities(mechanism, concentrations, case, case.sensitivity_time, settings)
    return name, mechanism, concentrations, case, np.asarray(ours), float(temperature), settings


def test_ten_largest_temperature_sensitivities_match_cantera_in_value_and_rank(sensitivities):
    name, _, _, case, ours, temperature, _ = sensitivities
    reference, reference_temperature = cantera_sensitivities(CANTERA_DATA / f"{name}.yaml", case,
                                                             case.sensitivity_time)
    assert abs(temperature / reference_temperature - 1) < 1e-6
    comparison = compare_sensitivities(ours, reference, top=10)
    assert comparison.max_relative_difference < 1e-3
    assert comparison.same_ranking
    assert abs(comparison.cantera[0]) > 0.1  # late in the induction: sensitivities are large


def test_reverse_pass_matches_central_bumps_of_our_own_solve(sensitivities):
    _, mechanism, concentrations, case, ours, temperature, settings = sensitivities
    solve = eqx.filter_jit(lambda log_multiplier: final_temperature(
        log_multiplier, mechanism, concentrations, case, case.sensitivity_time, settings))
    step, zero = 1e-5, jnp.zeros(mechanism.n_reactions)
    for i in np.argsort(-np.abs(ours))[[0, 1, 4, 9]]:
        bump = zero.at[i].set(step)
        central = float(solve(bump) - solve(-bump)) / (2 * step) / temperature
        assert abs(central - ours[i]) < 1e-5 * max(abs(ours[i]), 1e-3), (i, central, ours[i])
