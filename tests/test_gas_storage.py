"""Gas storage: the LP against hand-solved cases, the trained policy against the LP on three
facility/curve pairs, every adjoint sensitivity against central bumps, effects, bad input."""

import json

import jax
import jax.numpy as jnp
import numpy as np
import pytest

import snapo_ode
from finance import gas_storage as gs
from finance.gas_storage import CASES, StudySettings, constraint_violation, run_study
from finance.gas_storage._cases import FLAT_RATCHET as FLAT

def simple_facility(**overrides):
    facility = dict(capacity=20.0, initial_inventory=0.0, terminal_inventory_min=0.0, max_injection=10.0,
                    max_withdrawal=10.0, injection_ratchet=FLAT, withdrawal_ratchet=FLAT, fuel_loss=0.0,
                    injection_cost=0.0, withdrawal_cost=0.0, rate=0.0)
    facility.update(overrides)
    return facility


def test_lp_hand_solved_spread():
    # Buy 10 + 10 at 1, sell 10 + 10 at 3.
    inputs = gs.make_inputs(simple_facility(), [1.0, 1.0, 3.0, 3.0])
    lp = gs.solve_intrinsic(inputs, gs.deterministic_scene())
    assert lp.method == "LP"
    assert lp.value == pytest.approx(40.0, abs=1e-9)
    np.testing.assert_allclose(lp.inventory, [0, 10, 20, 10, 0], atol=1e-9)
    np.testing.assert_allclose(lp.deltas, [-10, -10, 10, 10], atol=1e-9)


def test_lp_hand_solved_with_fuel_costs_discounting_and_ratchet():
    # Injection halves above half full: days 0-1 inject 10 then 5 (fill 10 -> 15).
    facility = simple_facility(injection_ratchet=[[0.0, 1.0], [0.5, 1.0], [0.5000001, 0.5], [1.0, 0.5]],
                               fuel_loss=0.1, injection_cost=0.1, withdrawal_cost=0.2, rate=0.0)
    inputs = gs.make_inputs(facility, [1.0, 1.0, 4.0, 4.0])
    lp = gs.solve_intrinsic(inputs, gs.deterministic_scene())
    # inj0 = 10 -> V = 9; inj1 = 10 * g(9/20 = 0.45) = 10 -> V = 18; then withdraw 10 and 8.
    expected = -1.1 * 20 + 3.8 * 18
    assert lp.value == pytest.approx(expected, rel=1e-9)


def test_milp_for_non_concave_ratchet_lies_between_a_restriction_and_a_relaxation():
    dip = [[0.0, 1.0], [0.4, 0.3], [1.0, 1.0]]  # convex dip: not concave, so a MILP
    curve = 3 + np.sin(np.arange(60) / 60 * 4 * np.pi)
    base = dict(gs.sample_facility(), max_injection=40_000.0, max_withdrawal=60_000.0)
    solve = lambda ratchet: gs.solve_intrinsic(  # noqa: E731
        gs.make_inputs(dict(base, injection_ratchet=ratchet), curve), gs.deterministic_scene())
    milp = solve(dip)
    upper = solve([[0.0, 1.0], [1.0, 1.0]])  # a concave table above the dip: a relaxation
    lower = solve([[0.0, 0.3], [1.0, 0.3]])  # a concave table below it: a restriction
    assert milp.method == "MILP" and upper.method == lower.method == "LP"
    assert lower.value < milp.value < upper.value
    inputs = gs.make_inputs(dict(base, injection_ratchet=dip), curve)
    schedule = gs.Schedule(milp.value, milp.injection, milp.withdrawal, milp.inventory)
    assert constraint_violation(schedule, inputs, 1 - base["fuel_loss"]) < 1e-6 * base["capacity"]


# The three pairs the >= 98% claim is tested on; the salt cavern is measured in the benchmark.
TESTED_CASES = ["sample", "peaking_winter_spike", "depleted_field"]


