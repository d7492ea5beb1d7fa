"""How far from optimal, and at what cost: the dual upper bound on the evaluation paths with
every policy's duality gap, the checks that keep a bound a bound, and the forward-curve deltas
of LSMC (pathwise, one reverse pass) with the three ways of getting a value and its deltas timed
side by side.

The penalty of the bound is the factor lattice's (`_lattice.py`: the tightest measured, exact
conditional means) whenever the spot is random; at zero volatility it is none (the bound is then
perfect foresight, which is the intrinsic value there). Each policy's lower bound is its hard
value with the penalty as a control variate (cash - penalty: the same mean for a
non-anticipative policy, far smaller variance), so that (bound - lower) >= 0 holds path by path
and its mean has a small standard error; the plain value is reported beside it. The intrinsic
schedule is one of the policies: it is non-anticipative and worth the intrinsic value in
expectation (E[spot] = forward), so no bound may lie below it.

Checks (`certify`): a bound that falls below any policy's cash less penalty on any path is not
certified (its fields become null); a bound below a policy's plain value by more than 3 paired
standard errors, a policy below the intrinsic value by more than 3, and a relaxation that raised
the rates by more than `LOOSE_RELAXATION`, each give a warning.
"""

import jax
import numpy as np

from snapo_ode import Scene, time_function, time_once

from ._dual import PLACEMENTS, dual_bound, relaxed_grid, relaxed_grids, schedule_penalty, tightest_grid
from ._inputs import StorageInputs
from ._lattice import LATTICE_WORK, LatticePenalty, lattice_grid, run_lattice_policy, solve_factor_lattice
from ._lp import IntrinsicSolution
from ._lsmc import InventoryGrid, LSMCFit
from ._lsmc_deltas import lsmc_value_and_deltas
from ._model import Schedule, flows_and_cash, spot_prices
from ._paths import PricePaths
from ._results import standard_error

LOOSE_RELAXATION = 0.01  # rates raised by more than this share make the bound's warning "valid but loose"
DUAL_PATHS = (2_000, 500, 250)  # the bound runs on the first of these many evaluation paths that buys the finest grid
PATHWISE_TOLERANCE = 1e-9  # relative: round-off of the path problem's sums
PILOT_PATHS, PILOT_KEY = 50, 31  # paths of their own on which the bound's grid placement is chosen
PILOT_SHARE = 5  # and no more than 1/PILOT_SHARE of the bound's paths per placement


def intrinsic_schedule(inputs: StorageInputs, scene: Scene, intrinsic: IntrinsicSolution, prices) -> Schedule:
    """The intrinsic LP's schedule traded at the spot of each path (`prices`, (paths, T)): a
    non-anticipative policy worth the intrinsic value in expectation."""
    net = np.diff(intrinsic.inventory)
    day = np.arange(inputs.n_days)
    injection, withdrawal, cash = flows_and_cash(inputs, scene, net, prices, day, None)
    paths = prices.shape[0]
    return Schedule(cash.sum(-1), np.broadcast_to(injection, prices.shape), np.broadcast_to(withdrawal, prices.shape),
                    np.broadcast_to(intrinsic.inventory, (paths, inputs.n_days + 1)))


