"""The information-relaxation dual bound and the LSMC pathwise deltas: the exact conditional
means of the penalty's features, the bound against the LSMC and the intrinsic LP at zero
volatility, against any policy (path by path with the penalty, and in the mean) and against
perfect foresight; the one-reverse-pass deltas against central bumps of the refitted valuation."""

import jax
import jax.numpy as jnp
import numpy as np
import pytest

import snapo_ode
from finance import gas_storage as gs
from finance.gas_storage import (
    BDJ_MEAN_REVERSION, BDJ_VOLATILITY, CASES, fit_lsmc, inventory_grid, perfect_foresight, run_lsmc_policy,
    spot_prices)
from finance.gas_storage import _dual as dual
from finance.gas_storage import _lattice as lattice
from finance.gas_storage import _penalty as penalties
from finance.gas_storage._lsmc_deltas import lsmc_bumped_deltas, lsmc_value_and_deltas
from finance.gas_storage._model import spot_factor

BASES = [penalties.SpotPowers(4), penalties.ShockHermite(3), penalties.SpotCalls((0.8, 1.0, 1.25))]


def bdj_inputs(volatility=0.0):
    facility, curve = CASES["bdj"]()
    return gs.make_inputs(facility, curve, volatility=volatility, mean_reversion=BDJ_MEAN_REVERSION)


def small_inputs(volatility, days=40):
    """B&dJ's rates on a 50,000 MWh store over 40 days of its curve (Nov-Dec), 21 nodes."""
    facility, curve = CASES["bdj"]()
    facility = dict(facility, capacity=50_000.0, initial_inventory=20_000.0, terminal_inventory_min=20_000.0)
    return gs.make_inputs(facility, curve[120:120 + days], volatility=volatility, mean_reversion=BDJ_MEAN_REVERSION)


def shocks(inputs, paths, seed):
    return jax.random.normal(jax.random.key(seed), (paths, inputs.n_days))


def test_day_steps_recover_the_shocks_and_features_have_exact_conditional_mean_zero():
    inputs = bdj_inputs(BDJ_VOLATILITY["high"])
    eps = shocks(inputs, 3, 0)
    prices = spot_prices(inputs, eps)[0]
    steps = penalties._day_steps(inputs, prices, jnp.full(inputs.n_days, 0.3))
    # The step from day t to t+1 uses shock t: recovering it checks a, s and Var(X_t) exactly.
    recovered = (steps.log_ratio_next - steps.mean) / steps.step_sd[:, None]
    np.testing.assert_allclose(recovered[:-1], eps.T[:-1], atol=1e-9)
    # Features at three fixed day-t states, averaged over 400,000 draws of the next day's shock.
    draws = jax.random.normal(jax.random.key(1), (400_000,))
    for basis in BASES:
        for mean in (-0.4, 0.0, 0.35):
            step = penalties.DayStep(mean + 0.0945 * draws, jnp.full(draws.shape, mean), jnp.asarray(0.0945),
                                jnp.asarray(True), jnp.asarray(0.3))
            features = np.asarray(basis.innovations(step))
            se = features.std(0) / np.sqrt(draws.size)
            # 1e-12: a far out-of-the-money call that no draw exercises is off by its Black price alone.
            assert np.all(np.abs(features.mean(0)) <= 4.5 * se + 1e-12), (basis, mean, features.mean(0) / se)


@pytest.mark.parametrize("basis", BASES, ids=lambda b: type(b).__name__)
def test_dual_equals_lsmc_and_intrinsic_lp_at_zero_volatility(basis):
    inputs = bdj_inputs(0.0)
    scene = gs.stochastic_scene()
    lp = gs.solve_intrinsic(inputs, gs.deterministic_scene())
    grid = inventory_grid(inputs, scene, 101)
    prices = spot_prices(inputs, shocks(inputs, 4, 0))[0]
    fit = fit_lsmc(inputs, scene, grid, prices, 3)
    penalty = penalties.fit_penalty(fit, inputs, scene, grid, prices, basis, state_degree=2)
    bound = dual.dual_bound(penalty, inputs, scene, grid, prices)
    lsmc = run_lsmc_policy(fit, inputs, scene, grid, prices).value
    assert bound.grid.relaxation == 0.0  # bdj's rates are whole steps: the relaxation is exact
    np.testing.assert_allclose(bound.values, lp.value, rtol=1e-12)
    np.testing.assert_allclose(lsmc, lp.value, rtol=1e-12)


