"""LSMC baseline and the Boogert & de Jong contract: LSMC against the intrinsic LP at zero
volatility, pathwise against the perfect-foresight LP, in sample against out of sample, the hard
constraints of its schedules, bad input, and the CLI comparison at a small size."""

import json

import jax
import numpy as np
import pytest

import snapo_ode
from finance import gas_storage as gs
from finance.gas_storage import (
    BDJ_MEAN_REVERSION, BDJ_VOLATILITY, CASES, constraint_violation, fit_lsmc, inventory_grid, perfect_foresight,
    run_lsmc_policy, spot_prices, value_lsmc)
from finance.gas_storage._cases import BDJ_FEBRUARY, BDJ_JULY


def bdj_inputs(volatility=0.0):
    facility, curve = CASES["bdj"]()
    return gs.make_inputs(facility, curve, volatility=volatility, mean_reversion=BDJ_MEAN_REVERSION)


def prices(inputs, paths, seed):
    return spot_prices(inputs, jax.random.normal(jax.random.key(seed), (paths, inputs.n_days)))[0]


def test_bdj_curve_fits_the_two_quotes_and_intrinsic_is_within_5_percent_of_published():
    facility, curve = CASES["bdj"]()
    assert curve[BDJ_JULY].mean() == pytest.approx(14.88, rel=1e-12)
    assert curve[BDJ_FEBRUARY].mean() == pytest.approx(25.44, rel=1e-12)
    lp = gs.solve_intrinsic(bdj_inputs(), gs.deterministic_scene())
    assert abs(lp.value / 2.7e6 - 1) <= 0.05, lp.value
    # The end-inventory requirement binds: the LP ends at exactly 100,000 MWh.
    assert lp.inventory[-1] == pytest.approx(facility["terminal_inventory_min"], abs=1e-6)
    # B&dJ's units, per day, in the model's per-year units.
    assert BDJ_VOLATILITY["low"] / np.sqrt(365) == pytest.approx(0.0315)
    assert BDJ_MEAN_REVERSION / 365 == pytest.approx(0.05)


def test_lsmc_at_zero_volatility_equals_the_intrinsic_lp_on_an_exact_grid():
    # Rates 2,500 and 7,500 are whole grid steps of 250,000 / 100, so nothing is lost to the grid.
    inputs = bdj_inputs(0.0)
    lp = gs.solve_intrinsic(inputs, gs.deterministic_scene())
    paths = prices(inputs, 4, 0)
    result = value_lsmc(inputs, gs.stochastic_scene(), paths, paths, nodes=101, degree=3)
    assert result["lsmc_in_sample"] == pytest.approx(lp.value, rel=1e-10)
    assert result["lsmc_out_of_sample"] == pytest.approx(lp.value, rel=1e-10)


def test_lsmc_at_zero_volatility_reaches_the_lp_with_every_effect():
    # The sample facility: ratchets, fuel loss, costs, discounting; rates are not whole steps.
    # Decisions among the levels, the ends of the exact feasible interval and holding keep the
    # whole flexibility: the rule reaches the LP (rounding rates down to whole steps lost 3%).
    inputs = gs.make_inputs(gs.sample_facility(), gs.sample_curve())
    scene = gs.stochastic_scene()
    lp = gs.solve_intrinsic(inputs, gs.deterministic_scene())
    for nodes in (101, 1001):
        grid = inventory_grid(inputs, scene, nodes)
        fit = fit_lsmc(inputs, scene, grid, inputs.forward_curve[None], 2)
        schedule = run_lsmc_policy(fit, inputs, scene, grid, inputs.forward_curve[None])
        assert lp.value * (1 - 1e-4) <= float(schedule.value[0]) <= lp.value * (1 + 1e-9), nodes
        # In sample, realised values are interpolated between levels: an estimate, not a policy's value.
        assert float(fit.values[0]) == pytest.approx(lp.value, rel=1e-2)
        assert constraint_violation(schedule, inputs, 1 - float(inputs.fuel_loss)) <= 1e-6 * float(inputs.capacity)


