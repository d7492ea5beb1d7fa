"""How tight can the two-factor bound be, and what holds it back (docs/dev/gas_storage_notes.md,
"A slow facility's gap: the grid and the penalty")? On a family row under the shipped two-factor
model, the bound of `_dual.py` on the bench's evaluation paths with three penalties:

- `dp value`: w_t(n') = V_{t+1}(n', X_{t+1}) - E_t V_{t+1}(n', .)(X_t) from the independent dynamic
  program's own tables (`tests/gas_factor_dp.py`, Catmull-Rom between factor points, linear between
  levels). Its conditional mean is zero only to the DP's quadrature and interpolation, so this is a
  diagnostic of what a near-exact value function gives, not a certificate;
- `state lsmc`: the production penalty (`fit_state_penalty`, the state LSMC's value);
- `dp value, production basis`: the DP's V_{t+1} regressed on the production penalty's features
  (exact conditional mean zero): the production basis with a better value function.

Each bound is paired with the DP's rule and the state LSMC charged the same penalty.

    PYTHONPATH=$PWD .venv/bin/python benchmarks/gas_dp_penalty.py CASE PATHS[:TRAINING] LEVELS,POINTS,NODES [PER_FLOW]

PER_FLOW: the state LSMC's steps to a day's full flow (default `LEVELS_PER_FLOW`, the production default).
"""

import sys
import time

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
from gas_factor_dp_diagnosis import bench_row

import snapo_ode
from finance.gas_storage._bench_family import chosen_cases
from finance.gas_storage._dual import DUAL_WORK, dual_bound, relaxed_grid, schedule_penalty
from finance.gas_storage._lsmc import inventory_grid
from finance.gas_storage._model import Schedule, spot_prices
from finance.gas_storage._model_study import LEVELS_PER_FLOW, NODES_AT_LEAST
from finance.gas_storage._penalty import AbstractPenalty, _penalty_regression
from finance.gas_storage._price_model_file import sample_price_model
from finance.gas_storage._state_lsmc import fit_state_lsmc, run_state_lsmc, state_basis
from finance.gas_storage._state_penalty import (DEFAULT_SPOT_BASIS, StatePenalty, _features, _innovations,
                                                fit_state_penalty)
from finance.gas_storage._versus_lsmc import trading_nodes

from gas_factor_dp import _solve, two_factor_policy_cash  # on the path: gas_factor_dp_diagnosis puts tests/ there


def catmull_rom(table, axes, x):
    """`table` (N, G) on the square factor grid `axes` (2, points), at x (P, 2): (P, N), cubic: the
    weights of `tests/gas_factor_dp._cubic_weights`, in JAX, since the bound evaluates it on traced paths."""
    weights = []
    for dim in range(2):
        axis = axes[dim]
        step = axis[1] - axis[0]
        xi = jnp.clip(x[:, dim], axis[0], axis[-1])
        low = jnp.clip(jnp.floor((xi - axis[0]) / step).astype(int), 0, axis.shape[0] - 2)
        t = (xi - axis[0]) / step - low
        w = jnp.stack([(-t**3 + 2 * t**2 - t) / 2, (3 * t**3 - 5 * t**2 + 2) / 2, (-3 * t**3 + 4 * t**2 + t) / 2,
                       (t**3 - t**2) / 2], -1)
        weights.append((jnp.clip(low[:, None] + jnp.arange(-1, 3), 0, axis.shape[0] - 1), w))
    (i, wi), (j, wj) = weights
    return jnp.einsum("npab,pa,pb->pn", table[:, i[:, :, None] * axes.shape[1] + j[:, None, :]], wi, wj)


class DPValuePenalty(AbstractPenalty):
    """**Fields:** `later` V_{t+1} and `expected` E_t V_{t+1}, both (T, N, G) on the LSMC grid's
    N levels and the DP's factor grid (zero on the last day), and the grid's `axes` (2, points)."""

    later: jax.Array
    expected: jax.Array
    axes: jax.Array

    def daily(self, inputs, prices, paths=None):
        x = paths.factors
        x_next = jnp.concatenate([x[:, 1:], x[:, -1:]], 1)
        return jnp.swapaxes(x, 0, 1), jnp.swapaxes(x_next, 0, 1), self.later, self.expected

    def today(self, day_inputs):
        x, x_next, later, expected = day_inputs
        return catmull_rom(later, self.axes, x_next) - catmull_rom(expected, self.axes, x)


