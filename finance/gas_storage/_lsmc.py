"""The industry baseline: least-squares Monte Carlo (Longstaff-Schwartz, as in Boogert & de Jong
2008) with continuation values on an inventory grid, and the perfect-foresight upper bound.

Continuation values live on `nodes` equally spaced levels 0, D, 2D, ..., capacity (D = capacity /
(nodes - 1)) and are interpolated linearly in between; the inventory itself is continuous. A
day's decision chooses tomorrow's inventory among the grid levels inside the day's exact feasible
interval (`feasible_flows`: the ratchet-limited rates at the start-of-day inventory after fuel
loss, the room left, and the floor that keeps the terminal requirement reachable), the
interval's two ends (the largest feasible injection and withdrawal) and holding
(`candidate_inventories`). Today's cash is piecewise linear in tomorrow's inventory (kinked at
holding) and the interpolated continuation is linear between levels, so these candidates contain
the best decision over the whole continuous interval for the fitted continuation. No rate is
rounded to the grid: with ratchets, fuel loss, costs or discounting the rule keeps the
facility's whole flexibility, and every schedule it produces is feasible by construction.

Backward over days, for every level at once: the realised value of the days after t (per path,
the cash flows of the decisions taken later along that path, discounted to day 0; between levels
interpolated) is regressed on 1, x, ..., x^degree, x = (spot_t / F_t - 1) / sd_t (the same span as a
polynomial in spot_t; standardised for conditioning), giving the continuation value of each
level as a function of today's spot. Each path and level then takes the candidate that maximises
today's cash plus the fitted continuation, and is credited with the realised cash flows
(Longstaff-Schwartz), not the fitted ones. The in-sample value is the mean realised value at the
initial inventory on the paths the regressions were fitted on (interpolated when it lies between
levels); the out-of-sample value runs the fitted decision rule forward on fresh paths, from the
exact initial inventory. Below the floor (never reached by a feasible schedule) a level's
decision is the forced largest injection, which keeps its value finite for the interpolation.
"""

import math
from typing import NamedTuple

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
from tqdm.auto import tqdm

from snapo_ode import Scene, check_count, time_function

from ._inputs import StorageInputs
from ._lp import solve_intrinsic
from ._model import (GAS_EFFECTS, Schedule, feasible_flows, flows_and_cash, inventory_floor, kept_fraction,
                     largest_flows)
from ._results import standard_error

# Candidates that lie this close (relative to a day's largest flow) outside the feasible interval
# are kept and moved onto its end: round-off must not drop the level a rate lands on exactly.
_TOLERANCE = 1e-9


class InventoryGrid(NamedTuple):
    """The levels of the continuation values: `spacing` D [MMBtu], `nodes` N (levels 0, D, ...,
    capacity), and `window`: the offsets k of the levels floor(V / D) + k a day's decision may
    reach from inventory V, shape (W,), covering the largest withdrawal and injection."""

    spacing: float
    nodes: int
    window: np.ndarray

    @property
    def levels(self) -> np.ndarray:
        """The N levels [MMBtu]."""
        return self.spacing * np.arange(self.nodes)


def inventory_grid(inputs: StorageInputs, scene: Scene, nodes: int) -> InventoryGrid:
    """The grid of `nodes` levels from 0 to capacity, with the window of levels a day can reach.

    **Raises:** `InputError` for fewer than 2 nodes (or more than 100,000).
    """
    nodes = check_count("nodes", nodes, 2, 100_000)
    spacing = float(inputs.capacity) / (nodes - 1)
    largest_in, largest_out = largest_flows(inputs, scene)
    steps_in = min(math.ceil(largest_in / spacing), nodes)
    steps_out = min(math.ceil(largest_out / spacing), nodes)
    return InventoryGrid(spacing, nodes, np.arange(-steps_out, steps_in + 2))


def candidate_inventories(inputs: StorageInputs, scene: Scene, grid: InventoryGrid, inventory: jax.Array,
                          floor_tomorrow: jax.Array) -> tuple[jax.Array, jax.Array]:
    """Tomorrow's inventories a decision chooses among from start-of-day `inventory` [MMBtu] (any
    shape S): the grid levels inside the exact feasible interval, the interval's two ends and
    holding (or the nearest feasible inventory). Returns `(positions, valid)`, each shape S + (W + 3,);
    every valid position is feasible."""
    _, lower, upper = feasible_flows(inputs, scene, inventory, floor_tomorrow, None)
    low_end, high_end = (inventory + lower)[..., None], (inventory + upper)[..., None]
    base = jnp.floor(inventory / grid.spacing)[..., None]
    levels = (base + jnp.asarray(grid.window)) * grid.spacing
    slack = _TOLERANCE * jnp.maximum(inputs.max_injection, inputs.max_withdrawal)
    inside = (levels >= low_end - slack) & (levels <= high_end + slack)
    ends = jnp.concatenate([low_end, high_end, jnp.clip(inventory[..., None], low_end, high_end)], axis=-1)
    positions = jnp.concatenate([jnp.clip(levels, low_end, high_end), ends], axis=-1)
    return positions, jnp.concatenate([inside, jnp.ones(ends.shape, bool)], axis=-1)


