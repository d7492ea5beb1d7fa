"""The dual bound's penalty from the factor lattice's value (`_model_lattice.py`), for any
Gaussian price model:

    w_t(n') = V~_{t+1}(n', z_{t+1}) - E[V~_{t+1}(n', z_{t+1}) | z_t],

V~ the lattice's tensor-product piecewise-linear value at the path's coordinates z = U^-1 X.
The expectation is exact (`hat_expectations`, one axis at a time, as the lattice's own backward
pass takes it, but at the path's z_t rather than at a node), so w has conditional mean zero
under the model and the bound (`_dual.py`) is valid whatever the lattice's accuracy; the
accuracy decides only how tight the bound is. Each path and day costs G^k N multiply-adds
(G points per factor, N inventory levels), `CHUNK_PATHS` paths at a time.

Which penalty bounds more tightly, this one, the state LSMC's regression (`_state_penalty.py`) or
an even blend of the two (`_penalty.BlendedPenalty`), depends on the contract: the study decides
(`_model_study._chosen_penalty`) by the LSMC rule's gap under each (`pilot_gaps`) on pilot paths
of the model, fresh: not the evaluation's (the bound reported stays an unbiased estimate of a valid bound) and not the
training paths the state penalty was fitted on (its bound there is biased low by the fit).
"""

from typing import ClassVar

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np

from snapo_ode import Scene

from ._dual import RelaxedGrid, dual_bound, schedule_penalty
from ._inputs import StorageInputs
from ._lsmc import InventoryGrid, interpolate_levels, inventory_grid
from ._model import Schedule, spot_prices
from ._model_lattice import (
    MODEL_LATTICE_POINTS,
    ModelLattice,
    _coordinates,
    _degenerate,
    hat_expectations,
    interpolate_grid,
    lattice_coordinates,
)
from ._paths import PricePaths
from ._penalty import AbstractPenalty
from ._price_models import AbstractPriceModel
from ._results import standard_error
from ._versus_lsmc import trading_nodes

# The most numbers T x G^k x N the penalty's value tables may hold (3.2 GB in float64); the same
# count bounds the bound's work per path and policy (G^k N per day).
PENALTY_TABLE_SIZE = 4e8
# The fewest points per factor the penalty's lattice takes; coarser, the state penalty alone.
PENALTY_POINTS_AT_LEAST = 9
# The penalty lattice's own inventory grid, where the start's does not fit (`penalty_lattice`): levels
# to a day's full flow, and the fewest levels (docs/dev/gas_storage_notes.md, "The lattice's value as
# the bound's penalty").
PENALTY_LEVELS_PER_FLOW, PENALTY_LEVELS_AT_LEAST = 1, 26
# Paths contracted at once (memory: CHUNK_PATHS x G^(k-1) x N numbers).
CHUNK_PATHS = 64
# The fresh paths of the model on which the penalties' bounds are compared (`pilot_gaps`; no more
# than the bound itself runs on).
PILOT_PATHS = 500
# The state penalty's share in the blend the pilot also tries (`_penalty.BlendedPenalty`): even, the
# two being of like accuracy where the blend matters (docs/dev/gas_storage_notes.md, "The lattice's
# value as the bound's penalty").
BLEND_WEIGHT = 0.5


class ModelLatticePenalty(AbstractPenalty):
    """**Fields:** the price `model` (named in the bound's fields); `unit` U, `drift` M and `sd`
    D of the coordinates (`_model_lattice._coordinates`); `axes` (k, G); `values`: the lattice's
    V_t, shape (T, G, ..., G, N) [$] (the same buffer, not a copy: it is the memory's bulk);
    `levels`: where the lattice was solved on a grid of its own (`lattice_grid`, of `spacing`
    [MMBtu]), the levels of the bound's `grid` [MMBtu] at which `today` reads it (linearly, a
    function of the level alone, so the mean stays zero), else None."""

    label: ClassVar[str] = "factor lattice value"
    model: AbstractPriceModel
    unit: jax.Array
    drift: jax.Array
    sd: jax.Array
    axes: jax.Array
    values: jax.Array
    levels: jax.Array | None
    spacing: float = eqx.field(static=True)

    def __init__(self, model: AbstractPriceModel, lattice: ModelLattice, lattice_grid: InventoryGrid | None = None,
                 grid: InventoryGrid | None = None):
        if lattice.values is None:
            raise ValueError("the penalty needs the lattice's value tables: solve_model_lattice(..., keep_values=True)")
        self.model = model
        self.unit, self.drift, self.sd = _coordinates(model)
        self.axes, self.values = lattice.axes, lattice.values
        own = lattice_grid is not None and (lattice_grid.spacing, lattice_grid.nodes) != (grid.spacing, grid.nodes)
        self.levels = jnp.asarray(grid.levels) if own else None
        self.spacing = float(lattice_grid.spacing) if own else 0.0

    def daily(self, inputs: StorageInputs, prices: jax.Array, paths=None):
        if paths is None or paths.factors is None:
            raise ValueError("a ModelLatticePenalty needs the paths' factors (PricePaths with factors)")
        z = jnp.swapaxes(lattice_coordinates(self.unit, paths.factors), 0, 1)  # (T, paths, k)
        return z, jnp.concatenate([z[1:], z[-1:]]), jnp.arange(inputs.n_days)

    def later(self, day) -> jax.Array:
        """V_{day+1}, zero on the last day: shape (G, ..., G, N)."""
        last = self.values.shape[0] - 1
        return jnp.where(day < last, self.values[jnp.minimum(day + 1, last)], 0.0)

    def today(self, day_inputs) -> jax.Array:
        z, following, day = day_inputs
        table = self.later(day)

        def expected(z_path):  # E[V~(z_{t+1}) | z_t] of one path, shape (N,)
            mean = self.drift @ z_path
            out = table
            for d in range(self.axes.shape[0]):
                out = jnp.tensordot(hat_expectations(self.axes[d], mean[d], self.sd[d]), out, axes=1)
            return out

        out = interpolate_grid(self.axes, table, following) - jax.lax.map(expected, z, batch_size=CHUNK_PATHS)
        return out if self.levels is None else interpolate_levels(out, self.levels, self.spacing)


