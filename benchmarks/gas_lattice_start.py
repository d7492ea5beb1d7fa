"""Where the state policy starts on a fast facility: the factor lattice's basestock targets
(`_model_lattice.py`) at several grids against the state LSMC's (docs/dev/gas_storage_notes.md,
"The factor lattice as the start"). On a family row under a shipped model, the untrained start's
hard value on evaluation paths, paired with the independent two-factor dynamic program's rule
(`tests/gas_factor_dp.py`, 201 levels, 41 points, 9 nodes; `dp`) or else with the state LSMC.

    PYTHONPATH=$PWD .venv/bin/python benchmarks/gas_lattice_start.py CASE PATHS:TRAINING MODEL POINTS:WIDTH[,...] [dp]
"""

import sys
import time

import equinox as eqx
import jax
import numpy as np
from gas_factor_dp_diagnosis import bench_row

import snapo_ode
from finance.gas_storage._bench_family import chosen_cases
from finance.gas_storage._lsmc import inventory_grid
from finance.gas_storage._model_lattice import lattice_points, solve_model_lattice
from finance.gas_storage._model_study import LEVELS_PER_FLOW, NODES_AT_LEAST
from finance.gas_storage._price_model_file import sample_price_model
from finance.gas_storage._state_lsmc import fit_state_lsmc, run_state_lsmc
from finance.gas_storage._state_policy import make_state_policy, simulate_state_policy
from finance.gas_storage._versus_lsmc import trading_nodes

from gas_factor_dp import two_factor_policy_cash  # on the path: gas_factor_dp_diagnosis puts tests/ there


def main(name: str, paths: int, train: int, model_name: str, grids: list[tuple[int, float]], dp: bool) -> None:
    model = sample_price_model(model_name)
    case = chosen_cases(None, (name,), 0)[0]
    inputs, training, evaluation, scene, _ = bench_row(model, case, paths, train)
    grid = inventory_grid(inputs, scene, trading_nodes(inputs, NODES_AT_LEAST, LEVELS_PER_FLOW))
    fit = fit_state_lsmc(inputs, scene, grid, training, 2)
    lsmc = np.asarray(run_state_lsmc(fit, inputs, scene, grid, evaluation).value)
    reference, label = lsmc, "LSMC"
    if dp:
        decay, q = np.asarray(model.decay()), np.asarray(model.step_covariance())
        reference = two_factor_policy_cash(case.facility, case.curve, decay, q, np.asarray(evaluation.factors),
                                           levels=201, points=41, nodes=9)[0]
        label = "the DP's rule"
    print(f"{name} ({model_name}, {grid.nodes} levels, {paths:,} paths, {train:,} training): LSMC {lsmc.mean():,.0f}, "
          f"{label} {reference.mean():,.0f}; the budget's points: {lattice_points(model, inputs, scene, grid)}", flush=True)
    simulate = eqx.filter_jit(simulate_state_policy)

    def report(text, lattice=None):
        policy = make_state_policy(fit, grid, training, key=jax.random.key(0), lattice=lattice)
        difference = np.asarray(simulate(policy, inputs, scene, evaluation, sharpness=None).value) - reference
        print(f"  {text}: minus {label} {difference.mean():,.0f} (SE {difference.std(ddof=1) / np.sqrt(paths):,.0f})",
              flush=True)

    report("start on the LSMC")
    for points, width in grids:
        start = time.perf_counter()
        lattice = solve_model_lattice(model, inputs, scene, grid, points, width=width)
        seconds = time.perf_counter() - start
        report(f"start on the lattice, {points} points, width {width} (value {float(lattice.value):,.0f}, "
               f"{seconds:.1f} s)", lattice)


if __name__ == "__main__":
    snapo_ode.configure()
    counts = [int(x) for x in sys.argv[2].split(":")]
    grids = [(int(g.split(":")[0]), float(g.split(":")[1])) for g in sys.argv[4].split(",")]
    main(sys.argv[1], counts[0], counts[-1], sys.argv[3], grids, sys.argv[5:] == ["dp"])
