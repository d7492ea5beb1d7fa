"""The two-factor dynamic program of `gas_factor_dp.py` (the reference the family's gaps are
diagnosed against) checked on its own: it reproduces the whole-step reference of
test_gas_two_factor_dp.py, it falls to the intrinsic value when the volatilities vanish, and its
rule, simulated on the model's paths through the exact facility, keeps every constraint and earns
the value it promises."""

import jax
import numpy as np
import pytest

from finance import gas_storage as gs
from finance.gas_storage._family import facility
from finance.gas_storage._lp import solve_intrinsic
from finance.gas_storage._model import deterministic_scene
from finance.gas_storage._price_models import TwoFactorModel, model_paths
from gas_factor_dp import two_factor_policy_cash, two_factor_value
from test_gas_two_factor_dp import CURVE, FACILITY, KAPPA, RHO, SIGMA_CHI, SIGMA_XI, optimal_value

DAYS = 20
# A ratcheted facility with fuel loss, costs, discounting and an off-grid start (the family's
# "everything" kind), rates scaled so that it can cycle within the short horizon.
EVERYTHING = dict(facility("everything", 3), max_injection=60_000.0, max_withdrawal=90_000.0)
SEASON = 3.0 * (1 + 0.1 * np.cos(2 * np.pi * np.arange(DAYS) / DAYS))


def _model(short=1.2, long=0.5):
    model = TwoFactorModel(*(np.asarray(v) for v in (KAPPA, short, long, RHO)))
    return model, np.asarray(model.decay()), np.asarray(model.step_covariance())


def test_the_dp_reproduces_the_whole_step_reference():
    _, decay, q = _model(SIGMA_CHI, SIGMA_XI)
    value = two_factor_value(FACILITY, CURVE, decay, q, levels=11, points=41, nodes=9)
    assert value == pytest.approx(optimal_value(), rel=1e-4)  # the reference: linear in the factors, extrapolated


def test_without_volatility_the_dp_is_the_intrinsic_value():
    _, decay, q = _model(1e-6, 1e-6)
    intrinsic = solve_intrinsic(gs.make_inputs(EVERYTHING, SEASON), deterministic_scene()).value
    coarse, fine = (two_factor_value(EVERYTHING, SEASON, decay, q, levels=n, points=5, nodes=3) for n in (201, 801))
    # Below the continuous optimum (levels restrict the moves), converging to it as levels refine.
    assert coarse <= fine + 1e-6 * intrinsic and fine <= intrinsic * (1 + 1e-9)
    assert fine == pytest.approx(intrinsic, rel=2e-3)


def test_the_rule_keeps_the_facility_and_earns_the_dp_value():
    model, decay, q = _model()
    paths = model_paths(model, SEASON, 2_000, jax.random.key(5))
    grid = dict(levels=201, points=21, nodes=7)
    value = two_factor_value(EVERYTHING, SEASON, decay, q, **grid)
    cash, inventory = two_factor_policy_cash(EVERYTHING, SEASON, decay, q, np.asarray(paths.factors), **grid)
    capacity, kept = EVERYTHING["capacity"], 1 - EVERYTHING["fuel_loss"]
    assert inventory.min() >= -1e-6 and inventory.max() <= capacity * (1 + 1e-12)
    assert inventory[:, -1].min() >= EVERYTHING["terminal_inventory_min"] - 1e-6
    net, fill = np.diff(inventory, axis=1), inventory[:, :-1] / capacity
    ratchet = lambda table, x: np.interp(x, *np.asarray(table).T)  # noqa: E731
    assert np.all(net <= kept * EVERYTHING["max_injection"] * ratchet(EVERYTHING["injection_ratchet"], fill) + 1e-6)
    assert np.all(-net <= EVERYTHING["max_withdrawal"] * ratchet(EVERYTHING["withdrawal_ratchet"], fill) + 1e-6)
    # The rule's mean, with the intrinsic schedule's cash as control variate (its mean is the
    # intrinsic value exactly: E S_t = F_t), is a lower bound on the optimum; the DP's value is the
    # optimum up to its grids, so the two agree within both.
    intrinsic = solve_intrinsic(gs.make_inputs(EVERYTHING, SEASON), deterministic_scene())
    spot = SEASON * np.exp(np.asarray(paths.log_ratio))
    discount = np.exp(-EVERYTHING["rate"] / 365.0 * np.arange(DAYS))
    schedule = discount * (-(spot + EVERYTHING["injection_cost"]) * intrinsic.injection
                           + (spot - EVERYTHING["withdrawal_cost"]) * intrinsic.withdrawal)
    difference = cash - schedule.sum(-1)
    estimate, se = difference.mean() + intrinsic.value, difference.std(ddof=1) / np.sqrt(cash.size)
    assert abs(estimate - value) < 3 * se + 2e-3 * value, (estimate, se, value)
    # Not vacuous: on the same grids the volatility is worth something to the DP.
    _, still, q_still = _model(1e-6, 1e-6)
    assert value > 1.001 * two_factor_value(EVERYTHING, SEASON, still, q_still, **grid)