def test_lsmc_is_pathwise_below_perfect_foresight_and_out_of_sample_near_in_sample():
    inputs = bdj_inputs(BDJ_VOLATILITY["high"])
    scene = gs.stochastic_scene()
    fit_paths, eval_paths = prices(inputs, 1000, 1), prices(inputs, 1000, 2)
    grid = inventory_grid(inputs, scene, 101)
    fit = fit_lsmc(inputs, scene, grid, fit_paths, 3)
    schedule = run_lsmc_policy(fit, inputs, scene, grid, eval_paths)
    foresight = perfect_foresight(inputs, scene, eval_paths[:40])
    assert np.all(np.asarray(schedule.value[:40]) <= foresight + 1e-6 * foresight)
    in_sample, out_of_sample = float(fit.values.mean()), float(schedule.value.mean())
    se = float(np.std(schedule.value) / np.sqrt(1000))
    # In sample is biased up (the rule is fitted to those paths), out of sample down (suboptimal rule).
    assert out_of_sample <= in_sample + 3 * se
    assert abs(out_of_sample - in_sample) <= 0.05 * in_sample
    # Optionality: worth more than the intrinsic value.
    assert out_of_sample > gs.solve_intrinsic(inputs, gs.deterministic_scene()).value
    assert constraint_violation(schedule, inputs, 1.0) <= 1e-6 * float(inputs.capacity)


def test_lsmc_honours_ratchets_and_the_terminal_requirement_under_volatility():
    inputs = gs.make_inputs(gs.sample_facility(), gs.sample_curve(), volatility=1.0, mean_reversion=5.0)
    scene = gs.stochastic_scene()
    grid = inventory_grid(inputs, scene, 501)
    fit = fit_lsmc(inputs, scene, grid, prices(inputs, 200, 3), 2)
    schedule = run_lsmc_policy(fit, inputs, scene, grid, prices(inputs, 200, 4))
    assert constraint_violation(schedule, inputs, 1 - float(inputs.fuel_loss)) <= 1e-6 * float(inputs.capacity)
    assert np.all(np.asarray(schedule.inventory[:, -1]) >= float(inputs.terminal_inventory_min) - 1e-6)


def test_split_policy_trades_bang_bang_when_hard_and_smoothly_when_training():
    inputs = bdj_inputs(BDJ_VOLATILITY["high"])
    scene = gs.stochastic_scene()
    policy = gs.make_policy(scene, inputs, key=jax.random.key(3), head="split", spot_scale=0.3)
    shocks = jax.random.normal(jax.random.key(4), (8, inputs.n_days))
    hard = gs.simulate(policy, inputs, scene, sharpness=None, shocks=shocks)
    # Every bound on bdj (rates, capacity, the floor) is a multiple of 2,500 MWh, so is every flow.
    steps = (np.asarray(hard.withdrawal) - np.asarray(hard.injection)) / 2_500
    np.testing.assert_allclose(steps, np.round(steps), atol=1e-9)
    assert constraint_violation(hard, inputs, 1.0) <= 1e-6 * 250_000
    smooth = gs.simulate(policy, inputs, scene, sharpness=200.0, shocks=shocks)
    steps = (np.asarray(smooth.withdrawal) - np.asarray(smooth.injection)) / 2_500
    assert np.max(np.abs(steps - np.round(steps))) > 0.1  # partial trades: differentiable


@pytest.mark.parametrize("nodes, degree, message", [
    (1, 3, r"nodes = 1; allowed: a whole number in \[2, 100000\]"),
    (101, -1, r"degree = -1; allowed: a whole number in \[0, 12\]"),
])
def test_lsmc_bad_input_names_the_field(nodes, degree, message):
    inputs = bdj_inputs(0.2)
    with pytest.raises(snapo_ode.InputError, match=message):
        value_lsmc(inputs, gs.stochastic_scene(), prices(inputs, 4, 0), prices(inputs, 4, 1), nodes=nodes,
                   degree=degree)


