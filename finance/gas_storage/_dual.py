"""An upper bound on the storage value by information relaxation (Brown, Smith & Sun 2010,
"Information relaxations and duality in stochastic dynamic programs", Operations Research 58(4);
for storage, Lai, Margot & Secomandi 2010, Operations Research 58(3)), valid for every
non-anticipative policy of the continuous problem: ratchets, fuel loss, costs and discounting
included.

On each evaluation path the holder is told the whole price path in advance and pays, for ending
day t at inventory y, the penalty w~_t(y): the linear interpolation, between the levels of the
bound's own grid, of w_t(y) = sum_p beta_{t,p}(y, x_t) [phi_p(S_{t+1}) - E_t phi_p(S_{t+1})] (`_penalty.py`,
`_lattice.py`), whose conditional expectation given day t is exactly zero at every level; the
interpolation weights depend on y alone, so w~ has mean zero for any y chosen with day-t
information. The path's problem, the most cash less penalty any inventory path can earn knowing
the prices, bounds that path's (cash - penalty) of every policy, so its mean bounds every
non-anticipative policy's value (the penalty has mean zero for them).

The path's problem over continuous inventories is solved through a relaxation whose optimum lies
on a grid (`RelaxedGrid`), so the bound errs only upwards. Fix the cells [jD, (j+1)D] the
inventory visits each day. Within them the problem is a linear program over (V_t, injected gas
g_t, withdrawn gas wd_t): cash is linear in g and wd (allowing both on one day only adds options),
the penalty linear in V_{t+1}, and V_{t+1} - V_t - g_t + wd_t = 0 is a network matrix, hence totally
unimodular. Relax each day's rate limits to whole numbers of steps no smaller than the largest
exact limit over the cell (`max_in_steps`, `max_out_steps`: ratchets and fuel loss at their
most generous in the cell, rounded up), capacity up and empty down to a level, the initial
inventory to its cell and the terminal requirement down to a level where they are not levels
(`PLACEMENTS` say where the grid is anchored, `_placed`): every bound is then a whole number
of steps, so the optimum of each cell's program is a grid path, and the dynamic program over grid paths with each level
allowed the rates of both cells beside it,

    U_T(n) = 0 (n >= terminal level, else -inf),
    U_t(n) = max_{-max_out(n) <= k <= max_in(n)} [cash_t(kD) - w~_t((n + k) D) + U_{t+1}(n + k)],

bounds the continuous problem from above, path by path. With cash concave in the net flow and
positive prices (the stochastic spot), moving k steps earns the most by injecting or withdrawing
alone, which `flows_and_cash` prices; cash is then c k, linear on each side of 0, so the best
move is a window maximum of c m + [U_{t+1} - w~_t](m) over the levels m within reach, found for
every level at once in O(levels log moves) (`_range_maxima.py`). The relaxation costs only
where a rate is not a whole number of steps or varies with fill inside a cell: the grid is
chosen (`relaxed_grid`) to make the largest relative rate increase (`RelaxedGrid.relaxation`)
small within a work budget, and the bound is reported with it.
"""

import math
from typing import Literal, NamedTuple

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np

from snapo_ode import InputError, Scene

from ._inputs import StorageInputs
from ._lsmc import InventoryGrid, _per_row, interpolate_levels
from ._model import flows_and_cash, kept_fraction
from ._penalty import AbstractPenalty
from ._range_maxima import range_maxima

DUAL_WORK = 2e10  # levels x sweeps x paths x days of the bound's dynamic program, at most (`dual_work`)
DUAL_NODES = (101, 40_001)  # the range of level counts `relaxed_grid` searches
CHUNK_CELLS = 80_000  # paths x levels of one chunk of the bound's program: its arrays stay in cache (measured fastest)
EVERY_COUNT_TO = 2_001  # every count up to this is tried (one whose steps divide the rates is found), beyond 2^(1/8) apart
Placement = Literal["ends", "terminal", "capacity"]  # where the bound's grid is anchored (`_placed`)
PLACEMENTS: tuple[Placement, ...] = ("ends", "terminal", "capacity")


class RelaxedGrid(NamedTuple):
    """The bound's grid: `spacing` D [MMBtu], `nodes` and `first_level` L_0 in (-D, 0] [MMBtu]
    (levels L_0, L_0 + D, ..., the first at or above capacity); per level,
    `max_in_steps` and `max_out_steps`, the relaxed daily rates in whole steps (tuples of N, so
    that the grid is static under `jit`);
    `terminal_node`, the lowest level allowed at the end; `start_nodes`, the levels beside the
    initial inventory (equal when it is a level); `relaxation`, the largest relative
    increase of a rate over its exact value at a level (0: the relaxation is exact)."""

    spacing: float
    nodes: int
    max_in_steps: tuple[int, ...]
    max_out_steps: tuple[int, ...]
    terminal_node: int
    start_nodes: tuple[int, int]
    relaxation: float
    first_level: float = 0.0

    @property
    def levels(self) -> np.ndarray:
        return self.first_level + self.spacing * np.arange(self.nodes)


