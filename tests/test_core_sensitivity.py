"""One reverse pass, vmapped Jacobians in both modes, and both bump-and-revalue flavours,
against closed-form derivatives."""

import jax.numpy as jnp
import numpy as np
import pytest

import snapo_ode


def objective(inputs):
    a, b = inputs["a"], inputs["b"]
    return jnp.sum(jnp.exp(0.1 * a) * a**2) + b * a[0]


def analytic(inputs):
    a, b = inputs["a"], inputs["b"]
    da = jnp.exp(0.1 * a) * (0.1 * a**2 + 2 * a)
    return {"a": da.at[0].add(b), "b": a[0]}


INPUTS = {"a": jnp.linspace(-2.0, 3.0, 7), "b": jnp.array(1.5)}


def test_value_and_sensitivities_one_reverse_pass():
    value, grad = snapo_ode.value_and_sensitivities(objective, INPUTS)
    assert float(value) == pytest.approx(float(objective(INPUTS)), rel=1e-15)
    expected = analytic(INPUTS)
    np.testing.assert_allclose(grad["a"], expected["a"], rtol=1e-13)
    np.testing.assert_allclose(grad["b"], expected["b"], rtol=1e-13)


@pytest.mark.parametrize("batched", [True, False])
def test_central_bumps_agree_with_the_analytic_gradient(batched):
    bumped = snapo_ode.bump_and_revalue(objective, INPUTS, batched=batched)
    assert snapo_ode.max_relative_difference(bumped, analytic(INPUTS)) < 1e-8


def test_chunked_bumps_equal_fully_vmapped():
    full = snapo_ode.bump_and_revalue(objective, INPUTS)
    chunked = snapo_ode.bump_and_revalue(objective, INPUTS, batch_size=3)
    np.testing.assert_allclose(chunked["a"], full["a"], rtol=1e-14)


def test_bump_a_selected_subtree_only():
    bumped = snapo_ode.bump_and_revalue(objective, INPUTS, select=lambda p: p["a"])
    np.testing.assert_allclose(bumped, analytic(INPUTS)["a"], rtol=1e-8)


@pytest.mark.parametrize("mode", ["reverse", "forward"])
def test_jacobian_modes_agree_with_each_other_and_closed_form(mode):
    def outputs(inputs):
        return jnp.stack([objective(inputs), inputs["b"] ** 2, jnp.sum(inputs["a"])])

    jac = snapo_ode.jacobian(outputs, INPUTS, mode=mode)
    assert jac.mode == mode and jac.matrix.shape == (3, 8)
    np.testing.assert_allclose(jac.values, outputs(INPUTS), rtol=1e-15)
    np.testing.assert_allclose(jac.row(0)["a"], analytic(INPUTS)["a"], rtol=1e-13)
    np.testing.assert_allclose(jac.row(1)["b"], 2 * INPUTS["b"], rtol=1e-15)
    np.testing.assert_allclose(jac.row(2)["a"], jnp.ones(7), rtol=0)


def test_auto_mode_picks_the_fewer_passes():
    assert snapo_ode.jacobian(lambda p: jnp.stack([objective(p)] * 2), INPUTS).mode == "reverse"
    assert snapo_ode.jacobian(lambda b: jnp.stack([b, b**2, b**3]), jnp.array(2.0)).mode == "forward"
    assert snapo_ode.choose_mode(n_outputs=5, n_inputs=4) == "forward"


def test_max_relative_difference_uses_a_floor_for_near_zero_entries():
    assert snapo_ode.max_relative_difference([1.0, 1e-20], [1.0, 0.0]) < 1e-11
    assert snapo_ode.max_relative_difference([1.1, 0.0], [1.0, 0.0]) == pytest.approx(0.1)


