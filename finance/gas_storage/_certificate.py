"""How far from optimal, and at what cost: the dual upper bound on the evaluation paths with
every policy's duality gap, and the forward-curve deltas of LSMC (pathwise, one reverse pass)
with the three ways of getting a value and its 365 deltas timed side by side.

The penalty of the bound is the factor lattice's (`_lattice.py`: the tightest measured, exact
conditional means) whenever the spot is random; at zero volatility it is none (the bound is then
perfect foresight, which is the intrinsic value there). Each policy's lower bound is its hard
value with the penalty as a control variate (cash - penalty: the same mean for a
non-anticipative policy, far smaller variance), so that (bound - lower) >= 0 holds path by path
and its mean has a small standard error; the plain value is reported beside it.
"""

import numpy as np

from snapo_ode import Scene, time_function, time_once

from ._dual import dual_bound, schedule_penalty
from ._inputs import StorageInputs
from ._lattice import LatticePenalty, run_lattice_policy, solve_factor_lattice
from ._lsmc import InventoryGrid, LSMCFit
from ._lsmc_deltas import lsmc_value_and_deltas
from ._model import Schedule, spot_prices
from ._results import standard_error


def duality_gaps(inputs: StorageInputs, scene: Scene, grid: InventoryGrid, eval_shocks, policies: dict[str, Schedule],
                 *, lattice_points: int = 200) -> dict:
    """The dual bound on the paths of `eval_shocks` and, for each named policy (its hard schedule
    on those paths) and the lattice's own rule, its value with the penalty as a control variate
    and its gap (bound - value) / bound, each with its standard error. Keys: `dual_upper_bound`,
    `dual_upper_bound_se`, `dual_penalty`, `dual_bounds_continuous_policies`, `dual_seconds`,
    and per policy `NAME_value_control_variate(_se)`, `NAME_gap`, `NAME_gap_se`."""
    prices, _ = spot_prices(inputs, eval_shocks)
    penalty, kind = None, "none: zero volatility, the bound is perfect foresight"
    lattice_seconds = 0.0
    if float(inputs.volatility) > 0:
        lattice_seconds, lattice = time_once(solve_factor_lattice, inputs, scene, grid, points=lattice_points)
        penalty, kind = LatticePenalty(lattice), f"factor lattice ({lattice_points} levels of the OU factor)"
        policies = {**policies, "lattice": run_lattice_policy(lattice, inputs, scene, grid, prices)}
    seconds, bound = time_once(dual_bound, penalty, inputs, scene, grid, prices)
    upper = np.asarray(bound.values)
    out = {"dual_upper_bound": float(upper.mean()), "dual_upper_bound_se": standard_error(upper),
           "dual_penalty": kind, "dual_bounds_continuous_policies": bound.bounds_continuous_policies,
           "dual_seconds": seconds + lattice_seconds}
    for name, schedule in policies.items():
        cash = np.asarray(schedule.value)
        paid = 0.0 if penalty is None else np.asarray(schedule_penalty(penalty, inputs, grid, prices,
                                                                       schedule.inventory))
        lower = cash - paid
        out.update({f"{name}_value_control_variate": float(lower.mean()),
                    f"{name}_value_control_variate_se": standard_error(lower),
                    f"{name}_gap": float((upper - lower).mean() / upper.mean()),
                    f"{name}_gap_se": standard_error(upper - lower) / float(upper.mean())})
    if "lattice" in policies:
        out["lattice_out_of_sample"] = float(np.mean(policies["lattice"].value))
        out["lattice_se"] = standard_error(policies["lattice"].value)
    return out


def lsmc_deltas(fit: LSMCFit, inputs: StorageInputs, scene: Scene, grid: InventoryGrid, eval_shocks,
                fit_seconds: float, eval_seconds: float) -> dict:
    """LSMC's 365 pathwise deltas on the evaluation paths (one reverse pass, the fitted rule
    frozen), and the wall time of value + deltas by LSMC with them (`lsmc_plus_deltas_seconds`:
    the fit and the one pass) and with central bumps of the whole valuation
    (`lsmc_plus_bumps_seconds`: 2T refits and revaluations at the measured `fit_seconds` +
    `eval_seconds`, an estimate: 730 valuations were not run)."""
    timing, (_, deltas) = time_function(lsmc_value_and_deltas, fit, inputs, scene, grid, eval_shocks, repeats=1)
    return {"lsmc_pathwise_deltas": np.asarray(deltas).tolist(), "lsmc_deltas_seconds": timing.median_seconds,
            "lsmc_plus_deltas_seconds": fit_seconds + timing.median_seconds,
            "lsmc_plus_bumps_seconds": 2 * inputs.n_days * (fit_seconds + eval_seconds)}
