"""An upper bound on the storage value by information relaxation (Brown, Smith & Sun 2010,
"Information relaxations and duality in stochastic dynamic programs", Operations Research 58(4);
for storage, Lai, Margot & Secomandi 2010, Operations Research 58(3)).

On each evaluation path the holder is told the whole price path in advance and pays, for ending
day t at node n', the penalty

    w_t(n') = sum_p beta_{t,p}(n', x_t) [phi_p(S_{t+1}) - E_t phi_p(S_{t+1})],    w_{T-1} = 0,

whose conditional expectation given day t is exactly zero for any n' chosen with day-t
information (E_t phi is computed in closed form under the Ornstein-Uhlenbeck spot of
`_model.py`; it is never estimated). The path's deterministic dynamic program on the inventory
grid of `_lsmc.py`, for every node at once,

    U_T(n) = 0,    U_t(n) = max_{k allowed at (t, n)} [cash_t(k) - w_t(n + k) + U_{t+1}(n + k)],

gives U_0(start) >= cash - penalty of any policy's actions on that path, so the path mean of
U_0(start) bounds from above the value of every non-anticipative policy (the penalty has mean
zero for them). With w = 0 it is perfect foresight on the grid. The closer beta . phi is to the
optimal value of the days after t, the tighter the bound; it is exact for the optimal value.

The penalties, and the exact conditional means that give them mean zero, are in `_penalty.py`.

Grid and continuous policies: with a penalty extended linearly in inventory between nodes, the
path problem over continuous inventories splits into cells in which it is a linear program with
a totally unimodular (interval and difference) constraint matrix, so when every rate, the
capacity and the terminal requirement are whole numbers of grid steps and no ratchet varies
with fill, its optimum lies on the grid and the bound holds for continuous policies too
(`DualBound.bounds_continuous_policies`). Otherwise it bounds grid policies only.
"""

from typing import NamedTuple

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np

from snapo_ode import Scene

from ._inputs import StorageInputs
from ._lsmc import InventoryGrid, _move_cash
from ._model import kept_fraction, rate_fraction
from ._penalty import AbstractPenalty


class DualBound(NamedTuple):
    """`values`: U_0(start) per path [$], shape (paths,), whose mean bounds from above every
    non-anticipative policy's value; `bounds_continuous_policies`: whether that includes
    policies off the grid (see the module docstring) or grid policies only."""

    values: jax.Array
    bounds_continuous_policies: bool


def bounds_continuous_policies(inputs: StorageInputs, scene: Scene, grid: InventoryGrid) -> bool:
    """Whether every continuous policy's inventory path can be matched on the grid: rates and
    terminal requirement whole numbers of steps, and rates that do not vary with fill."""
    whole = lambda amount: abs(amount / grid.spacing - round(amount / grid.spacing)) < 1e-9  # noqa: E731
    fill = jnp.linspace(0.0, 1.0, grid.targets.shape[0])
    kept = kept_fraction(inputs, scene)
    in_room = np.asarray(kept * inputs.max_injection * rate_fraction(inputs.injection_ratchet, fill, scene, None))
    out_room = np.asarray(inputs.max_withdrawal * rate_fraction(inputs.withdrawal_ratchet, fill, scene, None))
    constant = np.ptp(in_room) <= 1e-9 * in_room.max() and np.ptp(out_room) <= 1e-9 * out_room.max()
    return bool(constant and whole(float(in_room[0])) and whole(float(out_room[0]))
                and whole(float(inputs.terminal_inventory_min)))


@eqx.filter_jit
def _dual_values(penalty: AbstractPenalty | None, inputs: StorageInputs, scene: Scene, grid: InventoryGrid,
                 prices: jax.Array) -> jax.Array:
    targets = jnp.asarray(grid.targets)
    daily = None if penalty is None else penalty.daily(inputs, prices)

    def back(later, today):
        day, price, allowed, day_inputs = today
        cash = _move_cash(inputs, scene, grid, price, day)[:, None, :]
        after = later if penalty is None else later - penalty.today(day_inputs)
        score = jnp.where(allowed[None], cash + after[:, targets], -jnp.inf)
        return jnp.max(score, axis=-1), None

    later = jnp.zeros((prices.shape[0], targets.shape[0]))
    values, _ = jax.lax.scan(back, later, (jnp.arange(inputs.n_days), prices.T, jnp.asarray(grid.allowed), daily),
                             reverse=True)
    return values[:, grid.start_node]


def dual_bound(penalty: AbstractPenalty | None, inputs: StorageInputs, scene: Scene, grid: InventoryGrid,
               prices: jax.Array) -> DualBound:
    """Solve every path's penalised dynamic program, for all nodes at once, on `prices` of shape
    (paths, T) [$/MMBtu]: evaluation paths, not those the penalty was fitted on. `penalty=None`
    gives perfect foresight on the grid (equal to `perfect_foresight`'s LP when
    `bounds_continuous_policies`)."""
    values = _dual_values(penalty, inputs, scene, grid, prices)
    return DualBound(values, bounds_continuous_policies(inputs, scene, grid))


@eqx.filter_jit
def schedule_penalty(penalty: AbstractPenalty, inputs: StorageInputs, grid: InventoryGrid, prices: jax.Array,
                     inventory: jax.Array) -> jax.Array:
    """The total penalty sum_t w_t(V_{t+1}) [$] paid by schedules with inventories `inventory` of
    shape (paths, T+1) [MMBtu] (as in `Schedule`), w interpolated linearly in inventory between
    nodes; shape (paths,). Zero mean for a non-anticipative policy, so cash - penalty is an
    unbiased, lower-variance estimate of its value, and U_0 >= cash - penalty path by path."""
    nodes = grid.targets.shape[0]
    position = inventory[:, 1:].T / grid.spacing  # (T, paths)

    def add(total, today):
        day_inputs, where = today
        per_node = penalty.today(day_inputs)
        low = jnp.clip(jnp.floor(where).astype(int), 0, nodes - 2)
        weight = where - low
        at = lambda n: jnp.take_along_axis(per_node, n[:, None], axis=-1)[:, 0]  # noqa: E731
        return total + (1 - weight) * at(low) + weight * at(low + 1), None

    total, _ = jax.lax.scan(add, jnp.zeros(prices.shape[0]), (penalty.daily(inputs, prices), position))
    return total
