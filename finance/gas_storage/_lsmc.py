"""The industry baseline: least-squares Monte Carlo (Longstaff-Schwartz, as in Boogert & de Jong
2008) on an inventory grid, and the perfect-foresight upper bound.

Inventory lives on `nodes` equally spaced levels 0, D, 2D, ..., capacity (D = capacity /
(nodes - 1)). A day's decision moves it by a whole number k of steps, allowed when the move
honours the hard constraints of `_model.py` at the start-of-day inventory: k D <= (1 -
fuel_loss) max_injection g_in(V / capacity), -k D <= max_withdrawal g_out(V / capacity), the
target inside [0, capacity] and one from which the terminal requirement can still be reached on
the grid. Rates that are not whole multiples of D are rounded down, so
the grid policy is feasible and its value a lower bound of the continuous problem's.

Backward over days, for every node at once: the realised value of the days after t (per path,
the cash flows of the decisions taken later along that path, discounted to day 0) is regressed
on 1, x, ..., x^degree, x = (spot_t / F_t - 1) / sd_t (the same span as a polynomial in spot_t;
standardised for conditioning), giving the continuation value of each target node as a function
of today's spot. Each path and node then takes the move that maximises today's cash plus the
fitted continuation, and is credited with the realised cash flows (Longstaff-Schwartz), not the
fitted ones. The in-sample value is the mean realised value from the start node on the paths
the regressions were fitted on; the out-of-sample value runs the fitted decision rule forward on
fresh paths.
"""

from typing import NamedTuple

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
from tqdm.auto import tqdm

from snapo_ode import InputError, Scene, check_count, time_function

from ._inputs import StorageInputs
from ._lp import solve_intrinsic
from ._model import GAS_EFFECTS, Schedule, flows_and_cash, kept_fraction, rate_fraction
from ._results import standard_error


class InventoryGrid(NamedTuple):
    """The inventory grid and its feasible moves. `spacing` D [MMBtu]; `moves`: the net moves in
    steps, shape (M,); `targets`: the node each move leads to, shape (N, M) (clipped to the grid
    where a move is not allowed); `allowed`: shape (T, N, M); `start_node`."""

    spacing: float
    moves: np.ndarray
    targets: np.ndarray
    allowed: np.ndarray
    start_node: int


def inventory_grid(inputs: StorageInputs, scene: Scene, nodes: int) -> InventoryGrid:
    """Build the grid of `nodes` levels and the moves allowed on each day from each node.

    **Raises:** `InputError` for fewer than 2 nodes, or when the initial inventory is not a grid
    level (it must be a whole multiple of capacity / (nodes - 1)).
    """
    nodes = check_count("nodes", nodes, 2, 100_000)
    capacity = float(inputs.capacity)
    spacing = capacity / (nodes - 1)
    start = float(inputs.initial_inventory) / spacing
    if abs(start - round(start)) > 1e-6:
        raise InputError(f"initial_inventory = {float(inputs.initial_inventory):g} is not on the grid of nodes = "
                         f"{nodes} (spacing {spacing:g}); choose nodes so that capacity / (nodes - 1) divides it.")
    kept = kept_fraction(inputs, scene)
    tolerance = 1e-9
    max_in = int(np.floor(float(kept * inputs.max_injection) / spacing + tolerance))
    max_out = int(np.floor(float(inputs.max_withdrawal) / spacing + tolerance))
    moves = np.arange(-max_out, max_in + 1)
    levels = spacing * np.arange(nodes)
    fill = jnp.asarray(levels / capacity)
    in_room = np.asarray(kept * inputs.max_injection * rate_fraction(inputs.injection_ratchet, fill, scene, None))
    out_room = np.asarray(inputs.max_withdrawal * rate_fraction(inputs.withdrawal_ratchet, fill, scene, None))
    step = moves * spacing
    raw_targets = np.arange(nodes)[:, None] + moves[None, :]
    rate_ok = (step[None] <= in_room[:, None] * (1 + tolerance) + tolerance) & (
        -step[None] <= out_room[:, None] * (1 + tolerance) + tolerance)
    inside = (raw_targets >= 0) & (raw_targets < nodes)
    targets = np.clip(raw_targets, 0, nodes - 1)
    # Backward over days: a node is viable if some allowed move leads to a viable node tomorrow,
    # the grid's own version of `inventory_floor` (rounded-down rates reach less).
    viable = levels >= float(inputs.terminal_inventory_min) - tolerance * capacity
    allowed = np.zeros((inputs.n_days,) + targets.shape, dtype=bool)
    for day in range(inputs.n_days - 1, -1, -1):
        allowed[day] = rate_ok & inside & viable[targets]
        viable = allowed[day].any(axis=1)
    start_node = int(round(start))
    if not viable[start_node]:
        raise InputError(f"terminal_inventory_min = {float(inputs.terminal_inventory_min):g} cannot be reached on the "
                         f"grid of nodes = {nodes} (rates rounded down to whole steps of {spacing:g}); use more nodes.")
    return InventoryGrid(spacing, moves, targets, allowed, start_node)