def _cell_maxima(table: np.ndarray, edges: np.ndarray) -> np.ndarray:
    """The largest value of the piecewise-linear `table` [[x, y], ...] over each cell [edges[i],
    edges[i + 1]], shape (len(edges) - 1,)."""
    at_edges = np.interp(edges, table[:, 0], table[:, 1])
    maxima = np.maximum(at_edges[:-1], at_edges[1:])
    for x, y in table:
        cell = np.searchsorted(edges, x, side="right") - 1
        if 0 <= cell < maxima.size and edges[cell] < x < edges[cell + 1]:
            maxima[cell] = max(maxima[cell], y)
    return maxima


def _relaxed(inputs: StorageInputs, scene: Scene, spacing: float, anchor: float) -> RelaxedGrid:
    """The grid of step `spacing` with a level at `anchor` [MMBtu], from the level at or below 0 to
    the first at or above capacity."""
    capacity = float(inputs.capacity)
    first = anchor - math.floor(anchor / spacing + 1e-9) * spacing
    first = first - spacing if first > 1e-9 * spacing else 0.0
    nodes = math.ceil((capacity - first) / spacing - 1e-9) + 1
    edges = (first + spacing * np.arange(nodes)) / capacity
    kept = float(kept_fraction(inputs, scene))
    ratchets = scene.has("ratchets")
    steps = []
    relaxation = 0.0
    for largest, table in ((kept * float(inputs.max_injection), np.asarray(inputs.injection_ratchet)),
                           (float(inputs.max_withdrawal), np.asarray(inputs.withdrawal_ratchet))):
        if not ratchets:
            table = np.array([[0.0, 1.0], [1.0, 1.0]])
        cells = largest * _cell_maxima(table, edges)
        per_level = np.maximum(np.concatenate([cells[:1], cells]), np.concatenate([cells, cells[-1:]]))
        whole = np.ceil(per_level / spacing - 1e-9).astype(int)
        exact = largest * np.interp(edges, table[:, 0], table[:, 1])
        if largest > 0:
            relaxation = max(relaxation, float(np.max(whole * spacing - exact)) / largest)
        steps.append(tuple(int(s) for s in np.minimum(whole, nodes - 1)))
    terminal = math.floor((float(inputs.terminal_inventory_min) - first) / spacing + 1e-9)
    start = (float(inputs.initial_inventory) - first) / spacing
    start_nodes = (min(math.floor(start + 1e-9), nodes - 1), min(math.ceil(start - 1e-9), nodes - 1))
    return RelaxedGrid(spacing, nodes, steps[0], steps[1], terminal, start_nodes, relaxation, first)


def _placed(inputs: StorageInputs, scene: Scene, count: int, placement: Placement) -> RelaxedGrid:
    """The grid of about `count` levels, placed (`placement`):
    - "ends": on the terminal requirement and, where a spacing between 1/2 and 3/2 of capacity /
      (count - 1) divides the distance to it, on the initial inventory too, with up to a step of
      room beyond each end of [0, capacity];
    - "terminal": on the terminal requirement, spacing capacity / (count - 1) (the start relaxed
      to its cell), where dividing the distance would coarsen the grid;
    - "capacity": levels 0 to capacity, the start relaxed to its cell and the end down to a level
      (up to a step of free gas), no room beyond.
    Which is tightest depends on the case (`tightest_grid`)."""
    spacing = float(inputs.capacity) / (count - 1)
    if placement == "capacity":
        return _relaxed(inputs, scene, spacing, 0.0)
    terminal, start = float(inputs.terminal_inventory_min), float(inputs.initial_inventory)
    steps = round(abs(start - terminal) / spacing)
    if placement == "ends" and steps >= 1:
        spacing = abs(start - terminal) / steps
    return _relaxed(inputs, scene, spacing, terminal)


