"""ICH Q8 sensitivities of the pharma chain: every dCQA/dCPP and every kinetic and physical
sensitivity from the reverse passes against central differences, forward tangents against reverse
passes, and the integrator against SciPy's Radau at tight tolerance."""

import numpy as np
import pytest

import snapo_ode
from chemistry.pharma import CPP_NAMES, PHARMA_EFFECTS, ChainSolver, PharmaChain, make_cpps
from chemistry.pharma._liquid import TEMPERATURE_SCALE
from chemistry.pharma._sensitivities import (
    bump_agreement, central_differences, chain_inputs, input_names, input_scales, jacobian_function, max_rel_diff, relative_errors,
    resolve_mode, sensitivities)
from chemistry.pharma._study import BUMP_SOLVER
from chemistry.pharma._verification import scipy_r1

# Tight enough that the solver's error is far below the 1e-5 agreement asked of the sensitivities
# (the CLI's bump solver: one process compiles each program once). The tight-tolerance reference
# is checked through the CLI's reference_rel_error in tests/test_pharma_cli.py.
CHECK = BUMP_SOLVER


@pytest.fixture(scope="module")
def chain():
    return PharmaChain(solver=CHECK)


@pytest.fixture(scope="module")
def inputs(chain):
    return chain_inputs(chain, make_cpps())


@pytest.fixture(scope="module")
def adjoint(chain, inputs):
    return sensitivities(chain, inputs, repeats=1)


@pytest.fixture(scope="module")
def bumped(chain, inputs):
    return central_differences(chain, inputs, range(len(input_names(chain))))


def test_default_mode_is_reverse_for_all_parameters_and_forward_for_the_cpps_alone(adjoint):
    assert adjoint.mode == "reverse"  # 5 outputs, 47 inputs: 5 passes
    assert resolve_mode("auto", len(CPP_NAMES)) == "forward"  # 5 outputs, 4 inputs: 4 tangents
    assert adjoint.matrix.shape == (5, 4) and adjoint.parameters.shape == (5, 43)


def test_all_20_cqa_cpp_sensitivities_match_central_differences(adjoint, bumped):
    assert max_rel_diff(adjoint.matrix, bumped[:, :4]) <= 1e-5
    # The one structural zero: the crystal size does not depend on the dryer.
    assert adjoint.matrix[3, 3] == 0.0 and abs(bumped[3, 3]) < 1e-9
    assert np.count_nonzero(adjoint.matrix) == 19


def test_every_kinetic_and_physical_sensitivity_matches_central_differences(chain, inputs, adjoint, bumped):
    names = input_names(chain)[4:]
    assert sum("[" in name for name in names) == 15  # log-multiplier, b and Ea/R of 5 reactions
    scales = input_scales(inputs)[4:]
    nonzero, at_zeros = bump_agreement(adjoint.parameters, bumped[:, 4:], scales)
    errors = relative_errors(adjoint.parameters, bumped[:, 4:], scales)
    assert nonzero <= 1e-5, names[int(np.argmax(errors.max(axis=0)))]
    assert np.count_nonzero(adjoint.parameters) >= 150
    # Where the reverse pass gives exactly zero, the bumps see at most round-off.
    assert at_zeros <= 1e-9


def test_normalised_sensitivities_are_log_derivatives(adjoint, inputs):
    cpps = np.array([float(getattr(inputs.cpps, name)) for name in CPP_NAMES])
    np.testing.assert_allclose(adjoint.normalized, adjoint.matrix * cpps / adjoint.cqas[:, None], rtol=1e-14)


def test_forward_tangents_give_the_reverse_passes_sensitivities(chain, inputs, adjoint):
    values, matrix = jacobian_function(chain, False, "forward")(inputs)
    np.testing.assert_allclose(values, adjoint.cqas, rtol=1e-13)
    assert max_rel_diff(np.asarray(matrix), adjoint.matrix) <= 1e-9


@pytest.mark.parametrize("without", [(), ("energy_balance",)])
def test_r1_agrees_with_scipy_radau_at_tight_tolerance(without):
    cpps = make_cpps(r1_temperature=320.0, r1_residence_time=38.0)
    physical = chain_inputs(PharmaChain(), cpps).physical
    chain = PharmaChain(scene=PHARMA_EFFECTS.scene(without=without),
                        solver=ChainSolver(rtol=1e-12, atol=1e-14, max_steps=20000))
    reference = scipy_r1(chain, cpps, physical)
    outlet = chain.run_r1(cpps, chain.rate_parameters, physical)
    ours = np.asarray(outlet.amounts)
    if not without:
        ours = np.append(ours, float(outlet.temperature) / TEMPERATURE_SCALE)
    significant = np.abs(reference) > 1e-12
    assert np.max(np.abs(ours - reference)[significant] / np.abs(reference[significant])) <= 1e-10
    assert snapo_ode.max_relative_difference(ours, reference, floor=1e-10) <= 1e-9
