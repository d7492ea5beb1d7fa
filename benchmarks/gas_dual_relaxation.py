"""How much of the two-factor dual bound's excess over the true value is its inventory grid's
relaxation, and what the two-level bound (`_model_study._bound`) takes off it
(docs/dev/gas_storage_notes.md, "The bound's grid relaxation"): on a family row under the
shipped two-factor model, the state penalty fitted as the bench fits it, the bound on PATHS
evaluation paths on the grid affordable there (the control), then on the first
CORRECTION_PATHS of them on the grid affordable there and on grids of LEVELS levels, each
paired with the control on the same paths (the correction).

    PYTHONPATH=$PWD .venv/bin/python benchmarks/gas_dual_relaxation.py CASE PATHS TRAINING [LEVELS ...]
"""

import sys
import time

import numpy as np

import snapo_ode
from finance.gas_storage._bench_family import chosen_cases
from finance.gas_storage._dual import dual_bound, relaxed_grid
from finance.gas_storage._model import spot_prices
from finance.gas_storage._model_study import CORRECTION_PATHS
from finance.gas_storage._price_model_file import sample_price_model
from finance.gas_storage._results import standard_error
from finance.gas_storage._state_lsmc import fit_state_lsmc
from finance.gas_storage._state_penalty import fit_state_penalty
from gas_factor_dp_diagnosis import bench_row  # the bench's paths, as the diagnosis draws them


def _bound(penalty, inputs, scene, grid, prices, evaluation, relaxed, count):
    """The bound's path values on the first `count` paths of `relaxed`, and the seconds taken."""
    start = time.perf_counter()
    values = dual_bound(penalty, inputs, scene, grid, prices[:count], relaxed=relaxed, price_paths=evaluation[:count])
    return np.asarray(values.values), time.perf_counter() - start


def main(name: str, paths: int, train: int, levels: list[int]) -> None:
    model = sample_price_model("two-factor")
    case = chosen_cases(None, (name,), 0)[0]
    inputs, training, evaluation, scene, grid = bench_row(model, case, paths, train)
    fit = fit_state_lsmc(inputs, scene, grid, training, 2)
    penalty = fit_state_penalty(fit, model, inputs, scene, grid, training)
    prices = spot_prices(inputs, evaluation)[0]
    few = min(paths, CORRECTION_PATHS)
    control = relaxed_grid(inputs, scene, paths=paths)
    upper, seconds = _bound(penalty, inputs, scene, grid, prices, evaluation, control, paths)
    print(f"{name}: control grid {control.nodes} levels (relaxation {control.relaxation:.3%}) on {paths} paths: "
          f"bound {upper.mean():,.0f} (SE {standard_error(upper):,.0f}); {seconds:.0f} s", flush=True)
    grids = [relaxed_grid(inputs, scene, paths=few)] + [relaxed_grid(inputs, scene, n) for n in levels]
    for relaxed in grids:
        values, seconds = _bound(penalty, inputs, scene, grid, prices, evaluation, relaxed, few)
        change = values - upper[:few]
        estimate = upper.mean() + change.mean()
        print(f"  {relaxed.nodes} levels (relaxation {relaxed.relaxation:.3%}) on the first {few}: correction "
              f"{change.mean():,.0f} (SE {standard_error(change):,.0f}, {change.mean() / upper.mean():.3%}), "
              f"two-level bound {estimate:,.0f} (SE {np.hypot(standard_error(upper), standard_error(change)):,.0f}); "
              f"{seconds:.0f} s", flush=True)


if __name__ == "__main__":
    snapo_ode.configure()
    main(sys.argv[1], int(sys.argv[2]), int(sys.argv[3]), [int(x) for x in sys.argv[4:]])