def test_the_relaxed_grid_never_tightens_a_rate_and_is_exact_on_whole_steps():
    scene = gs.stochastic_scene()
    exact = dual.relaxed_grid(bdj_inputs(), scene)
    assert (exact.nodes, exact.relaxation, set(exact.max_in_steps), set(exact.max_out_steps)) == (101, 0.0, {1}, {3})
    inputs = ratchet_inputs(0.0)
    for nodes in (51, 137, 400):
        relaxed = dual.relaxed_grid(inputs, scene, nodes)
        # Every fill inside the two cells beside a level: the relaxed rate is at least the exact one there.
        fill = np.linspace(0, 1, 20_001)
        capacity = float(inputs.capacity)
        level = np.clip(np.rint((fill * capacity - relaxed.first_level) / relaxed.spacing).astype(int), 0,
                        relaxed.nodes - 1)
        kept = 1 - float(inputs.fuel_loss)
        exact_in = kept * float(inputs.max_injection) * np.interp(fill, *np.asarray(inputs.injection_ratchet).T)
        exact_out = float(inputs.max_withdrawal) * np.interp(fill, *np.asarray(inputs.withdrawal_ratchet).T)
        assert np.all(np.asarray(relaxed.max_in_steps)[level] * relaxed.spacing >= exact_in * (1 - 1e-12))
        assert np.all(np.asarray(relaxed.max_out_steps)[level] * relaxed.spacing >= exact_out * (1 - 1e-12))
        assert relaxed.relaxation > 0


def ratchet_inputs(volatility, days=60):
    """A facility with everything that rounds flexibility away on a grid: ratchets in both
    directions, 0.5% fuel loss, costs and a 4% rate, rates that are no whole steps, an initial
    inventory off the grid, on a 60-day winter curve with a weekend discount."""
    day = np.arange(days)
    curve = 3.0 + 0.5 * np.cos(2 * np.pi * (day - 40) / days) - 0.1 * (day % 7 >= 5)
    facility = dict(capacity=500_000.0, initial_inventory=123_457.0, terminal_inventory_min=100_000.0,
                    max_injection=14_000.0, max_withdrawal=23_000.0,
                    injection_ratchet=[[0.0, 1.0], [0.6, 0.9], [1.0, 0.5]],
                    withdrawal_ratchet=[[0.0, 0.4], [0.3, 1.0], [1.0, 1.0]],
                    fuel_loss=0.005, injection_cost=0.01, withdrawal_cost=0.01, rate=0.04)
    return gs.make_inputs(facility, curve, volatility=volatility, mean_reversion=5.0)


def test_on_ratchets_fuel_costs_and_discounting_the_bound_bounds_every_policy_and_lsmc_beats_intrinsic():
    # Before: LSMC's grid rounded rates down (20% below the intrinsic value on such a facility)
    # and the grid's bound bounded grid policies only (it fell below the intrinsic value).
    from finance.gas_storage._certificate import duality_gaps, intrinsic_schedule

    inputs = ratchet_inputs(0.8)
    scene = gs.stochastic_scene()
    lp = gs.solve_intrinsic(inputs, gs.deterministic_scene())
    grid = inventory_grid(inputs, scene, 51)
    eval_shocks = shocks(inputs, 400, 2)
    eval_prices = spot_prices(inputs, eval_shocks)[0]
    fit = fit_lsmc(inputs, scene, grid, spot_prices(inputs, shocks(inputs, 400, 1))[0], 3)
    network = gs.make_policy(scene, inputs, key=jax.random.key(5), spot_scale=0.3)
    policies = {"lsmc": run_lsmc_policy(fit, inputs, scene, grid, eval_prices),
                "network": gs.simulate(network, inputs, scene, sharpness=None, shocks=eval_shocks),
                "intrinsic": intrinsic_schedule(inputs, scene, lp, eval_prices)}
    out = duality_gaps(inputs, scene, grid, eval_shocks, policies, lattice_points=60, dual_nodes=151)
    warnings = out["warnings"]
    assert not any(w.startswith("dual bound not certified") or w.startswith("dual bound ") and "lies below" in w
                   for w in warnings), warnings
    # Only the untrained network is worth less than the intrinsic schedule, and it is said.
    assert [w.split(" ")[0] for w in warnings if "below the intrinsic" in w] == ["network"], warnings
    # The intrinsic schedule's control-variate value is the LP's value up to Monte Carlo error.
    assert abs(out["intrinsic_value_control_variate"] - lp.value) <= 4 * out["intrinsic_value_control_variate_se"]
    for name in ("lsmc", "network", "intrinsic", "lattice"):
        # Path by path (certify checked it; the gap's mean is its share of the bound) ...
        assert out[f"{name}_gap"] >= 0
        # ... and in the mean, above the plain value too.
        value = np.mean(policies[name].value) if name in policies else out["lattice_out_of_sample"]
        assert out["dual_upper_bound"] >= value
    assert out["dual_upper_bound"] >= lp.value
    lsmc = np.asarray(policies["lsmc"].value)
    assert lsmc.mean() >= lp.value - 3 * lsmc.std() / np.sqrt(lsmc.size)
    assert gs.constraint_violation(policies["lsmc"], inputs, 1 - float(inputs.fuel_loss)) <= 1e-6 * 500_000


