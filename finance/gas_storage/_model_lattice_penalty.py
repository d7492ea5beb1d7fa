"""The dual bound's penalty from the factor lattice's value (`_model_lattice.py`), for any
Gaussian price model:

    w_t(n') = V~_{t+1}(n', z_{t+1}) - E[V~_{t+1}(n', z_{t+1}) | z_t],

V~ the lattice's tensor-product piecewise-linear value at the path's coordinates z = U^-1 X.
The expectation is exact (`hat_expectations`, one axis at a time, as the lattice's own backward
pass takes it, but at the path's z_t rather than at a node), so w has conditional mean zero
under the model and the bound (`_dual.py`) is valid whatever the lattice's accuracy; the
accuracy decides only how tight the bound is. Each path and day costs G^k N multiply-adds
(G points per factor, N inventory levels), `CHUNK_PATHS` paths at a time.

Which penalty bounds more tightly, this one or the state LSMC's regression (`_state_penalty.py`),
depends on the contract: `tighter_penalty` decides, by the LSMC rule's gap under each, on pilot
paths of the model, fresh: not the
evaluation's (the bound reported stays an unbiased estimate of a valid bound) and not the
training paths the state penalty was fitted on (its bound there is biased low by the fit).
"""

import jax
import jax.numpy as jnp
import numpy as np

from snapo_ode import Scene

from ._dual import RelaxedGrid, dual_bound, schedule_penalty
from ._inputs import StorageInputs
from ._lsmc import InventoryGrid
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

# The most numbers T x G^k x N the penalty's value tables may hold (3.2 GB in float64); the same
# count bounds the bound's work per path and policy (G^k N per day).
PENALTY_TABLE_SIZE = 4e8
# The fewest points per factor the penalty's lattice takes; coarser, the state penalty alone.
PENALTY_POINTS_AT_LEAST = 9
# Paths contracted at once (memory: CHUNK_PATHS x G^(k-1) x N numbers).
CHUNK_PATHS = 64
# The fresh paths of the model on which `tighter_penalty` compares the penalties' bounds.
PILOT_PATHS = 500


class ModelLatticePenalty(AbstractPenalty):
    """**Fields:** the price `model` (named in the bound's fields); `unit` U, `drift` M and `sd`
    D of the coordinates (`_model_lattice._coordinates`); `axes` (k, G); `values`: the lattice's
    V_t, shape (T, G, ..., G, N) [$] (the same buffer, not a copy: it is the memory's bulk)."""

    model: AbstractPriceModel
    unit: jax.Array
    drift: jax.Array
    sd: jax.Array
    axes: jax.Array
    values: jax.Array

    def __init__(self, model: AbstractPriceModel, lattice: ModelLattice):
        if lattice.values is None:
            raise ValueError("the penalty needs the lattice's value tables: solve_model_lattice(..., keep_values=True)")
        self.model = model
        self.unit, self.drift, self.sd = _coordinates(model)
        self.axes, self.values = lattice.axes, lattice.values

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

        return interpolate_grid(self.axes, table, following) - jax.lax.map(expected, z, batch_size=CHUNK_PATHS)


def penalty_points(model: AbstractPriceModel, inputs: StorageInputs, grid: InventoryGrid,
                   start_points: int | None) -> int | None:
    """The penalty lattice's points per factor: the start's lattice's (`start_points`, shared)
    where its tables fit PENALTY_TABLE_SIZE, else the most odd count that fits, at least
    PENALTY_POINTS_AT_LEAST; None where even that does not fit or the model's step is degenerate."""
    if _degenerate(model):
        return None
    k = len(model.factor_names)
    fitting = int((PENALTY_TABLE_SIZE / (inputs.n_days * grid.nodes)) ** (1 / k))
    points = min(MODEL_LATTICE_POINTS[1], fitting - (1 - fitting % 2), start_points or MODEL_LATTICE_POINTS[1])
    return points if points >= PENALTY_POINTS_AT_LEAST else None


def tighter_penalty(candidates: dict[str, AbstractPenalty], inputs: StorageInputs, scene: Scene, grid: InventoryGrid,
                    pilot: PricePaths, relaxed: RelaxedGrid, reference: Schedule) -> tuple[str, dict]:
    """The name of the candidate penalty whose bound lies least above the `reference` policy's
    value (its schedule on the `pilot` paths: none that a candidate was fitted on, nor the
    evaluation's), on the `relaxed` grid, and the JSON fields of the comparison.

    The policy's value is the same under both, so the difference of the gaps is that of the
    bounds; each gap, path by path the bound less the policy's cash less the penalty it pays,
    varies far less than the bound itself (the penalty's noise cancels), so the gaps tell the
    penalties apart on a few hundred paths where the bounds' means would not."""
    prices = spot_prices(inputs, pilot)[0]
    cash = np.asarray(reference.value)
    bounds, gaps = {}, {}
    for name, penalty in candidates.items():
        upper = np.asarray(dual_bound(penalty, inputs, scene, grid, prices, relaxed=relaxed, price_paths=pilot).values)
        paid = np.asarray(schedule_penalty(penalty, inputs, grid, prices, reference.inventory, relaxed, pilot))
        bounds[name], gaps[name] = float(upper.mean()), upper - (cash - paid)
    chosen = min(gaps, key=lambda name: gaps[name].mean())
    difference = gaps["lattice"] - gaps["state"] if set(gaps) == {"lattice", "state"} else None
    return chosen, {"penalty_pilot_bounds": bounds, "penalty_pilot_gaps": {k: float(v.mean()) for k, v in gaps.items()},
                    "penalty_pilot_gap_difference_se": None if difference is None else standard_error(difference)}