class LSMCFit(NamedTuple):
    """Fitted regressions and in-sample values. `coefficients`: shape (T, degree + 1, N), the
    continuation value [$] of ending day t at each node as a polynomial in the standardised spot;
    `spot_scale`: sd_t of spot_t / F_t on the fitting paths, shape (T,); `values`: realised
    value [$] from the start node per fitting path, shape (paths,)."""

    coefficients: jax.Array
    spot_scale: jax.Array
    values: jax.Array


def _move_cash(inputs: StorageInputs, scene: Scene, grid: InventoryGrid, price, day):
    """Discounted cash flow [$] of every move at `price`, shape price.shape + (M,)."""
    net = jnp.asarray(grid.moves * grid.spacing)
    return flows_and_cash(inputs, scene, net, price[..., None], day, None)[2]


def _basis(ratio, scale, degree: int):
    """1, x, ..., x^degree of x = (ratio - 1) / scale, shape ratio.shape + (degree + 1,)."""
    x = (ratio - 1.0) / scale
    return x[..., None] ** jnp.arange(degree + 1)


@eqx.filter_jit
def fit_lsmc(inputs: StorageInputs, scene: Scene, grid: InventoryGrid, prices: jax.Array, degree: int) -> LSMCFit:
    """Longstaff-Schwartz backward induction on `prices` of shape (paths, T) [$/MMBtu]."""
    n_days = inputs.n_days
    ratio = prices / inputs.forward_curve
    spot_scale = jnp.maximum(jnp.std(ratio, axis=0), 1e-12)
    targets = jnp.asarray(grid.targets)

    def back(later, today):
        day, price, ratio_t, scale, allowed = today
        basis = _basis(ratio_t, scale, degree)
        coefficients = jnp.linalg.lstsq(basis, later)[0]
        continuation = basis @ coefficients
        cash = _move_cash(inputs, scene, grid, price, day)[:, None, :]
        score = jnp.where(allowed[None], cash + continuation[:, targets], -jnp.inf)
        best = jnp.argmax(score, axis=-1)[..., None]
        realised = jnp.take_along_axis(cash + later[:, targets], best, axis=-1)[..., 0]
        return realised, coefficients

    nodes = grid.targets.shape[0]
    days = jnp.arange(n_days)
    later = jnp.zeros((prices.shape[0], nodes))
    values, coefficients = jax.lax.scan(back, later, (days, prices.T, ratio.T, spot_scale, jnp.asarray(grid.allowed)),
                                        reverse=True)
    return LSMCFit(coefficients, spot_scale, values[:, grid.start_node])


@eqx.filter_jit
def run_lsmc_policy(fit: LSMCFit, inputs: StorageInputs, scene: Scene, grid: InventoryGrid,
                    prices: jax.Array) -> Schedule:
    """The fitted decision rule run forward on `prices` of shape (paths, T), typically fresh
    paths (out of sample). Returns the hard schedule of every path, as `simulate` does."""
    degree = fit.coefficients.shape[1] - 1
    kept = kept_fraction(inputs, scene)
    targets = jnp.asarray(grid.targets)
    net_moves = jnp.asarray(grid.moves * grid.spacing)

    def forward(node, today):
        day, price, ratio_t, scale, coefficients, allowed = today
        basis = _basis(ratio_t, scale, degree)
        reachable = targets[node]  # (paths, M)
        continuation = jnp.einsum("pd,dpm->pm", basis, coefficients[:, reachable])
        cash = _move_cash(inputs, scene, grid, price, day)
        best = jnp.argmax(jnp.where(allowed[node], cash + continuation, -jnp.inf), axis=-1)
        chosen = lambda a: jnp.take_along_axis(a, best[:, None], axis=-1)[:, 0]  # noqa: E731
        return chosen(reachable), (node, chosen(cash), net_moves[best])

    start = jnp.full(prices.shape[0], grid.start_node)
    ratio = prices / inputs.forward_curve
    last, (nodes, cash, net) = jax.lax.scan(
        forward, start, (jnp.arange(inputs.n_days), prices.T, ratio.T, fit.spot_scale, fit.coefficients,
                         jnp.asarray(grid.allowed)))
    inventory = grid.spacing * jnp.concatenate([nodes, last[None]]).T
    return Schedule(cash.sum(0), jnp.maximum(net, 0.0).T / kept, jnp.maximum(-net, 0.0).T, inventory)


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