def test_a_bound_below_a_policy_is_refused_and_a_policy_below_intrinsic_is_warned():
    from finance.gas_storage._certificate import certify

    upper = np.full(100, 10.0) + np.linspace(0, 1, 100)
    fine = {"intrinsic": (upper - 1.0, upper - 1.0)}
    out = {"dual_upper_bound": 10.5, "snapo_gap": 0.1}
    assert certify(dict(out), upper, fine, 0.0) == []
    broken = dict(out)
    warnings = certify(broken, upper, {**fine, "snapo": (upper + 0.5, upper + 0.5)}, 0.0)
    assert "not certified" in warnings[0] and broken["dual_upper_bound"] is None and broken["snapo_gap"] is None
    low = certify(dict(out), upper, {**fine, "lsmc": (upper - 2.0, upper - 2.0)}, 0.02)
    assert any("valid but loose" in w for w in low) and any("lsmc" in w and "intrinsic" in w for w in low)


@pytest.fixture(scope="module")
def high_volatility_case():
    """bdj at high volatility, 101 nodes: LSMC and penalty fitted on 500 paths, evaluated on 300 others."""
    inputs = bdj_inputs(BDJ_VOLATILITY["high"])
    scene = gs.stochastic_scene()
    grid = inventory_grid(inputs, scene, 101)
    fit_prices = spot_prices(inputs, shocks(inputs, 500, 1))[0]
    eval_shocks = shocks(inputs, 300, 2)
    eval_prices = spot_prices(inputs, eval_shocks)[0]
    fit = fit_lsmc(inputs, scene, grid, fit_prices, 3)
    basis = penalties.SpotPowers(3)
    penalty = penalties.fit_penalty(fit, inputs, scene, grid, fit_prices, basis, target="fitted")
    bound = dual.dual_bound(penalty, inputs, scene, grid, eval_prices)
    return inputs, scene, grid, eval_shocks, eval_prices, fit, basis, penalty, bound


def test_dual_bounds_lsmc_and_a_continuous_policy_pathwise_and_in_the_mean(high_volatility_case):
    inputs, scene, grid, eval_shocks, eval_prices, fit, basis, penalty, bound = high_volatility_case
    upper = np.asarray(bound.values)
    lsmc = run_lsmc_policy(fit, inputs, scene, grid, eval_prices)
    # An untrained network trading continuous amounts (off the grid), non-anticipative.
    policy = gs.make_policy(scene, inputs, key=jax.random.key(5), spot_scale=0.3)
    network = gs.simulate(policy, inputs, scene, sharpness=None, shocks=eval_shocks)
    off_grid = np.asarray(network.inventory) / grid.spacing
    assert np.max(np.abs(off_grid - np.round(off_grid))) > 0.1
    for schedule in (lsmc, network):
        cash = np.asarray(schedule.value)
        paid = np.asarray(dual.schedule_penalty(penalty, inputs, grid, eval_prices, schedule.inventory))
        # Path by path: the relaxed problem's optimum beats this schedule's cash less its penalty.
        assert np.all(upper >= cash - paid - 1e-9 * np.abs(upper))
        # Non-anticipative, so its penalty has mean zero ...
        assert abs(paid.mean()) <= 4 * paid.std(ddof=1) / np.sqrt(paid.size)
        # ... and the bound is above its value, including with the penalty as a control variate.
        assert upper.mean() >= cash.mean()
        assert upper.mean() >= (cash - paid).mean()