def relaxed_grid(inputs: StorageInputs, scene: Scene, nodes: int | None = None, *, paths: int = 1,
                 work: float = DUAL_WORK, placement: Placement = "ends") -> RelaxedGrid:
    """The bound's grid with about `nodes` levels (`_placed`, placed by `placement`); None
    chooses, among the counts `_counts` tries, the one with the smallest relaxation whose work
    (`dual_work`, for `paths` paths) stays within `work` (the fewest levels among equals): 101
    levels on B&dJ, whose rates are whole steps of 2,500 MWh. Where rates are not whole steps the
    relaxation shrinks only as 1 / levels (the work grows as levels x log levels), so such a
    bound is valid but loose by about the relaxation's share of the rates' value:
    `RelaxedGrid.relaxation` says by how much the rates were raised.

    **Raises:** `InputError` for fewer than 2 nodes.
    """
    if nodes is not None:
        if nodes < 2:
            raise InputError(f"dual nodes = {nodes}: the bound's grid needs at least 2 levels.")
        return _placed(inputs, scene, int(nodes), placement)
    return relaxed_grids(inputs, scene, (paths,), work=work, placement=placement)[paths]


def relaxed_grids(inputs: StorageInputs, scene: Scene, paths: tuple[int, ...], *, work: float = DUAL_WORK,
                  placement: Placement = "ends") -> dict[int, RelaxedGrid]:
    """`relaxed_grid` for each of several path counts, from one walk over the counts (each grid
    is built once: a walk takes 1-2.5 s on a 90-day ratcheted facility)."""
    best: dict[int, RelaxedGrid | None] = dict.fromkeys(paths)
    searching = set(paths)
    for count in _counts():
        if not searching:
            break
        grid = _placed(inputs, scene, count, placement)
        for budget in list(searching):
            if dual_work(grid, budget, inputs.n_days) > work and best[budget] is not None:
                searching.discard(budget)
                continue
            if best[budget] is None or grid.relaxation < best[budget].relaxation - 1e-12:
                best[budget] = grid
            if best[budget].relaxation == 0.0:
                searching.discard(budget)
    return best


def _counts():
    """The level counts `relaxed_grid` tries, in increasing order."""
    yield from range(DUAL_NODES[0], EVERY_COUNT_TO + 1)
    count = EVERY_COUNT_TO
    while count < DUAL_NODES[1]:
        count = min(math.ceil(count * 2 ** 0.125), DUAL_NODES[1])
        yield count


def dual_work(relaxed: RelaxedGrid, paths: int, days: int) -> float:
    """The bound's dynamic program's work on `relaxed`: levels x sweeps x paths x days, a sweep
    being one pass over the levels of one path and day (`range_maxima` makes log2 of the
    furthest move's sweeps per direction, and a few more for the windows' ends, the choice
    between the table's orders and the sums)."""
    sweeps = 6 + sum(math.ceil(math.log2(max(steps) + 1)) for steps in (relaxed.max_in_steps, relaxed.max_out_steps))
    return relaxed.nodes * sweeps * paths * days


class DualBound(NamedTuple):
    """`values`: the path problem's optimum per path [$], shape (paths,), whose mean bounds from
    above every non-anticipative policy's value, continuous ones included; `grid`: the
    `RelaxedGrid` it was solved on (`schedule_penalty` needs it to charge a policy the same
    penalty)."""

    values: jax.Array
    grid: RelaxedGrid


@eqx.filter_jit
def _dual_values(penalty: AbstractPenalty | None, inputs: StorageInputs, scene: Scene, grid: InventoryGrid,
                 relaxed: RelaxedGrid, prices: jax.Array, paths=None) -> jax.Array:
    level = np.arange(relaxed.nodes)
    highest, lowest = level + np.asarray(relaxed.max_in_steps), level - np.asarray(relaxed.max_out_steps)
    levels = jnp.asarray(relaxed.levels)
    one_step = jnp.asarray([relaxed.spacing, -relaxed.spacing])
    daily = None if penalty is None else penalty.daily(inputs, prices, paths)

    def back(later, today):
        day, price, day_inputs = today
        after = later
        if penalty is not None:
            after = later - interpolate_levels(penalty.today(day_inputs), levels, grid.spacing)
        # Cash is linear in the steps moved on each side of 0: c_in k injecting, c_out k withdrawing
        # (k < 0), so the best move within reach is a window maximum of c m + after(m) over levels m.
        cash = flows_and_cash(inputs, scene, one_step, price[:, None], day, None)[2]
        c_in, c_out = cash[:, :1] * level, -cash[:, 1:] * level
        injecting = range_maxima(c_in + after, level, highest) - c_in
        withdrawing = range_maxima(c_out + after, lowest, level) - c_out
        return jnp.maximum(injecting, withdrawing), None

    terminal = jnp.where(jnp.arange(relaxed.nodes) >= relaxed.terminal_node, 0.0, -jnp.inf)
    later = jnp.broadcast_to(terminal, (prices.shape[0], relaxed.nodes))
    values, _ = jax.lax.scan(back, later, (jnp.arange(inputs.n_days), prices.T, daily), reverse=True)
    return jnp.maximum(values[:, relaxed.start_nodes[0]], values[:, relaxed.start_nodes[1]])