def interpolate_levels(values: jax.Array, positions: jax.Array, spacing: float) -> jax.Array:
    """Values given at the levels 0, D, ... (last axis, N) interpolated linearly at `positions`
    [MMBtu] (flat beyond the ends): every row of `values` at all of them, shape
    values.shape[:-1] + positions.shape (`jax.vmap` it to read each row at its own)."""
    nodes = values.shape[-1]
    scaled = jnp.clip(positions / spacing, 0.0, nodes - 1)
    low = jnp.clip(jnp.floor(scaled).astype(int), 0, nodes - 2)
    weight = scaled - low
    return (1 - weight) * values[..., low] + weight * values[..., low + 1]


def _per_row(values: jax.Array, positions: jax.Array, spacing: float) -> jax.Array:
    """Row p of `values` (paths, N) at row p of `positions` (paths, M)."""
    return jax.vmap(interpolate_levels, in_axes=(0, 0, None))(values, positions, spacing)


class LSMCFit(NamedTuple):
    """Fitted regressions and in-sample values. `coefficients`: shape (T, degree + 1, N), the
    continuation value [$] of ending day t at each level as a polynomial in the standardised spot;
    `spot_scale`: sd_t of spot_t / F_t on the fitting paths, shape (T,); `values`: realised
    value [$] from the initial inventory per fitting path, shape (paths,)."""

    coefficients: jax.Array
    spot_scale: jax.Array
    values: jax.Array


def _basis(ratio, scale, degree: int):
    """1, x, ..., x^degree of x = (ratio - 1) / scale, shape ratio.shape + (degree + 1,)."""
    x = (ratio - 1.0) / scale
    return x[..., None] ** jnp.arange(degree + 1)


def level_decisions(inputs: StorageInputs, scene: Scene, grid: InventoryGrid, price, day, floor_tomorrow,
                    continuation, later=None, *, regressors=None):
    """One backward day at every level: each path (rows of `price`, shape (paths,)) and level
    takes the candidate maximising today's discounted cash plus `continuation` (paths, N), the
    value of tomorrow's levels it decides by, and is credited with the cash plus `later` (paths, N)
    at that candidate (None: `continuation`). With `regressors` (paths, B), `continuation` is
    the coefficients (B, N) of that value in them. Returns `(credited, decided)`, each (paths, N):
    the credited value and the maximised score.

    The candidates are a loop keeping the running maximum and its first candidate (as `argmax`
    does), levels by paths: no (paths, levels, candidates) array is formed (docs/dev/gas_storage_notes.md,
    Measurements behind the design)."""
    levels = jnp.asarray(grid.levels)
    positions, valid = candidate_inventories(inputs, scene, grid, levels, floor_tomorrow)  # (N, M)
    scaled = jnp.clip(positions / grid.spacing, 0.0, grid.nodes - 1)
    low = jnp.clip(jnp.floor(scaled).astype(int), 0, grid.nodes - 2)
    weight = scaled - low
    by_level = jnp.asarray(continuation).T  # (N, paths), or (N, B) of coefficients

    def candidate(m, carry):
        best, best_m = carry
        value = (1 - weight[:, m, None]) * by_level[low[:, m]] + weight[:, m, None] * by_level[low[:, m] + 1]
        if regressors is not None:  # the coefficients interpolated, then multiplied: no gather per path
            value = value @ regressors.T
        cash = flows_and_cash(inputs, scene, (positions[:, m] - levels)[:, None], price[None, :], day, None)[2]
        score = jnp.where(valid[:, m, None], cash + value, -jnp.inf)
        better = score > best
        return jnp.where(better, score, best), jnp.where(better, m, best_m)

    start = (jnp.full((levels.shape[0], price.shape[0]), -jnp.inf), jnp.zeros((levels.shape[0], price.shape[0]), int))
    best, best_m = jax.lax.fori_loop(0, positions.shape[1], candidate, start)
    decided = best.T
    if later is None:
        return decided, decided
    chosen = jnp.take_along_axis(positions, best_m, axis=1).T  # (paths, N)
    chosen_cash = flows_and_cash(inputs, scene, chosen - levels, price[:, None], day, None)[2]
    # `later` read at the chosen candidates only (docs/dev/gas_storage_notes.md, Measurements behind the design).
    credited = chosen_cash + _per_row(later, chosen[..., None], grid.spacing)[..., 0]
    return credited, decided


