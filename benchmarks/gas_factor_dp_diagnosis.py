"""Where the two-factor gap lies (docs/dev/gas_storage_notes.md, "The two-factor gap, against a
dynamic program"): on family rows under the shipped two-factor model, the independent dynamic
program on (inventory, short-term, long-term factor) (`tests/gas_factor_dp.py`) gives the
optimal value on each grid given, and its own rule (on the last grid given), simulated on the bench's evaluation paths and
charged the bound's penalty, a lower bound paired with SNAPO, LSMC and the dual bound.

    PYTHONPATH=$PWD .venv/bin/python benchmarks/gas_factor_dp_diagnosis.py CASE PATHS[:TRAINING] [LEVELS,POINTS,NODES ...]

PATHS evaluation paths (the bound on all of them) and TRAINING paths (default PATHS) that LSMC,
the penalty and SNAPO fit and train on.
"""

import pathlib
import sys
import time

import jax
import numpy as np

import snapo_ode
from finance.gas_storage._bench_family import chosen_cases
from finance.gas_storage._bench_model_family import TRAIN_KEY, VALUE_KEY
from finance.gas_storage._inputs import make_inputs
from finance.gas_storage._lsmc import inventory_grid
from finance.gas_storage._model import Schedule, stochastic_scene
from finance.gas_storage._model_study import _bound, value_on_model
from finance.gas_storage._price_model_file import sample_price_model
from finance.gas_storage._price_models import model_paths
from finance.gas_storage._state_lsmc import run_state_lsmc
from finance.gas_storage._state_penalty import fit_state_lsmc_and_penalty
from finance.gas_storage._state_policy import simulate_state_policy
from finance.gas_storage._versus_lsmc import trading_nodes

sys.path.insert(0, str(pathlib.Path(__file__).resolve().parents[1] / "tests"))
from gas_factor_dp import two_factor_policy_cash, two_factor_value  # noqa: E402

RULE_GRID = (201, 41, 9)  # levels, points, nodes of the DP whose rule is simulated, unless grids are given


def bench_row(model, case, paths: int, train: int) -> tuple:
    """The family bench's inputs, `train` training and `paths` evaluation paths (seed 0), scene
    and LSMC grid for `case` under `model`."""
    inputs = make_inputs(case.facility, case.curve)
    key = jax.random.key(0)
    training = model_paths(model, inputs.forward_curve, train, jax.random.fold_in(key, TRAIN_KEY))
    evaluation = model_paths(model, inputs.forward_curve, paths, jax.random.fold_in(key, VALUE_KEY))
    scene = stochastic_scene()
    return inputs, training, evaluation, scene, inventory_grid(inputs, scene, trading_nodes(inputs, 101))


def main(name: str, paths: int, train: int, grids: list[tuple[int, int, int]]) -> None:
    model = sample_price_model("two-factor")
    case = chosen_cases(None, (name,), 0)[0]
    decay, q = np.asarray(model.decay()), np.asarray(model.step_covariance())
    for levels, points, nodes in grids:
        start = time.perf_counter()
        value = two_factor_value(case.facility, case.curve, decay, q, levels=levels, points=points, nodes=nodes)
        print(f"{name}: DP value {value:,.1f} (levels {levels}, points {points}, nodes {nodes}; "
              f"{time.perf_counter() - start:.0f} s)", flush=True)
    inputs, training, evaluation, scene, grid = bench_row(model, case, paths, train)
    out = value_on_model(model, inputs, training, evaluation, nodes=grid.nodes, rolling_paths=20, dual_paths=paths)
    policy = out.pop("policy")
    fit, penalty = fit_state_lsmc_and_penalty(model, inputs, scene, grid, training, 2)
    snapo = simulate_state_policy(policy, inputs, scene, evaluation, sharpness=None,
                                  start=policy.start_logits(inputs, scene, evaluation))
    levels, points, nodes = grids[-1] if grids else RULE_GRID  # the last grid's rule
    cash, inventory = two_factor_policy_cash(case.facility, case.curve, decay, q, np.asarray(evaluation.factors),
                                             levels=levels, points=points, nodes=nodes)
    rule = Schedule(jax.numpy.asarray(cash), None, None, jax.numpy.asarray(inventory))
    policies = {"snapo": snapo, "lsmc": run_state_lsmc(fit, inputs, scene, grid, evaluation), "dp_rule": rule}
    bound = _bound(penalty, inputs, scene, grid, evaluation, policies, paths, False)
    difference = np.asarray(cash) - np.asarray(snapo.value)
    print(f"{name} ({paths:,} paths, {train:,} training): SNAPO plain {out['snapo_out_of_sample']:,.0f}, DP rule plain {cash.mean():,.0f}, "
          f"DP rule - SNAPO {difference.mean():,.0f} (paired SE {difference.std(ddof=1) / np.sqrt(paths):,.0f})")
    for method in ("snapo", "lsmc", "dp_rule"):
        print(f"  {method}: control variate {bound[f'{method}_value_control_variate']:,.0f} "
              f"(SE {bound[f'{method}_value_control_variate_se']:,.0f}), gap {bound[f'{method}_gap']:.3%} "
              f"(SE {bound[f'{method}_gap_se']:.3%})")
    print(f"  bound {bound['dual_upper_bound']:,.0f} (SE {bound['dual_upper_bound_se']:,.0f}), relaxation "
          f"{bound['dual_relaxation']:.3%}, warnings {bound['bound_warnings']}", flush=True)


if __name__ == "__main__":
    snapo_ode.configure()
    counts = [int(x) for x in sys.argv[2].split(":")]
    main(sys.argv[1], counts[0], counts[-1], [tuple(int(x) for x in g.split(",")) for g in sys.argv[3:]])
