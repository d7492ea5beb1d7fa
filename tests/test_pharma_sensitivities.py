"""ICH Q8 sensitivities of the pharma chain: every dCQA/dCPP and every kinetic and physical
sensitivity from the reverse passes against central differences, forward tangents against reverse
passes, and the integrator against SciPy's Radau at tight tolerance."""

import functools

import numpy as np
import pytest

import snapo_ode
from chemistry.pharma import (
    BUMP_SOLVER, CHAIN_SOLVER, CPP_NAMES, PHARMA_EFFECTS, REFERENCE, TEMPERATURE_SCALE, PharmaChain, cqa_function, input_names,
    input_scales, jacobian_function, make_cpps, parameter_names, r1_outlet, scipy_r1, sensitivities)
from chemistry.pharma._sensitivities import resolve_mode

# Tight enough that the solver's error is far below the 1e-5 agreement asked of the sensitivities
# (the CLI's bump solver: one process compiles each program once). The tight-tolerance reference
# is checked through the CLI's reference_rel_error in tests/test_pharma_cli.py.
CHECK = BUMP_SOLVER


@pytest.fixture(scope="module")
def chain():
    return PharmaChain(solver=CHECK)


@pytest.fixture(scope="module")
def inputs(chain):
    return chain.inputs(make_cpps())


@pytest.fixture(scope="module")
def adjoint(chain, inputs):
    return sensitivities(chain, inputs, repeats=1)[0]


@pytest.fixture(scope="module")
def bumped(chain, inputs):
    """Richardson central differences of every input, named like the adjoint's columns."""
    matrix = snapo_ode.central_differences(
        cqa_function(chain), inputs, relative_step=1e-3, step_floor=0.0, richardson=True,
        call=functools.partial(snapo_ode.call_checked, what="the bumped chains"))
    return dict(zip(input_names(chain), matrix.T, strict=True))


def columns(bumped, names):
    return np.stack([bumped[name] for name in names], axis=1)


def test_default_mode_is_reverse_for_all_parameters_and_forward_for_the_cpps_alone(adjoint):
    assert adjoint.mode == "reverse"  # 5 outputs, 47 inputs: 5 passes
    assert resolve_mode("auto", len(CPP_NAMES)) == "forward"  # 5 outputs, 4 inputs: 4 tangents
    assert adjoint.matrix.shape == (5, 47) and adjoint.columns(CPP_NAMES).shape == (5, 4)


def test_all_20_cqa_cpp_sensitivities_match_central_differences(adjoint, bumped):
    ours, theirs = np.asarray(adjoint.columns(CPP_NAMES)), columns(bumped, CPP_NAMES)
    assert snapo_ode.agreement(ours, theirs).max_rel_diff <= 1e-5
    # The one structural zero: the crystal size does not depend on the dryer.
    assert adjoint.named(["dryer_temperature"])["mean_crystal_size"]["dryer_temperature"] == 0.0
    assert abs(bumped["dryer_temperature"][3]) < 1e-9
    assert np.count_nonzero(ours) == 19


def test_every_kinetic_and_physical_sensitivity_matches_central_differences(chain, inputs, adjoint, bumped):
    names = parameter_names(chain)
    assert sum("[" in name for name in names) == 15  # log-multiplier, b and Ea/R of 5 reactions
    scales = input_scales(inputs)[len(CPP_NAMES):]
    ours = np.asarray(adjoint.columns(names))
    result = snapo_ode.agreement(ours, columns(bumped, names), scales=scales, zero=1e-12)
    assert result.max_rel_diff <= 1e-5
    assert np.count_nonzero(ours) >= 150
    # Where the reverse pass gives exactly zero, the bumps see at most round-off.
    assert result.at_structural_zeros <= 1e-9


def test_normalised_sensitivities_are_log_derivatives(chain, adjoint, inputs):
    from chemistry.pharma._sensitivities import normalized

    cpps = np.array([float(getattr(inputs.cpps, name)) for name in CPP_NAMES])
    np.testing.assert_allclose(normalized(adjoint, inputs, CPP_NAMES),
                               np.asarray(adjoint.columns(CPP_NAMES)) * cpps / np.asarray(adjoint.values)[:, None],
                               rtol=1e-14)


def test_forward_tangents_give_the_reverse_passes_sensitivities(chain, inputs, adjoint):
    values, matrix = jacobian_function(chain, False, "forward")(inputs)
    # The same solve traced through jvp and through vjp: XLA may fuse and order the sums
    # differently, so the values agree to round-off of the solve (1.1e-13 seen once), not bit for bit.
    np.testing.assert_allclose(values, adjoint.values, rtol=1e-12)
    assert snapo_ode.agreement(np.asarray(matrix), np.asarray(adjoint.columns(CPP_NAMES))).max_rel_diff <= 1e-9


@pytest.mark.parametrize("without", [(), ("energy_balance",)])
def test_r1_agrees_with_scipy_radau_at_tight_tolerance(without):
    cpps = make_cpps(r1_temperature=320.0, r1_residence_time=38.0)
    chain = PharmaChain(scene=PHARMA_EFFECTS.scene(without=without),
                        solver=CHAIN_SOLVER.replace(rtol=1e-12, atol=1e-14, max_steps=20000))
    physical = chain.inputs(cpps).physical
    reference = scipy_r1(chain, cpps, physical)
    outlet = r1_outlet(chain, cpps, physical)
    ours = np.asarray(outlet.amounts)
    if not without:
        ours = np.append(ours, float(outlet.temperature) / TEMPERATURE_SCALE)
    significant = np.abs(reference) > 1e-12
    assert np.max(np.abs(ours - reference)[significant] / np.abs(reference[significant])) <= 1e-10
    assert snapo_ode.max_relative_difference(ours, reference, floor=1e-10) <= 1e-9


def test_the_reference_agrees_with_the_bdf_on_the_stiff_units(inputs):
    """The study's reference (Kvaerno5 on every unit, rtol 1e-12) against the BDF on R1 and R2
    at the same tolerance: two methods of different families on the stiff units. Measured
    9.6e-10 (entrywise, the crystal size's and the residual solvent's small entries in R1's CPPs;
    against both at rtol 1e-13 Kvaerno5 is off by 4.3e-10, the BDF by 1.1e-9), far below the
    errors the study reports (~1e-7)."""
    ours, theirs = (np.asarray(jacobian_function(PharmaChain(solver=solver), False, "forward")(inputs)[1])
                    for solver in (REFERENCE, REFERENCE.replace(solver="bdf")))
    assert snapo_ode.solver_name(REFERENCE.solver) == snapo_ode.solver_name(REFERENCE.nonstiff_solver) == "kvaerno5"
    assert snapo_ode.agreement(ours, theirs).max_rel_diff <= 5e-9


@pytest.mark.parametrize("solver", [CHAIN_SOLVER, REFERENCE, BUMP_SOLVER], ids=["study", "reference", "bumps"])
@pytest.mark.parametrize("mode", ["reverse", "forward"])
def test_every_program_of_the_study_can_be_kept_on_disk(solver, mode):
    # A chain whose description differs between processes is traced again by every process (the
    # reference's Kvaerno5 root finder holds a decorated function: 10 s a run until it was keyed).
    settings = solver.replace(differentiation=mode)
    assert snapo_ode.describe(PharmaChain(solver=settings), values=True) == snapo_ode.describe(
        PharmaChain(solver=settings), values=True)