def start_value(inputs: StorageInputs, grid: InventoryGrid, values: jax.Array) -> jax.Array:
    """Day-0 `values` (..., N) at the initial inventory (interpolated between levels)."""
    return interpolate_levels(values, inputs.initial_inventory[None], grid.spacing)[..., 0]


@eqx.filter_jit
def fit_lsmc(inputs: StorageInputs, scene: Scene, grid: InventoryGrid, prices: jax.Array, degree: int) -> LSMCFit:
    """Longstaff-Schwartz backward induction on `prices` of shape (paths, T) [$/MMBtu]."""
    ratio = prices / inputs.forward_curve
    spot_scale = jnp.maximum(jnp.std(ratio, axis=0), 1e-12)
    floor = inventory_floor(inputs, scene, None)

    def back(later, today):
        day, price, ratio_t, scale, floor_tomorrow = today
        basis = _basis(ratio_t, scale, degree)
        coefficients = jnp.linalg.lstsq(basis, later)[0]
        realised, _ = level_decisions(inputs, scene, grid, price, day, floor_tomorrow, basis @ coefficients, later)
        return realised, coefficients

    later = jnp.zeros((prices.shape[0], grid.nodes))
    values, coefficients = jax.lax.scan(back, later, (jnp.arange(inputs.n_days), prices.T, ratio.T, spot_scale,
                                                      floor[1:]), reverse=True)
    return LSMCFit(coefficients, spot_scale, start_value(inputs, grid, values))


def continuation_decision(inputs: StorageInputs, scene: Scene, grid: InventoryGrid, inventory, price, day,
                          floor_tomorrow, value_of_levels) -> tuple[jax.Array, jax.Array]:
    """One day's decision of every path from `inventory` (paths,) at `price` (paths,): the
    candidate inventory maximising today's discounted cash plus `value_of_levels` (paths, N),
    the value of ending the day at each level, interpolated. Returns (tomorrow's inventory,
    today's cash), each (paths,)."""
    positions, valid = candidate_inventories(inputs, scene, grid, inventory, floor_tomorrow)  # (paths, M)
    cash = flows_and_cash(inputs, scene, positions - inventory[:, None], price[:, None], day, None)[2]
    value_after = _per_row(value_of_levels, positions, grid.spacing)
    best = jnp.argmax(jnp.where(valid, cash + value_after, -jnp.inf), axis=-1)[:, None]
    chosen = lambda a: jnp.take_along_axis(a, best, axis=-1)[:, 0]  # noqa: E731
    return chosen(positions), chosen(cash)


def first_argmax(values: jax.Array) -> jax.Array:
    """The index of the first maximum along the last axis, as `jnp.argmax` (finite `values`):
    the maximum, then the least index attaining it. Two plain reductions: on CPU, XLA's
    `argmax` fused after a matrix product is several times slower (docs/dev/gas_storage_notes.md,
    Measurements behind the design)."""
    index = jnp.arange(values.shape[-1])
    at_maximum = values == jnp.max(values, axis=-1, keepdims=True)
    return jnp.min(jnp.where(at_maximum, index, values.shape[-1] - 1), axis=-1)


def continuation_targets(inputs: StorageInputs, scene: Scene, value: jax.Array, positions: jax.Array, price: jax.Array,
                         day, spacing: float) -> tuple[jax.Array, jax.Array]:
    """The basestock targets of a continuation value: b_L = argmax_y [C(y) - p_in y] and
    b_U = argmax_{y >= b_L} [C(y) - p_out y] over `positions` (N,) [MMBtu] (tomorrow's candidate
    inventories), with `value` (rows, N) the continuation C there [$] and p_in, p_out today's
    discounted cash per unit injected and withdrawn at `price` (rows,) [$/MMBtu] (fuel and costs
    included). Returns (b_L, b_U), each (rows,) [MMBtu]."""
    step = jnp.asarray(spacing)
    # Cash per unit of inventory gained: injecting (negative) and withdrawing (positive, per unit lost).
    cash = flows_and_cash(inputs, scene, jnp.stack([step, -step]), price[:, None], day, None)[2] / step
    low = positions[first_argmax(value + cash[:, :1] * positions)]
    above = positions >= low[:, None]
    high = positions[first_argmax(jnp.where(above, value - cash[:, 1:] * positions, -jnp.inf))]
    return low, high


