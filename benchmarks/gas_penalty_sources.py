"""What holds the two-factor bound back: the penalty's basis or the value function it stands for
(docs/dev/gas_storage_notes.md, "The penalty: its value function, not its basis")? On a family
row under the shipped two-factor model, the gap between the bound of `_dual.py` and the
independent dynamic program's rule (`tests/gas_factor_dp.py`) charged the same penalty, paired:

- `inner`: w_t(n') = V_{t+1}(n', X_{t+1}) - (1/M) sum_m V_{t+1}(n', a X_t + L z_m), with M
  antithetic inner draws z_m ~ N(0, I) independent of the path: an unbiased estimate of
  E_t V_{t+1}, so its conditional mean is exactly zero for any value function and the bound is
  valid without a basis. V is the DP's own value (against its quadrature penalty of
  `gas_dp_penalty.py`) or the state LSMC's (`level_decisions` on its continuation; against the
  production penalty `fit_state_penalty`, the same value regressed on the production basis).
- `degree`: the production penalty of state LSMCs of other degrees and training-path counts.

    PYTHONPATH=$PWD .venv/bin/python benchmarks/gas_penalty_sources.py CASE PATHS:TRAINING LEVELS,POINTS,NODES PER_FLOW inner M[,M]
    PYTHONPATH=$PWD .venv/bin/python benchmarks/gas_penalty_sources.py CASE PATHS:TRAINING LEVELS,POINTS,NODES PER_FLOW degree DEGREE:TRAINING[,...]
"""

import sys
import time

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
from gas_dp_penalty import DPValuePenalty, catmull_rom, dp_tables
from gas_factor_dp_diagnosis import bench_row

import snapo_ode
from finance.gas_storage._bench_family import chosen_cases
from finance.gas_storage._dual import DUAL_WORK, dual_bound, relaxed_grid, schedule_penalty
from finance.gas_storage._lsmc import inventory_grid, level_decisions
from finance.gas_storage._model import Schedule, inventory_floor, spot_prices
from finance.gas_storage._model_study import NODES_AT_LEAST
from finance.gas_storage._penalty import AbstractPenalty
from finance.gas_storage._price_model_file import sample_price_model
from finance.gas_storage._state_lsmc import StateBasis, fit_state_lsmc
from finance.gas_storage._state_penalty import fit_state_penalty
from finance.gas_storage._versus_lsmc import trading_nodes

from gas_factor_dp import _solve, two_factor_policy_cash  # on the path: gas_factor_dp_diagnosis puts tests/ there

INNER_KEY = 7


def _tomorrow(a):
    """a[t + 1] on row t along the leading axis (the last row repeated; its penalty is 0)."""
    return jnp.concatenate([a[1:], a[-1:]])