def penalty_lattices(model: AbstractPriceModel, inputs: StorageInputs, scene: Scene, grid: InventoryGrid,
                     start_points: int | None) -> list[tuple[int, InventoryGrid]]:
    """The penalty lattices to try, as (points per factor, inventory grid): the start's lattice
    (`start_points` on `grid`, one lattice for both) where its tables fit PENALTY_TABLE_SIZE;
    else the most odd count of points that fits on `grid` and, where `grid` has more levels than
    PENALTY_LEVELS_PER_FLOW to a day's full flow (a slow facility's: the state LSMC takes four),
    the most that fit on a grid of that many (at least PENALTY_LEVELS_AT_LEAST): the memory
    spent on the factors rather than on the levels. Which bounds more tightly depends on the
    contract (docs/dev/gas_storage_notes.md, "The lattice's value as the bound's penalty"), so
    the pilot decides (`pilot_gaps`). Each has at least PENALTY_POINTS_AT_LEAST points and
    MODEL_LATTICE_POINTS' largest at most; none where the model's step is degenerate."""
    if _degenerate(model):
        return []
    k, largest = len(model.factor_names), MODEL_LATTICE_POINTS[1]

    def fitting(nodes):  # the most odd points per factor whose tables fit, `largest` at most
        most = int((PENALTY_TABLE_SIZE / (inputs.n_days * nodes)) ** (1 / k))
        return min(largest, most - (1 - most % 2))

    if start_points is not None and fitting(grid.nodes) >= start_points:
        return [(start_points, grid)]
    lattices = [(fitting(grid.nodes), grid)]
    nodes = trading_nodes(inputs, PENALTY_LEVELS_AT_LEAST, PENALTY_LEVELS_PER_FLOW)
    if nodes < grid.nodes and lattices[0][0] < largest:
        lattices.append((fitting(nodes), inventory_grid(inputs, scene, nodes)))
    return [(points, on) for points, on in lattices if points >= PENALTY_POINTS_AT_LEAST]


def pilot_gaps(penalty: AbstractPenalty, inputs: StorageInputs, scene: Scene, grid: InventoryGrid,
               pilot: PricePaths, relaxed: RelaxedGrid, reference: Schedule) -> tuple[np.ndarray, np.ndarray]:
    """Path by path on the `pilot` paths, the bound with `penalty` (on the `relaxed` grid) and the
    `reference` policy's gap under it (the bound less the policy's cash less the penalty it pays),
    each [$], shape (paths,). The policy's value is common to every penalty, so
    the differences of the gaps are those of the bounds, and the gaps vary far less than the
    bounds themselves (the penalty's noise cancels): they tell penalties apart on a few hundred
    paths where the bounds' means would not."""
    prices = spot_prices(inputs, pilot)[0]
    upper = np.asarray(dual_bound(penalty, inputs, scene, grid, prices, relaxed=relaxed, price_paths=pilot).values)
    paid = np.asarray(schedule_penalty(penalty, inputs, grid, prices, reference.inventory, relaxed, pilot))
    return upper, upper - (np.asarray(reference.value) - paid)


def tightest(gaps: dict[str, np.ndarray]) -> tuple[str, float | None]:
    """The name whose mean gap is least, and the standard error of its gap less the runner-up's
    (None where it is alone)."""
    ranked = sorted(gaps, key=lambda name: gaps[name].mean())
    return ranked[0], standard_error(gaps[ranked[0]] - gaps[ranked[1]]) if len(ranked) > 1 else None
