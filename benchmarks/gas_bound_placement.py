"""How tight the dual bound is on every gas-family row, before and after the grid's placement
became a choice (docs/gas_storage.md, "Continuous policies, any facility").

For each case and B&dJ volatility: the factor lattice (200 levels) and its rule, a near-optimal
policy, on 1,000 paths; the rule charged the lattice penalty; the bound on the grid from 0 to
capacity (the placement before 2026-11-27) and on the placement `_bound_grid` keeps, on the same
paths. Prints one markdown row per case: lattice value, rule value, bound and the rule's gap
before, bound and gap after, the placement kept, seconds.

    .venv/bin/python benchmarks/gas_bound_placement.py   # ~40 min on a 2-core machine
"""

import time

import jax
import numpy as np

import snapo_ode
from finance.gas_storage._cases import BDJ_MEAN_REVERSION, BDJ_VOLATILITY
from finance.gas_storage._certificate import _bound_grid
from finance.gas_storage._dual import dual_bound, relaxed_grid, schedule_penalty
from finance.gas_storage._family import family
from finance.gas_storage._inputs import make_inputs
from finance.gas_storage._lattice import LatticePenalty, run_lattice_policy, solve_factor_lattice
from finance.gas_storage._lsmc import inventory_grid
from finance.gas_storage._model import spot_prices, stochastic_scene
from finance.gas_storage._versus_lsmc import trading_nodes

PATHS, KEY, LATTICE_POINTS = 1_000, 123, 200


def row(case, level: str) -> str:
    start = time.perf_counter()
    inputs = make_inputs(case.facility, case.curve, volatility=BDJ_VOLATILITY[level], mean_reversion=BDJ_MEAN_REVERSION)
    scene = stochastic_scene()
    prices = spot_prices(inputs, jax.random.normal(jax.random.key(KEY), (PATHS, inputs.n_days)))[0]
    grid = inventory_grid(inputs, scene, trading_nodes(inputs, 101))
    lattice = solve_factor_lattice(inputs, scene, grid, points=LATTICE_POINTS)
    rule = run_lattice_policy(lattice, inputs, scene, grid, prices)
    penalty = LatticePenalty(lattice)
    cells = []
    on_capacity = relaxed_grid(inputs, scene, paths=PATHS, placement="capacity")
    for relaxed in (on_capacity, _bound_grid(inputs, scene, grid, penalty, None, PATHS)[0]):
        bound = np.asarray(dual_bound(penalty, inputs, scene, grid, prices, relaxed=relaxed).values).mean()
        lower = np.asarray(rule.value) - np.asarray(schedule_penalty(penalty, inputs, grid, prices, rule.inventory,
                                                                     relaxed))
        cells += [f"{bound:,.0f}", f"{(bound - lower.mean()) / bound:.2%}"]
    placement = "0 to capacity" if relaxed == on_capacity else "anchored"
    return (f"| {case.name} | {level} | {float(lattice.value):,.0f} | {np.mean(rule.value):,.0f} | "
            f"{' | '.join(cells)} | {placement} | {time.perf_counter() - start:.0f} |")


if __name__ == "__main__":
    snapo_ode.configure()
    print("| case | vol | lattice value | lattice rule | bound before | rule's gap before | bound after | "
          "rule's gap after | placement kept | s |\n| --- | --- | ---: | ---: | ---: | ---: | ---: | ---: | --- | ---: |")
    for case in family():
        for level in ("low", "high"):
            print(row(case, level), flush=True)