def test_dual_is_tight_and_below_perfect_foresight(high_volatility_case):
    inputs, scene, grid, eval_shocks, eval_prices, fit, basis, penalty, bound = high_volatility_case
    upper = np.asarray(bound.values)
    # Zero penalty: perfect foresight on the grid, equal to the pathwise LP on bdj (whole steps).
    zero = np.asarray(dual.dual_bound(None, inputs, scene, grid, eval_prices).values)
    lp = perfect_foresight(inputs, scene, eval_prices[:8])
    np.testing.assert_allclose(zero[:8], lp, rtol=1e-10)
    assert upper.mean() <= zero.mean()
    # The LSMC's gap, with the penalty as a control variate: ~1.5% at this size (10,000 paths: 1.0%);
    # a wrong or zero penalty gives 25% or more.
    lsmc = run_lsmc_policy(fit, inputs, scene, grid, eval_prices)
    paid = np.asarray(dual.schedule_penalty(penalty, inputs, grid, eval_prices, lsmc.inventory))
    gap = upper - (np.asarray(lsmc.value) - paid)
    assert np.all(gap >= -1e-9 * upper)
    assert gap.mean() <= 0.03 * upper.mean()


def test_lsmc_pathwise_deltas_are_the_derivative_of_the_refitted_valuation():
    inputs = small_inputs(BDJ_VOLATILITY["high"])
    scene = gs.stochastic_scene()
    grid = inventory_grid(inputs, scene, 21)
    fit_shocks, eval_shocks = shocks(inputs, 400, 3), shocks(inputs, 400, 4)
    fit = fit_lsmc(inputs, scene, grid, spot_prices(inputs, fit_shocks)[0], 3)
    value, deltas = lsmc_value_and_deltas(fit, inputs, scene, grid, eval_shocks)
    schedule = run_lsmc_policy(fit, inputs, scene, grid, spot_prices(inputs, eval_shocks)[0])
    assert float(value) == pytest.approx(float(jnp.mean(schedule.value)), rel=1e-12)
    # Closed form of the pathwise derivative: mean over paths of exp(factor_t) (withdrawal - injection),
    # and Euler's identity (the value is homogeneous of degree 1 in the curve): sum_t F_t delta_t = value.
    per_path = np.exp(np.asarray(spot_factor(inputs, eval_shocks))) * np.asarray(schedule.withdrawal
                                                                                 - schedule.injection)
    np.testing.assert_allclose(deltas, per_path.mean(0), rtol=1e-10, atol=1e-6)
    assert float(jnp.dot(inputs.forward_curve, deltas)) == pytest.approx(float(value), rel=1e-10)
    # Central bumps of the whole valuation, refitted on the same paths: below the smallest decision
    # margin (relative step 1e-9) no decision moves, and they agree to round-off on every day.
    # Larger steps (1e-2) move decisions; then they differ from the frozen rule's derivative by the
    # rule's own response, measured systematic (see docs/gas_storage.md), not only noise.
    bumped = np.asarray(lsmc_bumped_deltas(inputs, scene, grid, fit_shocks, eval_shocks, 3, relative_step=1e-9))
    np.testing.assert_allclose(bumped, deltas, rtol=1e-4, atol=1e-2 * float(np.max(np.abs(deltas))) * 1e-2)


def test_lattice_expectation_of_the_interpolant_is_exact():
    factor = jnp.linspace(-1.0, 1.0, 41)
    levels = jax.random.normal(jax.random.key(6), (41, 3)).cumsum(0)  # rough, with kinks at every level
    means, sd = jnp.array([-1.3, -0.2, 0.0, 0.45, 1.1]), 0.09
    expected = levels[0] + lattice._calls(factor, means, sd) @ (lattice._kinks(factor) @ levels)
    # Fine trapezoidal quadrature over +- 12 sd of the interpolant (flat beyond the ends).
    z = jnp.linspace(-12.0, 12.0, 240_001)
    density = jnp.exp(-0.5 * z**2) / jnp.sqrt(2 * jnp.pi)
    for mean, row in zip(means, expected):
        values = lattice.interpolate_factor(factor, levels, mean + sd * z)
        quadrature = jnp.trapezoid(values * density[:, None], z, axis=0)
        np.testing.assert_allclose(row, quadrature, rtol=0, atol=1e-8)