def dual_bound(penalty: AbstractPenalty | None, inputs: StorageInputs, scene: Scene, grid: InventoryGrid,
               prices: jax.Array, *, relaxed: RelaxedGrid | None = None, chunk: int = 2_000,
               price_paths=None) -> DualBound:
    """Solve every path's relaxed penalised problem on `prices` of shape (paths, T) [$/MMBtu]
    (evaluation paths, not those the penalty was fitted on; positive, as the stochastic spot's),
    `chunk` paths at a time. `grid`: the levels the penalty is given on; `relaxed`: the bound's
    grid (default `relaxed_grid`); fewer than `chunk` at a time on a grid of more than
    CHUNK_CELLS / `chunk` levels. `penalty=None` gives perfect foresight (relaxed: equal to
    `perfect_foresight`'s LP when the relaxation is exact). `price_paths`: the same paths as
    `PricePaths`, for a penalty that reads the price model's state (`AbstractPenalty.daily`)."""
    relaxed = relaxed_grid(inputs, scene, paths=prices.shape[0]) if relaxed is None else relaxed
    paths = prices.shape[0]
    size = min(chunk, paths, max(1, CHUNK_CELLS // relaxed.nodes))
    parts = []
    for start in range(0, paths, size):
        block = prices[start:start + size]
        padded = jnp.concatenate([block, jnp.broadcast_to(block[-1:], (size - block.shape[0],) + block.shape[1:])])
        state = None if price_paths is None else _padded(price_paths[start:start + size], size)
        parts.append(_dual_values(penalty, inputs, scene, grid, relaxed, padded, state)[:block.shape[0]])
    return DualBound(jnp.concatenate(parts), relaxed)


def _padded(paths, size: int):
    """`paths` (a `PricePaths` block) with its last path repeated up to `size` paths."""
    rows = jnp.minimum(jnp.arange(size), paths.shape[0] - 1)
    return paths[rows]


@eqx.filter_jit
def schedule_penalty(penalty: AbstractPenalty, inputs: StorageInputs, grid: InventoryGrid, prices: jax.Array,
                     inventory: jax.Array, relaxed: RelaxedGrid | None = None, paths=None) -> jax.Array:
    """The total penalty sum_t w_t(V_{t+1}) [$] paid by schedules with inventories `inventory` of
    shape (paths, T+1) [MMBtu] (as in `Schedule`): w interpolated linearly between the levels of
    `relaxed` (the bound's grid, as `dual_bound` charges it) or, without it, of `grid`; shape
    (paths,). Zero mean for a non-anticipative policy, so cash - penalty is an unbiased,
    lower-variance estimate of its value, and the bound's path value >= cash - penalty path by path."""
    spacing = grid.spacing if relaxed is None else relaxed.spacing
    nodes = grid.nodes if relaxed is None else relaxed.nodes
    first = 0.0 if relaxed is None else relaxed.first_level

    def add(total, today):
        day_inputs, where = today
        per_level = penalty.today(day_inputs)
        low = jnp.clip(jnp.floor((where - first) / spacing), 0, nodes - 2)
        weight = jnp.clip((where - first) / spacing - low, 0.0, 1.0)
        ends = _per_row(per_level, first + jnp.stack([low, low + 1], -1) * spacing, grid.spacing)
        return total + (1 - weight) * ends[:, 0] + weight * ends[:, 1], None

    total, _ = jax.lax.scan(add, jnp.zeros(prices.shape[0]), (penalty.daily(inputs, prices, paths),
                                                              inventory[:, 1:].T))
    return total


def tightest_grid(penalty: AbstractPenalty | None, inputs: StorageInputs, scene: Scene, grid: InventoryGrid,
                  candidates: list[RelaxedGrid], pilot_prices: jax.Array, pilot_paths=None) -> RelaxedGrid:
    """The candidate grid whose bound is lowest on `pilot_prices` (paths, T): paths of their own,
    not the bound's, so that the choice leaves the bound valid and unbiased (the lower of two
    bounds on the same paths would be biased low, and a per-path minimum is no bound: each grid
    charges its own interpolation of the penalty). A grid on the ends wins where a step of free
    gas is worth more than the room it adds (low volatility, off-grid ends); one on [0, capacity]
    where the room is traded daily (fast facilities at high volatility); one on the terminal
    requirement alone where dividing the distance to the start would coarsen the grid."""
    distinct = list(dict.fromkeys(candidates))
    if len(distinct) == 1:
        return distinct[0]
    means = [float(jnp.mean(dual_bound(penalty, inputs, scene, grid, pilot_prices, relaxed=candidate,
                                       price_paths=pilot_paths).values))
             for candidate in distinct]
    return distinct[int(np.argmin(means))]
