"""Why the bound's penalty is chosen by a policy's paired gap, not by the bounds' means: on fresh
paths of the model, each penalty's bound (`_dual.dual_bound`, the grid the bench takes for 2,000
paths) and the LSMC rule's gap under it (bound less the rule's cash less the penalty it pays,
path by path), with the standard error of each difference between the two penalties on the
first 200, 500 and all the pilot paths (docs/dev/gas_storage_notes.md, "The lattice's value as
the bound's penalty").

    PYTHONPATH=$PWD .venv/bin/python benchmarks/gas_penalty_pilot.py CASE MODEL TRAINING PILOT
"""

import sys
import time

import jax
import numpy as np
from gas_factor_dp_diagnosis import bench_row

import snapo_ode
from finance.gas_storage._bench_family import chosen_cases
from finance.gas_storage._dual import DUAL_WORK, dual_bound, relaxed_grid, schedule_penalty
from finance.gas_storage._lsmc import inventory_grid
from finance.gas_storage._model import spot_prices
from finance.gas_storage._model_lattice import lattice_points, solve_model_lattice
from finance.gas_storage._model_lattice_penalty import ModelLatticePenalty, penalty_points
from finance.gas_storage._model_study import LEVELS_PER_FLOW, NODES_AT_LEAST
from finance.gas_storage._price_model_file import sample_price_model
from finance.gas_storage._price_models import model_paths
from finance.gas_storage._state_lsmc import run_state_lsmc
from finance.gas_storage._state_penalty import fit_state_lsmc_and_penalty
from finance.gas_storage._versus_lsmc import trading_nodes


def main(name: str, model_name: str, train: int, pilot_count: int) -> None:
    model = sample_price_model(model_name)
    case = chosen_cases(None, (name,), 0)[0]
    inputs, training, _, scene, _ = bench_row(model, case, 10, train)
    grid = inventory_grid(inputs, scene, trading_nodes(inputs, NODES_AT_LEAST, LEVELS_PER_FLOW))
    fit, state = fit_state_lsmc_and_penalty(model, inputs, scene, grid, training, 2)
    points = penalty_points(model, inputs, grid, lattice_points(model, inputs, scene, grid))
    lattice = ModelLatticePenalty(model, solve_model_lattice(model, inputs, scene, grid, points, keep_values=True))
    pilot = model_paths(model, inputs.forward_curve, pilot_count, jax.random.fold_in(jax.random.key(0), 2))
    prices = spot_prices(inputs, pilot)[0]
    relaxed = relaxed_grid(inputs, scene, paths=2000, work=DUAL_WORK)
    vals = {}
    for label, pen in (("state", state), ("lattice", lattice)):
        t = time.time()
        vals[label] = np.asarray(dual_bound(pen, inputs, scene, grid, prices, relaxed=relaxed, price_paths=pilot).values)
        print(f"{label}: bound {vals[label].mean():,.0f} (SE {vals[label].std() / np.sqrt(pilot_count):,.0f}), "
              f"{time.time() - t:.0f} s", flush=True)
    d = vals["lattice"] - vals["state"]
    for n in (200, 500, pilot_count):
        print(f"{n} paths: bound, lattice - state {d[:n].mean():,.0f} (SE {d[:n].std(ddof=1) / np.sqrt(n):,.0f})")
    print(f"{points} points per factor; the bound's grid {relaxed.nodes} levels, relaxation {relaxed.relaxation:.2e}")
    sched = run_state_lsmc(fit, inputs, scene, grid, pilot)
    cash = np.asarray(sched.value)
    gaps = {}
    for label, pen in (("state", state), ("lattice", lattice)):
        paid = np.asarray(schedule_penalty(pen, inputs, grid, prices, sched.inventory, relaxed, pilot))
        gaps[label] = vals[label] - (cash - paid)
        print(f"{label}: the LSMC rule's gap {gaps[label].mean():,.0f} "
              f"(SE {gaps[label].std(ddof=1) / np.sqrt(pilot_count):,.0f})")
    g = gaps["lattice"] - gaps["state"]
    for n in (200, 500, pilot_count):
        print(f"{n} paths: gap, lattice - state {g[:n].mean():,.0f} (SE {g[:n].std(ddof=1) / np.sqrt(n):,.0f})")


if __name__ == "__main__":
    snapo_ode.configure()
    main(sys.argv[1], sys.argv[2], int(sys.argv[3]), int(sys.argv[4]))