@pytest.mark.parametrize("case", TESTED_CASES)
def test_trained_policy_reaches_98_percent_of_the_lp_and_is_feasible(case):
    facility, curve = CASES[case]()
    inputs = gs.make_inputs(facility, curve)
    result = run_study(inputs, StudySettings(progress=False, repeats=1))
    assert result.hard_to_lp_ratio >= 0.98, result.hard_to_lp_ratio
    assert result.value_hard <= result.intrinsic_lp * (1 + 1e-9)
    assert result.max_constraint_violation <= 1e-6 * facility["capacity"]


@pytest.fixture(scope="module")
def trained_deterministic():
    inputs = gs.make_inputs(gs.sample_facility(), gs.sample_curve())
    scene = gs.deterministic_scene()
    policy = gs.make_policy(scene, inputs, key=jax.random.key(0))
    loss = lambda p: (-gs.expected_value(p, inputs, scene, sharpness=200.0) / 3e6, {})  # noqa: E731
    return snapo_ode.train(loss, policy, steps=300, progress=False).params, inputs, scene


def test_every_adjoint_sensitivity_equals_central_bumps(trained_deterministic):
    policy, inputs, scene = trained_deterministic
    value = lambda i: gs.expected_value(policy, i, scene, sharpness=200.0)  # noqa: E731
    _, adjoint = snapo_ode.value_and_sensitivities(value, inputs)
    # The value is linear in the forward curve at a fixed policy, so a wide step is exact.
    bumped_curve = snapo_ode.bump_and_revalue(value, inputs, select=lambda i: i.forward_curve, relative_step=1e-2)
    assert snapo_ode.max_relative_difference(adjoint.forward_curve, bumped_curve) <= 1e-6
    bumped = snapo_ode.bump_and_revalue(value, inputs, relative_step=1e-6)
    for field in ("capacity", "initial_inventory", "terminal_inventory_min", "max_injection", "max_withdrawal",
                  "fuel_loss", "injection_cost", "withdrawal_cost", "rate", "injection_ratchet",
                  "withdrawal_ratchet"):
        scale = max(float(jnp.max(jnp.abs(getattr(bumped, field)))), 1e-8 * float(value(inputs)))
        error = float(jnp.max(jnp.abs(getattr(adjoint, field) - getattr(bumped, field)))) / scale
        assert error <= 1e-6, (field, error)


def test_deterministic_deltas_are_discounted_net_withdrawals(trained_deterministic):
    policy, inputs, scene = trained_deterministic
    run = gs.simulate(policy, inputs, scene, sharpness=200.0)
    _, adjoint = snapo_ode.value_and_sensitivities(lambda i: gs.expected_value(policy, i, scene, sharpness=200.0),
                                                   inputs)
    discount = jnp.exp(-inputs.rate * jnp.arange(365) / 365)
    np.testing.assert_allclose(adjoint.forward_curve, discount * (run.withdrawal - run.injection), rtol=1e-10,
                               atol=1e-8)


def test_stochastic_value_beats_intrinsic_and_deltas_match_bumps():
    inputs = gs.make_inputs(gs.sample_facility(), gs.sample_curve(), volatility=0.6, mean_reversion=3.0)
    settings = StudySettings(stochastic=True, paths=100, train_paths=64, train_steps=150, progress=False,
                             repeats=1, bump=True)
    result = run_study(inputs, settings).to_json()
    assert result["value_hard"] >= result["intrinsic_lp"] - 2 * result["value_hard_se"]
    # Same random numbers in both. The policy reacts to the spot level, so the value is not
    # linear in the curve and the central difference carries a truncation error of about 3e-4
    # in absolute terms: 1e-8 of the largest delta, more for the smallest deltas.
    assert result["max_diff_over_max_delta"] <= 1e-6
    assert result["max_rel_diff"] <= 1e-4
    assert len(result["deltas"]) == 365


