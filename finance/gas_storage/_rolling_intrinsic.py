"""Rolling intrinsic, the practitioners' baseline: re-optimise the intrinsic schedule on the
conditional forward curve E_t[S_u] (u > t, exact under the price model:
`AbstractPriceModel.conditional_curve`) and trade today at today's spot.

On a re-optimisation day t0 and every path, the intrinsic values V_u(y) of the days from u on
from every level y (u > t0) are a dynamic program on the LSMC's inventory grid and candidates
(`_lsmc.level_decisions`) run backward on the conditional curve of day t0, from the contract's
end down to t0 + 1 only; each day t of the block t0..t0+R-1 then trades to maximise today's
cash at the spot plus V_{t+1} (`_lsmc.continuation_decision`: the exact feasible candidates, so
every schedule is feasible). `every` = R = 1, the default, is the practitioners' daily
re-optimisation: the work is about T^2 / 2 x paths x levels x candidates. A larger R is cheaper
and weaker (the continuation between re-optimisations is stale: on a fast facility, every second
day gave 14% less than daily, docs/dev/gas_storage_notes.md), kept to measure that loss.
"""

import math

import equinox as eqx
import jax
import jax.numpy as jnp

from snapo_ode import Scene

from ._inputs import StorageInputs
from ._lsmc import InventoryGrid, continuation_decision, level_decisions, schedule_of
from ._model import Schedule, inventory_floor, spot_prices
from ._paths import PricePaths
from ._price_models import AbstractPriceModel


@eqx.filter_jit
def rolling_intrinsic(model: AbstractPriceModel, inputs: StorageInputs, scene: Scene, grid: InventoryGrid,
                      paths: PricePaths, every: int = 1) -> Schedule:
    """The rolling-intrinsic schedule on `paths` (which carry the model's `factors`), re-optimised
    every `every` days (static), every path."""
    n_days = inputs.n_days
    floor = inventory_floor(inputs, scene, None)
    prices = spot_prices(inputs, paths)[0]
    nothing = jnp.zeros((prices.shape[0], grid.nodes))

    def block(inventory, start):
        curve = inputs.forward_curve * model.conditional_curve(paths.factors[:, start], start, n_days)

        def back(u, later):  # V_u from V_{u+1} (paths, N) on day start's curve
            return level_decisions(inputs, scene, grid, curve[:, u], u, floor[u + 1], later)[0]

        # V_{start+every}: the days after the block, backward from the end (V_T = 0); a while loop
        # of as many days as remain, so a re-optimisation costs the days ahead, not the contract.
        end = jnp.minimum(start + every, n_days)
        after = jax.lax.fori_loop(0, n_days - end, lambda i, later: back(n_days - 1 - i, later), nothing)

        def inside(later, j):  # the block's own days, backward (0 beyond the end)
            u = start + j + 1
            value = jnp.where(u < n_days, back(jnp.minimum(u, n_days - 1), later), later)
            return value, value

        # stages[j] = V_{start+j+1}, j = 0..every-1 (the scan is empty for daily re-optimisation).
        stages = jnp.concatenate([jax.lax.scan(inside, after, jnp.arange(every - 1), reverse=True)[1], after[None]])

        def trade(held, offset):
            day = jnp.minimum(start + offset, n_days - 1)
            moved, cash = continuation_decision(inputs, scene, grid, held, prices[:, day], day, floor[day + 1],
                                                stages[offset])
            live = start + offset < n_days
            return jnp.where(live, moved, held), (held, jnp.where(live, cash, 0.0))

        return jax.lax.scan(trade, inventory, jnp.arange(every))

    padded = math.ceil(n_days / every) * every
    start = jnp.broadcast_to(inputs.initial_inventory, prices.shape[:1])
    last, (held, cash) = jax.lax.scan(block, start, jnp.arange(0, padded, every))
    held, cash = held.reshape(padded, -1)[:n_days], cash.reshape(padded, -1)[:n_days]
    return schedule_of(inputs, scene, jnp.concatenate([held, last[None]]).T, cash)