def duality_gaps(inputs: StorageInputs, scene: Scene, grid: InventoryGrid, eval_shocks, policies: dict[str, Schedule],
                 *, lattice_points: int = 200, dual_nodes: int | None = None,
                 lattice_work: float = LATTICE_WORK) -> dict:
    """The dual bound on the paths of `eval_shocks` and, for each named policy (its hard schedule
    on those paths) and the lattice's own rule, its value with the penalty as a control variate
    and its gap (bound - value) / bound, each with its standard error. Keys: `dual_upper_bound`,
    `dual_upper_bound_se`, `dual_penalty`, `dual_bounds_continuous_policies`, `dual_grid_nodes`,
    `dual_relaxation`, `dual_paths` (the first evaluation paths the bound and the gaps are taken
    on: all, or one of DUAL_PATHS where fewer paths afford a tighter grid), `dual_seconds`, per policy `NAME_value_control_variate(_se)`, `NAME_gap`,
    `NAME_gap_se`, and `warnings` (a list of sentences; the bound's fields are None when a
    pathwise check failed)."""
    prices, _ = spot_prices(inputs, eval_shocks)
    penalty, kind = None, "none: zero volatility, the bound is perfect foresight"
    lattice_seconds = 0.0
    if float(inputs.volatility) > 0:
        grid = lattice_grid(inputs, scene, grid, points=lattice_points, work=lattice_work)
        lattice_seconds, lattice = time_once(solve_factor_lattice, inputs, scene, grid, points=lattice_points)
        penalty = LatticePenalty(lattice)
        kind = f"factor lattice ({lattice_points} levels of the OU factor, {grid.nodes} of the inventory)"
        policies = {**policies, "lattice": run_lattice_policy(lattice, inputs, scene, grid, prices)}
    relaxed, paths = _bound_grid(inputs, scene, grid, penalty, dual_nodes, prices.shape[0])
    prices = prices[:paths]
    seconds, bound = time_once(dual_bound, penalty, inputs, scene, grid, prices, relaxed=relaxed)
    upper = np.asarray(bound.values)
    out = {"dual_upper_bound": float(upper.mean()), "dual_upper_bound_se": standard_error(upper),
           "dual_penalty": kind, "dual_bounds_continuous_policies": True, "dual_grid_nodes": relaxed.nodes,
           "dual_grid_spacing": relaxed.spacing, "dual_grid_first_level": relaxed.first_level,
           "dual_relaxation": relaxed.relaxation, "dual_paths": paths, "dual_seconds": seconds + lattice_seconds}
    lowers = {}
    for name, schedule in policies.items():
        cash = np.asarray(schedule.value)[:paths]
        paid = 0.0 if penalty is None else np.asarray(schedule_penalty(penalty, inputs, grid, prices,
                                                                       schedule.inventory[:paths], relaxed))
        lower = cash - paid
        lowers[name] = (cash, lower)
        out.update({f"{name}_value_control_variate": float(lower.mean()),
                    f"{name}_value_control_variate_se": standard_error(lower),
                    f"{name}_gap": float((upper - lower).mean() / upper.mean()),
                    f"{name}_gap_se": standard_error(upper - lower) / float(upper.mean())})
    if "lattice" in policies:
        out["lattice_out_of_sample"] = float(np.mean(policies["lattice"].value))
        out["lattice_se"] = standard_error(policies["lattice"].value)
    warnings = certify(out, upper, lowers, relaxed.relaxation)
    if isinstance(eval_shocks, PricePaths) and penalty is not None and "intrinsic" in lowers:
        warnings += penalty_mean_check(out, *lowers["intrinsic"])
    return {**out, "warnings": warnings}


def _clear_bound(out: dict) -> None:
    for key in [key for key in out if key.startswith("dual_upper_bound") or key.endswith("_gap")
                or key.endswith("_gap_se")]:
        out[key] = None


def penalty_mean_check(out: dict, cash: np.ndarray, lower: np.ndarray) -> list[str]:
    """On given paths (a file), the penalty has mean zero for a non-anticipative policy only if
    the paths follow the price model whose conditional expectations built it: the penalty the
    intrinsic schedule pays (cash - lower, per path) is tested for mean zero (4 standard
    errors); where it fails the bound is not certified and its fields become null, and so do the
    values with the penalty as control variate (`*_control_variate*`), biased by it too."""
    paid = cash - lower
    if abs(paid.mean()) <= 4 * standard_error(paid) + 1e-12 * (np.abs(cash).mean() + 1.0):
        return []
    _clear_bound(out)
    out.update({key: None for key in out if "_control_variate" in key})
    return [f"dual bound not certified: the penalty paid by the intrinsic schedule has mean {paid.mean():,.2f} "
            f"(standard error {standard_error(paid):,.2f}), not zero: the paths do not follow the price model its "
            "conditional expectations come from; its fields and the control-variate values are null"]


