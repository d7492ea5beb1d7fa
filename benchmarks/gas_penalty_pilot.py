"""How the bound's penalty is chosen, measured: on fresh paths of the model, each candidate
penalty's bound (`_dual.dual_bound`, on the grid the bench takes for 2,000 paths) and the LSMC
rule's gap under it (bound less the rule's cash less the penalty it pays, path by path), with the
standard error of each difference from the state penalty on the first 200, 500 and all the pilot
paths; the bounds' means too, to show why the gaps decide (docs/dev/gas_storage_notes.md, "The
lattice's value as the bound's penalty"). The candidates: the state LSMC's penalty, the factor
lattices `penalty_lattices` gives (or the one asked for), and the even blend of the state's with
each lattice.

    PYTHONPATH=$PWD:$PWD/benchmarks .venv/bin/python benchmarks/gas_penalty_pilot.py CASE MODEL TRAINING PILOT [PER_FLOW POINTS]

PER_FLOW, POINTS: instead, the one lattice on a grid of PER_FLOW levels to a day's flow (at least
26; 4: the LSMC's), POINTS per factor.
"""

import sys
import time

import jax
import numpy as np
from gas_factor_dp_diagnosis import bench_row

import snapo_ode
from finance.gas_storage._bench_family import chosen_cases
from finance.gas_storage._dual import DUAL_WORK, relaxed_grid
from finance.gas_storage._lsmc import inventory_grid
from finance.gas_storage._model_lattice import lattice_points, solve_model_lattice
from finance.gas_storage._model_lattice_penalty import BLEND_WEIGHT, ModelLatticePenalty, penalty_lattices, pilot_gaps
from finance.gas_storage._model_study import LEVELS_PER_FLOW, NODES_AT_LEAST
from finance.gas_storage._penalty import BlendedPenalty
from finance.gas_storage._price_model_file import sample_price_model
from finance.gas_storage._price_models import model_paths
from finance.gas_storage._state_lsmc import run_state_lsmc
from finance.gas_storage._state_penalty import fit_state_lsmc_and_penalty
from finance.gas_storage._versus_lsmc import trading_nodes


def _report(label: str, values: np.ndarray, reference: np.ndarray | None) -> None:
    line = f"{label} {values.mean():,.0f} (SE {values.std(ddof=1) / np.sqrt(values.size):,.0f})"
    if reference is not None:
        d = values - reference
        line += "; less the state's: " + ", ".join(
            f"{n} paths {d[:n].mean():,.0f} (SE {d[:n].std(ddof=1) / np.sqrt(n):,.0f})"
            for n in sorted({200, 500, values.size}) if n <= values.size)
    print(line, flush=True)


def main(name: str, model_name: str, train: int, pilot_count: int, per_flow: int | None = None,
         points: int | None = None) -> None:
    model = sample_price_model(model_name)
    case = chosen_cases(None, (name,), 0)[0]
    inputs, training, _, scene, _ = bench_row(model, case, 10, train)
    grid = inventory_grid(inputs, scene, trading_nodes(inputs, NODES_AT_LEAST, LEVELS_PER_FLOW))
    fit, state = fit_state_lsmc_and_penalty(model, inputs, scene, grid, training, 2)
    lattices = (penalty_lattices(model, inputs, scene, grid, lattice_points(model, inputs, scene, grid))
                if per_flow is None else [(points, inventory_grid(inputs, scene, trading_nodes(inputs, 26, per_flow)))])
    pilot = model_paths(model, inputs.forward_curve, pilot_count, jax.random.fold_in(jax.random.key(0), 2))
    relaxed = relaxed_grid(inputs, scene, paths=2000, work=DUAL_WORK)
    print(f"the bound's grid {relaxed.nodes} levels, relaxation {relaxed.relaxation:.2e}; the LSMC's {grid.nodes}")
    reference = run_state_lsmc(fit, inputs, scene, grid, pilot)
    bounds, gaps = pilot_gaps(state, inputs, scene, grid, pilot, relaxed, reference)
    _report("state: bound", bounds, None)
    _report("state: the LSMC rule's gap", gaps, None)
    for points_, own in lattices:
        t = time.time()
        lattice = ModelLatticePenalty(model, solve_model_lattice(model, inputs, scene, own, points_, keep_values=True),
                                      own, grid)
        print(f"lattice {points_} points, {own.nodes} levels: solved in {time.time() - t:.0f} s", flush=True)
        blend = BlendedPenalty(state, lattice, BLEND_WEIGHT)
        for label, penalty in ((f"lattice {points_} x {own.nodes}", lattice),
                               (f"blend with lattice {points_} x {own.nodes}", blend)):
            t = time.time()
            their_bounds, their_gaps = pilot_gaps(penalty, inputs, scene, grid, pilot, relaxed, reference)
            _report(f"{label} ({time.time() - t:.0f} s): bound", their_bounds, bounds)
            _report(f"{label}: the LSMC rule's gap", their_gaps, gaps)
        del lattice, blend


if __name__ == "__main__":
    snapo_ode.configure()
    main(sys.argv[1], sys.argv[2], *map(int, sys.argv[3:]))
