"""Rolling intrinsic, the practitioners' baseline: re-optimise the intrinsic schedule on the
conditional forward curve E_t[S_u] (u > t, exact under the price model:
`AbstractPriceModel.conditional_curve`) and trade today at today's spot.

On a re-optimisation day t0 and every path, the intrinsic values V_u(y) of the days from u on
from every level y (u > t0) are a dynamic program on the LSMC's inventory grid and candidates
(`_lsmc.level_decisions`) run on the conditional curve of day t0; each day t of the block
t0..t0+R-1 then trades to maximise today's cash at the spot plus V_{t+1}
(`_lsmc.continuation_decision`: the exact feasible candidates, so every schedule is feasible).
`every` = R = 1 is the daily re-optimisation; the work grows as T^2 / R x paths x levels x
candidates, so a longer contract is re-optimised less often (`reoptimisation_days`).
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

REOPTIMISATIONS = 45  # re-optimisations over a contract at most (daily up to 45 days)


def reoptimisation_days(n_days: int) -> int:
    """R: re-optimise every R days, so that a contract is re-optimised at most REOPTIMISATIONS times."""
    return max(1, math.ceil(n_days / REOPTIMISATIONS))


@eqx.filter_jit
def rolling_intrinsic(model: AbstractPriceModel, inputs: StorageInputs, scene: Scene, grid: InventoryGrid,
                      paths: PricePaths, every: int = 1) -> Schedule:
    """The rolling-intrinsic schedule on `paths` (which carry the model's `factors`), re-optimised
    every `every` days (static), every path."""
    n_days = inputs.n_days
    blocks = math.ceil(n_days / every)
    padded = blocks * every
    floor = inventory_floor(inputs, scene, None)
    prices = spot_prices(inputs, paths)[0]
    days = jnp.arange(n_days)

    def block(inventory, start):
        curve = inputs.forward_curve * model.conditional_curve(paths.factors[:, start], start, n_days)

        def back(later, step):
            u, price, floor_tomorrow = step
            decided, _ = level_decisions(inputs, scene, grid, price, u, floor_tomorrow, later)
            return jnp.where(u > start, decided, later), later

        # stages[u] = V_{u+1}: the value of ending day u at each level, on day start's curve.
        _, stages = jax.lax.scan(back, jnp.zeros((prices.shape[0], grid.nodes)), (days, curve.T, floor[1:]),
                                 reverse=True)

        def trade(held, offset):
            day = jnp.minimum(start + offset, n_days - 1)
            moved, cash = continuation_decision(inputs, scene, grid, held, prices[:, day], day, floor[day + 1],
                                                stages[day])
            live = start + offset < n_days
            return jnp.where(live, moved, held), (held, jnp.where(live, cash, 0.0))

        return jax.lax.scan(trade, inventory, jnp.arange(every))

    start = jnp.broadcast_to(inputs.initial_inventory, prices.shape[:1])
    last, (held, cash) = jax.lax.scan(block, start, jnp.arange(0, padded, every))
    held, cash = held.reshape(padded, -1)[:n_days], cash.reshape(padded, -1)[:n_days]
    return schedule_of(inputs, scene, jnp.concatenate([held, last[None]]).T, cash)