def _dp_case(train: int, paths: int, **grid) -> tuple:
    """The EVERYTHING facility under `_model()`: model, inputs, `train` training and `paths`
    evaluation paths, the DP's value on `grid` and its rule's (cash, inventory) on the latter."""
    model, decay, q = _model()
    inputs = gs.make_inputs(EVERYTHING, SEASON)
    training = model_paths(model, inputs.forward_curve, train, jax.random.key(1))
    evaluation = model_paths(model, inputs.forward_curve, paths, jax.random.key(2))
    value = two_factor_value(EVERYTHING, SEASON, decay, q, **grid)
    rule = two_factor_policy_cash(EVERYTHING, SEASON, decay, q, np.asarray(evaluation.factors), **grid)
    return model, inputs, training, evaluation, value, rule


@pytest.mark.slow
def test_on_a_ratcheted_facility_the_bound_stays_above_the_dp_and_its_rule():
    """The bound (inventory relaxation, ratchets, fuel, costs, discounting) against the DP's value
    and, path by path with the penalty, against the DP's own rule: a valid upper bound of both;
    SNAPO and LSMC below the DP's value."""
    from finance.gas_storage._lsmc import inventory_grid
    from finance.gas_storage._model import Schedule, stochastic_scene
    from finance.gas_storage._model_study import _bound, value_on_model
    from finance.gas_storage._state_penalty import fit_state_lsmc_and_penalty

    model, inputs, training, evaluation, value, (cash, inventory) = _dp_case(4_000, 1_000, levels=801, points=31,
                                                                              nodes=7)
    out = value_on_model(model, inputs, training, evaluation, nodes=101, train_steps=30, rolling_paths=50,
                         dual_paths=1_000)
    tolerance = 2e-3 * value  # the DP's grids
    assert out["dual_upper_bound"] >= value - 3 * out["dual_upper_bound_se"] - tolerance
    for method in ("lsmc", "snapo"):
        assert out[f"{method}_value_control_variate"] <= value + 3 * out[f"{method}_value_control_variate_se"] + tolerance
    scene = stochastic_scene()
    lsmc_grid = inventory_grid(inputs, scene, 101)
    _, penalty = fit_state_lsmc_and_penalty(model, inputs, scene, lsmc_grid, training, 2)
    rule = Schedule(jax.numpy.asarray(cash), None, None, jax.numpy.asarray(inventory))
    bound = _bound(penalty, inputs, scene, lsmc_grid, evaluation, {"dp_rule": rule}, 1_000, False)
    assert bound["bound_warnings"] == []  # certify: the bound's path values >= the rule's cash - penalty, path by path
    assert bound["dp_rule_gap"] >= -3 * bound["dp_rule_gap_se"]
    assert bound["dp_rule_value_control_variate"] == pytest.approx(value, rel=5e-3)  # not vacuous: the rule is near the optimum


def test_the_bound_on_a_finer_grid_by_correction_stays_above_the_dp_and_its_rule(monkeypatch):
    """The two-level bound (`_model_study._bound`: a control grid on all paths, a finer grid's
    correction on the first few) on a ratcheted facility: above the DP's value, and each grid,
    path by path with its own penalty, above the DP's rule and LSMC (`certify`,
    `pathwise_failures`)."""
    from finance.gas_storage import _model_study
    from finance.gas_storage._lsmc import inventory_grid
    from finance.gas_storage._model import Schedule, stochastic_scene
    from finance.gas_storage._state_lsmc import run_state_lsmc
    from finance.gas_storage._state_penalty import fit_state_lsmc_and_penalty

    monkeypatch.setattr(_model_study, "CORRECTION_PATHS", 60)
    monkeypatch.setattr(_model_study, "DUAL_WORK", 2e8)  # a small budget: grids of ~1,700 and ~8,000 levels
    model, inputs, training, evaluation, value, (cash, inventory) = _dp_case(1_000, 300, levels=201, points=21,
                                                                              nodes=7)
    scene = stochastic_scene()
    lsmc_grid = inventory_grid(inputs, scene, 51)
    fit, penalty = fit_state_lsmc_and_penalty(model, inputs, scene, lsmc_grid, training, 2)
    policies = {"dp_rule": Schedule(jax.numpy.asarray(cash), None, None, jax.numpy.asarray(inventory)),
                "lsmc": run_state_lsmc(fit, inputs, scene, lsmc_grid, evaluation)}
    out = _model_study._bound(penalty, inputs, scene, lsmc_grid, evaluation, policies, 300, False)
    # Not vacuous: the finer grid relaxes less, and its correction was taken on 60 paths.
    assert out["dual_correction_paths"] == 60
    assert out["dual_relaxation"] < 0.5 * out["dual_control_relaxation"]
    assert not [w for w in out["bound_warnings"] if "not certified" in w]  # both grids, path by path
    tolerance = 2e-3 * value  # the DP's grids
    assert out["dual_upper_bound"] >= value - 3 * out["dual_upper_bound_se"] - tolerance
    assert out["dp_rule_gap"] >= -3 * out["dp_rule_gap_se"]
