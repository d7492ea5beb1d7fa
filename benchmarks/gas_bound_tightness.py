"""How tight the dual bound is on every gas-family row (docs/gas_storage.md, "Window maxima,
finer grids, a finer penalty"): the certificate as `snapo gas --lsmc` and `snapo bench gas-family` run it
(`_certificate.duality_gaps`: the factor lattice on the finest inventory grid its budget allows,
its rule charged the penalty, the bound on the grid and paths its budget allows), with the
intrinsic schedule beside it. One markdown row per case and B&dJ volatility: the lattice's
inventory levels, its rule's value (control variate), the bound, the rule's gap with its
standard error, the bound's levels, relaxation and paths, seconds.

    .venv/bin/python benchmarks/gas_bound_tightness.py [CASE ...]   # all 14 cases by default
"""

import sys
import time

import jax

import snapo_ode
from finance.gas_storage._cases import BDJ_MEAN_REVERSION, BDJ_VOLATILITY
from finance.gas_storage._certificate import duality_gaps, intrinsic_schedule
from finance.gas_storage._family import family
from finance.gas_storage._inputs import make_inputs
from finance.gas_storage._lattice import lattice_grid
from finance.gas_storage._lp import solve_intrinsic
from finance.gas_storage._lsmc import inventory_grid
from finance.gas_storage._model import deterministic_scene, spot_prices, stochastic_scene
from finance.gas_storage._versus_lsmc import trading_nodes

PATHS, KEY = 2_000, 123


def row(case, level: str) -> str:
    start = time.perf_counter()
    inputs = make_inputs(case.facility, case.curve, volatility=BDJ_VOLATILITY[level], mean_reversion=BDJ_MEAN_REVERSION)
    scene = stochastic_scene()
    shocks = jax.random.normal(jax.random.key(KEY), (PATHS, inputs.n_days))
    grid = inventory_grid(inputs, scene, trading_nodes(inputs, 101))
    intrinsic = intrinsic_schedule(inputs, scene, solve_intrinsic(inputs, deterministic_scene()),
                                   spot_prices(inputs, shocks)[0])
    out = duality_gaps(inputs, scene, grid, shocks, {"intrinsic": intrinsic})
    return (f"| {case.name} | {level} | {lattice_grid(inputs, scene, grid).nodes:,} | {out['lattice_value_control_variate']:,.0f} | "
            f"{out['dual_upper_bound']:,.0f} | {out['lattice_gap']:.2%} ({out['lattice_gap_se']:.3%}) | "
            f"{out['dual_grid_nodes']:,} | {out['dual_relaxation']:.2%} | {out['dual_paths']:,} | "
            f"{time.perf_counter() - start:.0f} |")


if __name__ == "__main__":
    snapo_ode.configure()
    names = sys.argv[1:]
    print("| case | vol | lattice levels | lattice rule | dual bound | rule's gap (SE) | bound levels | relaxation "
          "| bound paths | s |\n| --- | --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: |")
    for case in family():
        if names and case.name not in names:
            continue
        for level in ("low", "high"):
            print(row(case, level), flush=True)