def test_cli_gas_lsmc_writes_both_methods_on_the_same_paths(tmp_path):
    from snapo_ode.cli import main

    out = tmp_path / "bdj.json"
    assert main(["gas", "--sample", "bdj", "--stochastic", "--volatility", str(BDJ_VOLATILITY["high"]),
                 "--mean-reversion", str(BDJ_MEAN_REVERSION), "--paths", "64", "--train-paths", "32",
                 "--train-steps", "30", "--split-actions", "--bump", "--lsmc", "--foresight-paths", "16",
                 "--json", str(out)]) == 0
    result = json.loads(out.read_text())
    for key in ("lsmc_in_sample", "lsmc_out_of_sample", "lsmc_se", "snapo_out_of_sample", "snapo_se",
                "perfect_foresight", "lsmc_fit_seconds", "snapo_seconds", "train_seconds", "gradient_seconds"):
        assert np.isfinite(result[key]), key
    assert result["snapo_out_of_sample"] == pytest.approx(result["value_hard"], rel=1e-12)
    assert result["lsmc_out_of_sample"] < result["perfect_foresight"]
    assert result["snapo_out_of_sample"] < result["perfect_foresight"]
    assert result["paths"] == 64 and len(result["deltas"]) == 365
    # The split policy's deltas (one reverse pass) against central bumps with the same random numbers.
    assert result["max_diff_over_max_delta"] <= 1e-6
    assert result["max_constraint_violation"] <= 1e-6 * 250_000


def test_cli_lsmc_without_stochastic_is_refused(tmp_path, capsys):
    from snapo_ode.cli import main

    assert main(["gas", "--sample", "bdj", "--lsmc", "--json", str(tmp_path / "x.json")]) == 2
    assert "--lsmc needs --stochastic" in capsys.readouterr().err


def test_cli_lsmc_on_a_grid_that_cannot_trade_is_refused_before_computing(tmp_path, capsys):
    # Before: the sample facility's 9,900 MMBtu/day injection (after fuel loss) is under the
    # 101-node grid's 10,000 step, the grid DP never moved, and the gap divided by a zero bound.
    from snapo_ode.cli import main

    assert main(["gas", "--stochastic", "--lsmc", "--no-progress", "--json", str(tmp_path / "x.json")]) == 2
    error = capsys.readouterr().err
    assert "lsmc_nodes = 101" in error and "--lsmc-nodes 106" in error and not (tmp_path / "x.json").exists()


def test_a_days_decisions_are_the_brute_force_best_candidate():
    """`level_decisions` (a loop over the candidates keeping the running maximum) against a NumPy
    enumeration of every path, level and feasible candidate (the exact cash of the move plus the
    continuation interpolated there) on a ratcheted facility with fuel, costs and discounting:
    the decided value is the maximum and the credited one is the cash plus `later` at the first
    best candidate, to round-off."""
    from finance.gas_storage._family import facility
    from finance.gas_storage._lsmc import candidate_inventories, level_decisions
    from finance.gas_storage._model import flows_and_cash, inventory_floor, stochastic_scene

    inputs = gs.make_inputs(facility("everything", 3), 3.0 + np.sin(np.arange(20) / 3.0))
    scene = stochastic_scene()
    grid = inventory_grid(inputs, scene, 41)
    rng = np.random.default_rng(4)
    price = rng.uniform(1.0, 6.0, 7)
    continuation = np.cumsum(rng.normal(3.0, 1.0, (7, 41)), axis=1) * float(grid.spacing)
    later = continuation + rng.normal(0.0, 1e3, (7, 41))
    day, floor = 5, inventory_floor(inputs, scene, None)[6]
    credited, decided = level_decisions(inputs, scene, grid, price, day, floor, continuation, later)
    levels = np.asarray(grid.levels)
    positions, valid = (np.asarray(a) for a in candidate_inventories(inputs, scene, grid, levels, floor))
    scale = np.abs(later).max()
    for p in range(7):
        for n, level in enumerate(levels):
            moves = positions[n][valid[n]]
            cash = np.asarray(flows_and_cash(inputs, scene, moves - level, price[p], day, None)[2])
            score = cash + np.interp(moves, levels, continuation[p])
            best = int(np.argmax(score))
            assert decided[p, n] == pytest.approx(score[best], abs=1e-12 * scale)
            assert credited[p, n] == pytest.approx(cash[best] + np.interp(moves[best], levels, later[p]),
                                                   abs=1e-12 * scale)