def _bound_grid(inputs: StorageInputs, scene: Scene, grid: InventoryGrid, penalty, dual_nodes: int | None,
                paths: int) -> tuple:
    """The bound's grid and the number of evaluation paths it runs on: for each way of placing
    the grid (`_dual.PLACEMENTS`), the tightest relaxation the work budget allows on all paths or
    on fewer (DUAL_PATHS: a tighter relaxation on fewer paths beats a looser one on all: the
    gap's standard error stays small, the penalty being a control variate, the relaxation's bias
    does not; and no finer than the fewest of DUAL_PATHS afford, so that a run of a few paths
    gets the same grid at a share of the cost); then the placement whose bound is lower on
    PILOT_PATHS paths of their own (fewer where the bound runs on fewer than PILOT_SHARE x
    PILOT_PATHS: on its grid, the pilots cost as much per path as the bound)."""
    budgets = (max(paths, min(DUAL_PATHS)), *(count for count in DUAL_PATHS if count < paths))
    options = {}
    for placement in PLACEMENTS:
        if dual_nodes is not None:
            options[relaxed_grid(inputs, scene, dual_nodes, placement=placement)] = paths
            continue
        grids = relaxed_grids(inputs, scene, budgets, placement=placement)
        relaxed, used = grids[budgets[0]], paths
        for count in budgets[1:]:
            if grids[count].relaxation < relaxed.relaxation - 1e-12:
                relaxed, used = grids[count], count
        options[relaxed] = used
    pilots = max(2, min(PILOT_PATHS, min(options.values()) // PILOT_SHARE))
    pilot = jax.random.normal(jax.random.key(PILOT_KEY), (pilots, inputs.n_days))
    chosen = tightest_grid(penalty, inputs, scene, grid, list(options), spot_prices(inputs, pilot)[0])
    return chosen, options[chosen]


def certify(out: dict, upper: np.ndarray, lowers: dict[str, tuple], relaxation: float) -> list[str]:
    """The checks of the module docstring on the bound's path values `upper` and each policy's
    (cash, cash - penalty) per path; clears the bound's fields in `out` where it fails a pathwise
    check. Returns the warnings."""
    warnings = pathwise_failures(upper, lowers)
    if warnings:
        _clear_bound(out)
        return warnings + _mean_checks(None, lowers)
    for name, (cash, lower) in lowers.items():
        difference = upper - cash
        if difference.mean() < -3 * standard_error(difference):
            warnings.append(f"dual bound {upper.mean():,.0f} lies below {name}'s value {cash.mean():,.0f} by more "
                            f"than 3 paired standard errors")
    if relaxation > LOOSE_RELAXATION:
        warnings.append(f"dual bound valid but loose: to be solved on a grid its rates were raised by up to "
                        f"{relaxation:.1%} (rates that are not whole steps of any affordable grid, or ratchets); "
                        "gaps against it overstate the distance to the optimum")
    return warnings + _mean_checks(upper, lowers)


def pathwise_failures(upper: np.ndarray, lowers: dict[str, tuple]) -> list[str]:
    """The first policy whose cash less penalty (`lowers[name][1]`) lies above the bound's path
    values `upper` on some path (beyond round-off), as a one-item list of the warning; [] where
    the bound holds path by path against all."""
    scale = np.abs(upper) + 1.0
    for name, (_, lower) in lowers.items():
        below = upper < lower - PATHWISE_TOLERANCE * scale
        if np.any(below):
            worst = float(np.max(lower - upper))
            return [f"dual bound not certified: below {name}'s cash less penalty on {int(below.sum())} of "
                    f"{upper.size} paths (by up to {worst:,.2f}); its fields are null"]
    return []


def _mean_checks(upper, lowers: dict[str, tuple]) -> list[str]:
    """Policies worth less than the intrinsic schedule on the same paths (paired, 3 SE)."""
    if "intrinsic" not in lowers:
        return []
    warnings = []
    reference = lowers["intrinsic"][0]
    for name, (cash, _) in lowers.items():
        difference = cash - reference
        if name != "intrinsic" and difference.mean() < -3 * standard_error(difference):
            warnings.append(f"{name} ({cash.mean():,.0f}) lies below the intrinsic schedule on the same paths "
                            f"({reference.mean():,.0f}) by more than 3 paired standard errors: a lower bound below "
                            "the intrinsic value")
    return warnings


def lsmc_deltas(fit: LSMCFit, inputs: StorageInputs, scene: Scene, grid: InventoryGrid, eval_shocks,
                fit_seconds: float, eval_seconds: float) -> dict:
    """LSMC's pathwise deltas on the evaluation paths, one per day (one reverse pass, the fitted
    rule frozen), and the wall time of value + deltas by LSMC with them (`lsmc_plus_deltas_seconds`:
    the fit and the one pass) and with central bumps of the whole valuation
    (`lsmc_plus_bumps_seconds`: 2T refits and revaluations at the measured `fit_seconds` +
    `eval_seconds`, an estimate: 2T valuations were not run)."""
    timing, (_, deltas) = time_function(lsmc_value_and_deltas, fit, inputs, scene, grid, eval_shocks, repeats=1)
    return {"lsmc_pathwise_deltas": np.asarray(deltas).tolist(), "lsmc_deltas_seconds": timing.median_seconds,
            "lsmc_plus_deltas_seconds": fit_seconds + timing.median_seconds,
            "lsmc_plus_bumps_seconds": 2 * inputs.n_days * (fit_seconds + eval_seconds)}