def test_lattice_refuses_zero_volatility():
    inputs = bdj_inputs(0.0)
    scene = gs.stochastic_scene()
    with pytest.raises(snapo_ode.InputError, match="volatility = 0"):
        lattice.solve_factor_lattice(inputs, scene, inventory_grid(inputs, scene, 101))


def test_lattice_policy_and_its_dual_bracket_the_optimum_tightly(high_volatility_case):
    inputs, scene, grid, eval_shocks, eval_prices, fit, basis, penalty, bound = high_volatility_case
    solved = lattice.solve_factor_lattice(inputs, scene, grid, points=100)
    tight = lattice.LatticePenalty(solved)
    upper = np.asarray(dual.dual_bound(tight, inputs, scene, grid, eval_prices).values)
    policies = {"lattice": lattice.run_lattice_policy(solved, inputs, scene, grid, eval_prices),
                "lsmc": run_lsmc_policy(fit, inputs, scene, grid, eval_prices)}
    gaps = {}
    for name, schedule in policies.items():
        paid = np.asarray(dual.schedule_penalty(tight, inputs, grid, eval_prices, schedule.inventory))
        assert abs(paid.mean()) <= 4 * paid.std(ddof=1) / np.sqrt(paid.size)
        gaps[name] = upper - (np.asarray(schedule.value) - paid)
        assert np.all(gaps[name] >= -1e-9 * upper)
    # The lattice's own rule is within 0.05% of its bound (measured 0.01%); LSMC fitted on 500
    # paths is further (measured ~1%), and the LSMC penalty's bound is above the lattice's.
    assert gaps["lattice"].mean() <= 5e-4 * upper.mean()
    assert gaps["lsmc"].mean() > gaps["lattice"].mean()
    assert np.asarray(bound.values).mean() > upper.mean()


def test_the_bound_hands_out_no_free_gas_at_an_off_grid_start_and_end():
    # Before: the start rounded up and the end down to a level, so perfect foresight sold up to a
    # step of gas it never had (~1.5% of the value on the family's fast facilities). Now both are
    # levels; what remains is the room the grid adds beyond [0, capacity], worth at most that room
    # cycled over every price rise of the curve.
    facility, curve = CASES["bdj"]()
    facility = dict(facility, capacity=50_000.0, initial_inventory=21_234.5, terminal_inventory_min=21_234.5)
    inputs = gs.make_inputs(facility, curve[120:160], volatility=0.0, mean_reversion=BDJ_MEAN_REVERSION)
    scene = gs.stochastic_scene()
    relaxed = dual.relaxed_grid(inputs, scene)
    levels = relaxed.levels
    assert levels[relaxed.start_nodes[0]] == levels[relaxed.start_nodes[1]] == pytest.approx(21_234.5, abs=1e-6)
    assert levels[relaxed.terminal_node] == pytest.approx(21_234.5, abs=1e-6)
    assert -relaxed.spacing < levels[0] <= 0 and 50_000 <= levels[-1] < 50_000 + relaxed.spacing
    lp = gs.solve_intrinsic(inputs, gs.deterministic_scene()).value
    forward = np.asarray(inputs.forward_curve)[None]
    bound = float(dual.dual_bound(None, inputs, scene, inventory_grid(inputs, scene, 21), forward).values[0])
    room = (levels[-1] - 50_000) - levels[0]
    assert lp * (1 - 1e-12) <= bound <= lp + room * np.abs(np.diff(forward)).sum()
    assert relaxed.spacing * forward.min() > room * np.abs(np.diff(forward)).sum()  # the free step would fail it
    # The grid on [0, capacity] rounds the start and end and hands out the step: the pilot's choice
    # (on paths of its own; here the one deterministic path) is the anchored grid.
    on_capacity = dual.relaxed_grid(inputs, scene, placement="capacity")
    free = float(dual.dual_bound(None, inputs, scene, inventory_grid(inputs, scene, 21), forward,
                                 relaxed=on_capacity).values[0])
    assert free > lp + relaxed.spacing * forward.min() * 0.9
    chosen = dual.tightest_grid(None, inputs, scene, inventory_grid(inputs, scene, 21), [on_capacity, relaxed], forward)
    assert chosen == relaxed