def test_compare_with_bumps_reports_agreement_and_timings():
    comparison = snapo_ode.compare_with_bumps(objective, INPUTS, select=lambda p: p["a"], repeats=1,
                                              sequential=True, forward_mode=True)
    np.testing.assert_allclose(comparison.adjoint["a"], analytic(INPUTS)["a"], rtol=1e-13)
    np.testing.assert_allclose(comparison.bumped, analytic(INPUTS)["a"], rtol=1e-8)
    assert comparison.max_rel_diff < 1e-8 and comparison.forward_mode_agreement.max_rel_diff < 1e-13
    assert float(comparison.value) == pytest.approx(float(objective(INPUTS)), rel=1e-15)
    assert comparison.speedup == pytest.approx(comparison.bump_seconds / comparison.adjoint_seconds)
    assert comparison.sequential_seconds > 0 and comparison.forward_mode_seconds > 0


def test_untimed_bumps_run_once_and_report_no_timing():
    calls = []

    def counted(program, *args):
        calls.append(program)
        return program(*args)

    comparison = snapo_ode.compare_with_bumps(objective, INPUTS, select=lambda p: p["a"], repeats=1, bump_repeats=0,
                                              call=counted)
    np.testing.assert_allclose(comparison.bumped, analytic(INPUTS)["a"], rtol=1e-8)
    assert comparison.max_rel_diff < 1e-8
    assert comparison.bump_seconds is None and comparison.bump_compile_seconds is None and comparison.speedup is None
    assert len(calls) == 3  # the adjoint twice (a first call, one timed), the bumps once


def test_vector_outputs_richardson_differences_and_named_jacobian():
    def outputs(inputs):
        return jnp.stack([objective(inputs), jnp.sin(inputs["b"]) * 1e-6, jnp.sum(inputs["a"])])

    comparison = snapo_ode.compare_with_bumps(outputs, INPUTS, mode="forward", richardson=True, relative_step=1e-3, step_floor=0.0,
                                              zero=1e-12, repeats=1)
    jac = snapo_ode.jacobian(outputs, INPUTS, output_names=("objective", "tiny", "sum"))
    np.testing.assert_allclose(comparison.adjoint, jac.matrix, rtol=1e-13)
    # Each row is compared at its own scale: the 1e-6 row is not swamped by the others.
    assert comparison.max_rel_diff < 1e-9
    assert comparison.agreement.at_structural_zeros < 1e-9
    assert jac.input_names == tuple(f"a[{i}]" for i in range(7)) + ("b",)
    assert jac.named(["b"])["tiny"]["b"] == pytest.approx(1e-6 * np.cos(1.5), rel=1e-13)
    np.testing.assert_allclose(jac.columns(["a[0]", "b"])[0], [analytic(INPUTS)["a"][0], INPUTS["a"][0]], rtol=1e-13)
    with pytest.raises(snapo_ode.InputError, match="no input named 'c'"):
        jac.columns(["c"])


def test_agreement_scales_and_structural_zeros():
    estimate = np.array([[2.0, 0.0, 1e-3], [4.0, 1.0, 0.0]])
    reference = np.array([[2.0, 1e-14, 1.1e-3], [4.0, 1.0, 3e-13]])
    result = snapo_ode.agreement(estimate, reference, zero=1e-12)
    assert result.max_rel_diff == pytest.approx(0.1 / 1.1, rel=1e-12)
    assert result.at_structural_zeros == pytest.approx(3e-13 / 4.0, rel=1e-12)
    scaled = snapo_ode.agreement(estimate, reference, scales=np.array([1.0, 1.0, 1e6]))
    assert scaled.normwise == pytest.approx(100.0 / 1100.0, rel=1e-12)


def test_input_names_follow_the_flat_order():
    assert snapo_ode.input_names({"b": jnp.zeros((2, 1)), "a": jnp.array(1.0), "n": 3}) == ["a", "b[0][0]", "b[1][0]"]


def test_check_count_refuses_fractions_and_bools():
    assert snapo_ode.check_count("paths", 3) == 3
    for bad in (0, 2.5, True, "4"):
        with pytest.raises(snapo_ode.InputError, match="paths"):
            snapo_ode.check_count("paths", bad)
