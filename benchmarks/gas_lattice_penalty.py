"""How much tighter does the factor lattice's penalty (`_model_lattice_penalty.py`) bound than
the state LSMC's (`_state_penalty.py`), at a chosen number of points per factor,
on a family row under a shipped model: each bound (`_model_study._bound`, the bench's estimator)
and the gap of the policy started on the lattice, untrained, valued with each penalty as control
variate (docs/dev/gas_storage_notes.md, "The factor lattice as the start").

    PYTHONPATH=$PWD .venv/bin/python benchmarks/gas_lattice_penalty.py CASE PATHS:TRAINING MODEL POINTS
"""

import sys
import time

import equinox as eqx
import jax
import jax.numpy as jnp
from gas_factor_dp_diagnosis import bench_row

import snapo_ode
from finance.gas_storage._bench_family import chosen_cases
from finance.gas_storage._lsmc import inventory_grid
from finance.gas_storage._model_lattice import solve_model_lattice
from finance.gas_storage._model_lattice_penalty import ModelLatticePenalty
from finance.gas_storage._model_study import LEVELS_PER_FLOW, NODES_AT_LEAST, _bound
from finance.gas_storage._price_model_file import sample_price_model
from finance.gas_storage._state_penalty import fit_state_lsmc_and_penalty
from finance.gas_storage._state_policy import make_state_policy, simulate_state_policy
from finance.gas_storage._versus_lsmc import trading_nodes


def main(name: str, paths: int, train: int, model_name: str, points: int) -> None:
    model = sample_price_model(model_name)
    case = chosen_cases(None, (name,), 0)[0]
    inputs, training, evaluation, scene, _ = bench_row(model, case, paths, train)
    grid = inventory_grid(inputs, scene, trading_nodes(inputs, NODES_AT_LEAST, LEVELS_PER_FLOW))
    fit, production = fit_state_lsmc_and_penalty(model, inputs, scene, grid, training, 2)
    lattice = solve_model_lattice(model, inputs, scene, grid, points, keep_values=True)
    policy = make_state_policy(fit, grid, training, key=jax.random.key(0), lattice=lattice)
    start = eqx.filter_jit(simulate_state_policy)(policy, inputs, scene, evaluation, sharpness=None)
    print(f"{name} ({model_name}, {grid.nodes} levels, {points} points, {paths:,} paths, {train:,} training): "
          f"the lattice's start {float(jnp.mean(start.value)):,.0f}", flush=True)
    for label, penalty in (("state LSMC penalty", production), ("lattice penalty", ModelLatticePenalty(model, lattice))):
        began = time.perf_counter()
        out = _bound(penalty, inputs, scene, grid, evaluation, {"start": start}, paths, False)
        print(f"  {label}: bound {out['dual_upper_bound']:,.0f} (SE {out['dual_upper_bound_se']:,.0f}); the start's "
              f"gap {out['start_gap']:.3%} (SE {out['start_gap_se']:.3%}); {time.perf_counter() - began:.0f} s; "
              f"warnings {out['bound_warnings']}", flush=True)


if __name__ == "__main__":
    snapo_ode.configure()
    counts = [int(x) for x in sys.argv[2].split(":")]
    main(sys.argv[1], counts[0], counts[-1], sys.argv[3], int(sys.argv[4]))