class InnerPenalty(AbstractPenalty):
    """w_t = V_{t+1}(X_{t+1}) - the mean of V_{t+1} over `inner` antithetic draws of X_{t+1} given
    X_t. Subclasses give `value(day_inputs, state)`: V_{t+1} at states (rows, k), shape (rows, N).
    **Fields:** the model's `decay` a (k,) and step `chol`esky factor L (k, k)."""

    decay: eqx.AbstractVar[jax.Array]
    chol: eqx.AbstractVar[jax.Array]
    inner: eqx.AbstractVar[int]

    def draws(self, paths):
        x = paths.factors
        half = jax.random.normal(jax.random.key(INNER_KEY), (x.shape[1], x.shape[0], self.inner // 2, x.shape[2]),
                                 x.dtype)
        return jnp.swapaxes(x, 0, 1), _tomorrow(jnp.swapaxes(x, 0, 1)), jnp.concatenate([half, -half], 2)

    def today(self, day_inputs):
        (x, x_next, z), rest = day_inputs[:3], day_inputs[3:]

        def add(m, total):
            return total + self.value(rest, self.decay * x + z[:, m] @ self.chol.T)

        later = self.value(rest, x_next)
        return later - jax.lax.fori_loop(0, self.inner, add, jnp.zeros_like(later)) / self.inner


class InnerDPPenalty(InnerPenalty):
    """V: the DP's table `later` (T, N, G) on its factor grid `axes`, Catmull-Rom between points."""

    later: jax.Array
    axes: jax.Array
    decay: jax.Array
    chol: jax.Array
    inner: int = eqx.field(static=True)

    def daily(self, inputs, prices, paths=None):
        return (*self.draws(paths), self.later)

    def value(self, rest, state):
        return catmull_rom(rest[0], self.axes, state)


class InnerLSMCPenalty(InnerPenalty):
    """V: the state LSMC's value of day t+1's levels, max over its moves of the cash at the spot
    of `state` plus its continuation regression (`_lsmc.level_decisions`), the rule `fit` frozen."""

    model: object
    fit: object
    scene: object
    grid: object
    inputs: object
    decay: jax.Array
    chol: jax.Array
    inner: int = eqx.field(static=True)

    def daily(self, inputs, prices, paths=None):
        n_days = inputs.n_days
        floor = inventory_floor(inputs, self.scene, None)[1:]  # the floor of the day after each day
        basis = self.fit.basis
        return (*self.draws(paths), _tomorrow(self.fit.coefficients), _tomorrow(basis.mean), _tomorrow(basis.scale),
                jnp.minimum(jnp.arange(n_days) + 1, n_days - 1), _tomorrow(floor),
                _tomorrow(self.model.loadings(n_days)), _tomorrow(self.model.log_variance(n_days)),
                _tomorrow(inputs.forward_curve), jnp.arange(n_days) < n_days - 1)

    def value(self, rest, state):
        coefficients, mean, scale, day, floor, loading, variance, forward, live = rest
        price = forward * jnp.exp(state @ loading - variance / 2)
        continuation = StateBasis(mean, scale, self.fit.basis.exponents)(state) @ coefficients
        value = level_decisions(self.inputs, self.scene, self.grid, price, day, floor, continuation)[1]
        return jnp.where(live, value, 0.0)


def main(name: str, paths: int, train: int, dp_grid: tuple[int, int, int], per_flow: int, mode: str,
         variants: list[str]) -> None:
    model = sample_price_model("two-factor")
    case = chosen_cases(None, (name,), 0)[0]
    decay, q = np.asarray(model.decay()), np.asarray(model.step_covariance())
    chol = jnp.asarray(np.linalg.cholesky(q))
    levels, points, nodes = dp_grid
    solution = _solve(case.facility, case.curve, decay, q, levels, points, nodes, keep_values=True)
    inputs, training, evaluation, scene, _ = bench_row(model, case, paths, train)
    grid = inventory_grid(inputs, scene, trading_nodes(inputs, NODES_AT_LEAST, per_flow))
    prices = spot_prices(inputs, evaluation)[0]
    cash, inventory = two_factor_policy_cash(case.facility, case.curve, decay, q, np.asarray(evaluation.factors),
                                             levels=levels, points=points, nodes=nodes)
    rule = Schedule(jnp.asarray(cash), None, None, jnp.asarray(inventory))
    relaxed = relaxed_grid(inputs, scene, paths=paths, work=DUAL_WORK)
    print(f"{name}: DP value {solution.value:,.0f} ({levels} levels); LSMC {grid.nodes} levels; bound grid "
          f"{relaxed.nodes} levels; {paths:,} paths, {train:,} training", flush=True)
    first = None

    def report(label, penalty):
        nonlocal first
        start = time.perf_counter()
        upper = np.asarray(dual_bound(penalty, inputs, scene, grid, prices, relaxed=relaxed,
                                      price_paths=evaluation).values)
        lower = np.asarray(rule.value) - np.asarray(schedule_penalty(penalty, inputs, grid, prices, rule.inventory,
                                                                     relaxed, evaluation))
        margin = (upper - lower) / upper.mean()
        line = (f"  {label}: bound {upper.mean():,.0f} (SE {upper.std(ddof=1) / np.sqrt(paths):,.0f}), DP rule "
                f"{lower.mean():,.0f}, gap {margin.mean():.3%} (SE {margin.std(ddof=1) / np.sqrt(paths):.3%})")
        if first is None:
            first = margin
        else:
            change = margin - first
            line += f", gap - first {change.mean():+.3%} (SE {change.std(ddof=1) / np.sqrt(paths):.3%})"
        print(line + f"; {time.perf_counter() - start:.0f} s", flush=True)

    def fitted(degree, count):
        subset = jax.tree_util.tree_map(lambda a: a[:count], training)
        return subset, fit_state_lsmc(inputs, scene, grid, subset, degree)

    if mode == "degree":
        for variant in variants:
            degree, count = (int(x) for x in variant.split(":"))
            subset, fit = fitted(degree, count)
            report(f"LSMC degree {degree}, {count:,} training", fit_state_penalty(fit, model, inputs, scene, grid,
                                                                                 subset))
        return
    later, expected = map(jnp.asarray, dp_tables(solution, np.asarray(grid.levels), inputs.n_days))
    axes = jnp.asarray(np.asarray(solution.axes))
    report("DP value, quadrature", DPValuePenalty(later, expected, axes))
    for inner in variants:
        report(f"DP value, inner {inner}", InnerDPPenalty(later, axes, jnp.asarray(decay), chol, int(inner)))
    fit = fitted(2, train)[1]
    report("LSMC value, production basis", fit_state_penalty(fit, model, inputs, scene, grid, training))
    for inner in variants:
        report(f"LSMC value, inner {inner}", InnerLSMCPenalty(model, fit, scene, grid, inputs, jnp.asarray(decay),
                                                              chol, int(inner)))


if __name__ == "__main__":
    snapo_ode.configure()
    counts = [int(x) for x in sys.argv[2].split(":")]
    main(sys.argv[1], counts[0], counts[-1], tuple(int(x) for x in sys.argv[3].split(",")), int(sys.argv[4]),
         sys.argv[5], sys.argv[6].split(","))