def dp_tables(solution, levels: np.ndarray, days: int) -> tuple[np.ndarray, np.ndarray]:
    """V_{t+1} and E_t V_{t+1} of the DP `solution` at the inventories `levels`, each (T, N, G)."""
    def at(table):
        return np.stack([np.interp(levels, solution.inventory, column) for column in table.T], 1)
    zero = np.zeros((levels.size, solution.continuations[0].shape[1]))
    later = np.stack([at(solution.values[t + 1]) if t < days - 1 else zero for t in range(days)])
    expected = np.stack([at(solution.continuations[t]) if t < days - 1 else zero for t in range(days)])
    return later, expected


def regressed_penalty(penalty: DPValuePenalty, fit, model, training, days: int) -> StatePenalty:
    """The DP's V_{t+1} on `training` regressed on the production penalty's features (degree 1)."""
    multipliers = state_basis(training, 1)
    state = training.state()
    features = jax.vmap(_features, in_axes=(1, 1))(multipliers(state), _innovations(model, DEFAULT_SPOT_BASIS,
                                                                                    training, days))
    predictable = jnp.swapaxes(fit.basis(state), 0, 1)
    later = jnp.concatenate([training.factors[:, 1:], training.factors[:, -1:]], 1)

    @eqx.filter_jit
    def day(later_table, x_next, basis, feature):
        return _penalty_regression(basis, feature, catmull_rom(later_table, penalty.axes, x_next))

    beta = jnp.stack([day(penalty.later[t], later[:, t], predictable[t], features[t]) for t in range(days)])
    return StatePenalty(model, DEFAULT_SPOT_BASIS, multipliers, beta.at[-1].set(0.0))


def main(name: str, paths: int, train: int, dp_grid: tuple[int, int, int], per_flow: int) -> None:
    model = sample_price_model("two-factor")
    case = chosen_cases(None, (name,), 0)[0]
    decay, q = np.asarray(model.decay()), np.asarray(model.step_covariance())
    levels, points, nodes = dp_grid
    start = time.perf_counter()
    solution = _solve(case.facility, case.curve, decay, q, levels, points, nodes, keep_values=True)
    print(f"{name}: DP value {solution.value:,.1f} (levels {levels}, points {points}, nodes {nodes}; "
          f"{time.perf_counter() - start:.0f} s)", flush=True)
    inputs, training, evaluation, scene, _ = bench_row(model, case, paths, train)
    grid = inventory_grid(inputs, scene, trading_nodes(inputs, NODES_AT_LEAST, per_flow))
    prices = spot_prices(inputs, evaluation)[0]
    fit = fit_state_lsmc(inputs, scene, grid, training, 2)
    cash, inventory = two_factor_policy_cash(case.facility, case.curve, decay, q, np.asarray(evaluation.factors),
                                             levels=levels, points=points, nodes=nodes)
    policies = {"dp rule": Schedule(jnp.asarray(cash), None, None, jnp.asarray(inventory)),
                "lsmc": run_state_lsmc(fit, inputs, scene, grid, evaluation)}
    oracle = DPValuePenalty(*map(jnp.asarray, dp_tables(solution, np.asarray(grid.levels), inputs.n_days)),
                            jnp.asarray(np.asarray(solution.axes)))
    penalties = {"dp value": oracle, "state lsmc": fit_state_penalty(fit, model, inputs, scene, grid, training),
                 "dp value, production basis": regressed_penalty(oracle, fit, model, training, inputs.n_days)}
    relaxed = relaxed_grid(inputs, scene, paths=paths, work=DUAL_WORK)
    print(f"  LSMC {grid.nodes} levels; bound grid {relaxed.nodes} levels (relaxation {relaxed.relaxation:.3%}); "
          f"{paths:,} paths, {train:,} training", flush=True)
    for label, penalty in penalties.items():
        upper = np.asarray(dual_bound(penalty, inputs, scene, grid, prices, relaxed=relaxed,
                                      price_paths=evaluation).values)
        line = f"  {label}: bound {upper.mean():,.0f} (SE {upper.std(ddof=1) / np.sqrt(paths):,.0f})"
        for method, schedule in policies.items():
            lower = np.asarray(schedule.value) - np.asarray(schedule_penalty(
                penalty, inputs, grid, prices, schedule.inventory, relaxed, evaluation))
            margin = upper - lower
            line += (f"; {method} {lower.mean():,.0f} (SE {lower.std(ddof=1) / np.sqrt(paths):,.0f}), gap "
                     f"{margin.mean() / upper.mean():.3%} (SE {margin.std(ddof=1) / np.sqrt(paths) / upper.mean():.3%})")
        print(line, flush=True)


if __name__ == "__main__":
    snapo_ode.configure()
    counts = [int(x) for x in sys.argv[2].split(":")]
    main(sys.argv[1], counts[0], counts[-1], tuple(int(x) for x in sys.argv[3].split(",")),
         int(sys.argv[4]) if len(sys.argv) > 4 else LEVELS_PER_FLOW)