@pytest.mark.parametrize("effect, neutral", [("fuel_loss", dict(fuel_loss=0.0)),
                                             ("costs", dict(injection_cost=0.0, withdrawal_cost=0.0)),
                                             ("discounting", dict(rate=0.0)),
                                             ("ratchets", dict(injection_ratchet=FLAT, withdrawal_ratchet=FLAT))])
def test_absent_effect_is_untraced_and_matches_neutral_parameters(effect, neutral):
    inputs = gs.make_inputs(dict(gs.sample_facility(), **neutral), gs.sample_curve())
    full = gs.deterministic_scene()
    reduced = gs.GAS_EFFECTS.scene(without=["stochastic_spot", effect])
    policy = gs.make_policy(full, inputs, key=jax.random.key(1))
    value = lambda scene: gs.expected_value(policy, inputs, scene, sharpness=200.0)  # noqa: E731
    assert snapo_ode.count_operations(value, reduced) < snapo_ode.count_operations(value, full)
    np.testing.assert_allclose(value(reduced), value(full), rtol=1e-12)


@pytest.mark.parametrize("change, message", [
    (dict(capacity=0.0), r"capacity = 0.0 is outside the allowed range \(0, 1e\+12\]"),
    (dict(initial_inventory=2e6), r"initial_inventory = 2000000.0 is outside the allowed range \[0, 1e\+06\]"),
    (dict(injection_ratchet=[[0.0, 1.0], [0.5, 1.0], [0.4, 1.0], [1.0, 1.0]]), "must be strictly increasing"),
    (dict(injection_ratchet=[[0.0, 1.0]]), "at least two rows"),
    (dict(withdrawal_ratchet=[[0.1, 1.0], [1.0, 1.0]]), "must run from 0 to 1"),
    (dict(terminal_inventory_min=1e6, initial_inventory=0.0, max_injection=100.0), "cannot be reached"),
    (dict(fuel_loss=float("nan")), "fuel_loss = nan is not a finite number"),
    (dict(bogus=1.0), "unknown: \\['bogus'\\]"),
])
def test_bad_facility_raises_naming_the_field(change, message):
    with pytest.raises(snapo_ode.InputError, match=message):
        gs.make_inputs(dict(gs.sample_facility(), **change), gs.sample_curve())


def test_bad_curve_raises_naming_the_entry(tmp_path):
    curve = gs.sample_curve().copy()
    curve[10] = -1.0  # a negative price is a price (gas and power markets see them): accepted
    assert float(gs.make_inputs(gs.sample_facility(), curve).forward_curve[10]) == -1.0
    curve[10] = np.nan
    with pytest.raises(snapo_ode.InputError, match=r"\[10\] = nan is not a finite number"):
        gs.make_inputs(gs.sample_facility(), curve)
    path = tmp_path / "curve.csv"
    path.write_text("date,price\n0,1.0\n")
    with pytest.raises(snapo_ode.InputError, match="header must be 'day,price'"):
        gs.load_curve(path)


def test_cli_gas_writes_the_documented_json(tmp_path):
    from snapo_ode.cli import main

    out = tmp_path / "gas.json"
    assert main(["gas", "--train-steps", "30", "--bump", "--json", str(out)]) == 0
    result = json.loads(out.read_text())
    assert (tmp_path / "gas.policy.eqx").exists()
    for key in ("value_hard", "value_smooth", "intrinsic_lp", "schedule", "deltas", "parameter_sensitivities",
                "train_seconds", "compile_seconds", "forward_seconds", "gradient_seconds", "bump_seconds",
                "max_rel_diff"):
        assert key in result
    assert set(result["schedule"]) == {"injection", "withdrawal", "inventory"}
    assert len(result["deltas"]) == 365


def test_cli_reports_bad_input_before_compiling(tmp_path, capsys):
    from snapo_ode.cli import main

    facility = tmp_path / "facility.json"
    facility.write_text(json.dumps(dict(gs.sample_facility(), capacity=-5)))
    assert main(["gas", "--facility", str(facility), "--json", str(tmp_path / "x.json")]) == 2
    assert "capacity = -5.0 is outside the allowed range" in capsys.readouterr().err