def test_window_maxima_equal_a_loop_over_every_window():
    from finance.gas_storage._range_maxima import range_maxima

    rng = np.random.default_rng(3)
    values = rng.normal(size=(3, 57))
    values[:, 9] = -np.inf  # an infeasible level stays out of every maximum
    low = rng.integers(-20, 57, size=80)
    high = low + rng.integers(0, 45, size=80)  # windows partly or wholly outside [0, 57)
    padded = np.concatenate([np.full((3, 20), -np.inf), values, np.full((3, 45), -np.inf)], axis=1)
    expected = np.stack([padded[:, a + 20:b + 21].max(axis=1) for a, b in zip(low, high)], axis=1)
    np.testing.assert_array_equal(np.asarray(range_maxima(jnp.asarray(values), low, high)), expected)
    level = np.arange(57)  # windows that move with the level: slices, no gather
    np.testing.assert_array_equal(np.asarray(range_maxima(jnp.asarray(values), level - 4, level + 11)),
                                  np.stack([padded[:, n + 16:n + 32].max(axis=1) for n in level], axis=1))


def test_the_bound_s_program_equals_the_program_over_every_move():
    # The bound's dynamic program takes the best move as a window maximum (cash is linear in the
    # steps on each side of 0). Reference: every move k tried, on a facility whose ratchets make
    # the reachable window vary with the level, with the lattice penalty.
    inputs = ratchet_inputs(0.8, days=30)
    scene = gs.stochastic_scene()
    grid = inventory_grid(inputs, scene, 51)
    penalty = lattice.LatticePenalty(lattice.solve_factor_lattice(inputs, scene, grid, points=40))
    prices = spot_prices(inputs, shocks(inputs, 6, 4))[0]
    relaxed = dual.relaxed_grid(inputs, scene, 301)
    assert len(set(relaxed.max_in_steps)) > 3 and len(set(relaxed.max_out_steps)) > 3
    levels = relaxed.levels
    daily = penalty.daily(inputs, prices)
    later = np.where(np.arange(relaxed.nodes) >= relaxed.terminal_node, 0.0, -np.inf)[None].repeat(6, 0)
    for day in reversed(range(inputs.n_days)):
        today = jax.tree_util.tree_map(lambda leaf: leaf[day], daily)
        after = later - np.asarray(gs._lsmc.interpolate_levels(penalty.today(today), levels, grid.spacing))
        moves = np.arange(-max(relaxed.max_out_steps), max(relaxed.max_in_steps) + 1)
        cash = np.asarray(gs._model.flows_and_cash(inputs, scene, jnp.asarray(moves * relaxed.spacing),
                                                   prices[:, day][:, None], day, None)[2])
        best = np.full_like(later, -np.inf)
        for n in range(relaxed.nodes):
            for k in range(-relaxed.max_out_steps[n], relaxed.max_in_steps[n] + 1):
                if 0 <= n + k < relaxed.nodes:
                    best[:, n] = np.maximum(best[:, n], cash[:, k - moves[0]] + after[:, n + k])
        later = best
    expected = np.maximum(later[:, relaxed.start_nodes[0]], later[:, relaxed.start_nodes[1]])
    bound = np.asarray(dual.dual_bound(penalty, inputs, scene, grid, prices, relaxed=relaxed).values)
    np.testing.assert_allclose(bound, expected, rtol=1e-12)


def test_off_model_paths_null_the_bound_and_every_control_variate_value():
    """A penalty the intrinsic schedule pays with a mean 10 standard errors from zero (the paths
    do not follow the model): the bound's fields and the values with the penalty as control
    variate become null; with a mean-zero penalty nothing changes."""
    from finance.gas_storage._certificate import penalty_mean_check

    cash = np.full(400, 100.0)
    noise = np.random.default_rng(0).standard_normal(400)
    fields = {"dual_upper_bound": 110.0, "snapo_gap": 0.01, "snapo_value_control_variate": 101.0,
              "snapo_minus_rolling_control_variate": 2.0, "snapo_minus_rolling_control_variate_se": 0.5,
              "snapo_out_of_sample": 100.0}
    fine = dict(fields)
    assert penalty_mean_check(fine, cash, cash - (noise - noise.mean())) == [] and fine == fields
    biased = dict(fields)
    warnings = penalty_mean_check(biased, cash, cash - (noise + 10 * noise.std() / np.sqrt(400)))
    assert "not certified" in warnings[0] and biased["snapo_out_of_sample"] == 100.0
    assert all(biased[key] is None for key in fields if key != "snapo_out_of_sample")