def schedule_of(inputs: StorageInputs, scene: Scene, inventory: jax.Array, cash: jax.Array) -> Schedule:
    """The hard `Schedule` of inventories (paths, T+1) and daily cash (T, paths)."""
    net = jnp.diff(inventory, axis=-1)
    kept = kept_fraction(inputs, scene)
    return Schedule(cash.sum(0), jnp.maximum(net, 0.0) / kept, jnp.maximum(-net, 0.0), inventory)


def run_continuation_policy(inputs: StorageInputs, scene: Scene, grid: InventoryGrid, prices: jax.Array,
                            continuation, per_day) -> Schedule:
    """A rule that each day moves every path (`prices`, shape (paths, T)) to the candidate
    inventory maximising today's cash plus `continuation(today, prices_t)` (paths, N), the value of
    ending the day at each level, interpolated. `per_day`: what `continuation` reads, leading axis
    T. Starts at the exact initial inventory; returns the hard schedule, as `simulate` does."""
    floor = inventory_floor(inputs, scene, None)

    def forward(inventory, today):
        day, price, floor_tomorrow, rest = today
        chosen, cash = continuation_decision(inputs, scene, grid, inventory, price, day, floor_tomorrow,
                                             continuation(rest, price))
        return chosen, (inventory, cash)

    start = jnp.broadcast_to(inputs.initial_inventory, prices.shape[:1])
    last, (inventory, cash) = jax.lax.scan(forward, start, (jnp.arange(inputs.n_days), prices.T, floor[1:], per_day))
    return schedule_of(inputs, scene, jnp.concatenate([inventory, last[None]]).T, cash)


@eqx.filter_jit
def run_lsmc_policy(fit: LSMCFit, inputs: StorageInputs, scene: Scene, grid: InventoryGrid,
                    prices: jax.Array) -> Schedule:
    """The fitted decision rule run forward on `prices` of shape (paths, T), typically fresh
    paths (out of sample). Returns the hard schedule of every path, as `simulate` does."""
    degree = fit.coefficients.shape[1] - 1
    ratio = prices / inputs.forward_curve

    def continuation(today, _):
        ratio_t, scale, coefficients = today
        return _basis(ratio_t, scale, degree) @ coefficients

    return run_continuation_policy(inputs, scene, grid, prices, continuation,
                                   (ratio.T, fit.spot_scale, fit.coefficients))


def perfect_foresight(inputs: StorageInputs, scene: Scene, prices, *, progress: bool = False) -> np.ndarray:
    """The value [$] of each path with its prices known in advance: the intrinsic LP (`_lp.py`)
    with the path as the curve, shape (paths,). Its mean bounds every non-anticipative policy's
    value from above."""
    deterministic = GAS_EFFECTS.scene(name for name in scene.active if name != "stochastic_spot")
    values = []
    for path in tqdm(np.asarray(prices), desc="perfect foresight LPs", disable=not progress, leave=False):
        path_inputs = eqx.tree_at(lambda i: i.forward_curve, inputs, jnp.asarray(path))
        values.append(solve_intrinsic(path_inputs, deterministic).value)
    return np.asarray(values)


def value_lsmc(inputs: StorageInputs, scene: Scene, fit_prices, eval_prices, *, nodes: int, degree: int) -> dict:
    """Fit the regressions on `fit_prices`, run the rule on `eval_prices` (both (paths, T)),
    and time both (median after a warm-up call; compile time apart).

    Returns `lsmc_in_sample, lsmc_in_sample_se, lsmc_out_of_sample, lsmc_se` [$],
    `lsmc_fit_seconds, lsmc_eval_seconds, lsmc_compile_seconds`, `lsmc_nodes, lsmc_degree`, and
    (not for JSON) under `"schedule"` the out-of-sample `Schedule`, `"fit"` the `LSMCFit` and
    `"grid"` the `InventoryGrid`.
    """
    check_count("degree", degree, 0, 12)
    grid = inventory_grid(inputs, scene, nodes)
    fit_timing, fit = time_function(fit_lsmc, inputs, scene, grid, fit_prices, int(degree), repeats=1)
    eval_timing, schedule = time_function(run_lsmc_policy, fit, inputs, scene, grid, eval_prices, repeats=1)
    return {
        "lsmc_in_sample": float(jnp.mean(fit.values)),
        "lsmc_in_sample_se": standard_error(fit.values),
        "lsmc_out_of_sample": float(jnp.mean(schedule.value)),
        "lsmc_se": standard_error(schedule.value),
        "lsmc_fit_seconds": fit_timing.median_seconds,
        "lsmc_eval_seconds": eval_timing.median_seconds,
        "lsmc_compile_seconds": fit_timing.compile_seconds + eval_timing.compile_seconds,
        "lsmc_nodes": int(nodes),
        "lsmc_degree": int(degree),
        "schedule": schedule,
        "fit": fit,
        "grid": grid,
    }
