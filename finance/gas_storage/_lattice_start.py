"""Where the basestock head starts on a random spot: the targets the factor lattice implies.

For a one-factor spot the day and the factor x are the whole price state, and the lattice
(`_lattice.py`) gives the value C_t(y, x) of ending day t at inventory y. Today's cash is linear
in tomorrow's inventory on each side of holding (p_in per unit injected, fuel and costs
included, p_out per unit withdrawn, both discounted), so the best place to inject up to and the
best place to withdraw down to are

    b_L(t, x) = argmax_y [C_t(y, x) - p_in y],   b_U(t, x) = argmax_{y >= b_L} [C_t(y, x) - p_out y]

over the lattice's inventory levels between tomorrow's floor and ceiling and those two ends: the basestock targets
(Secomandi 2010) of the lattice's value, computed on every factor level, for every day. The
policy's network then learns a correction to them by the adjoint, on the exact model's
simulator (ratchets, fuel, costs and discounting as they are), so the trained policy is not the
lattice's rule: it is a basestock policy started where the lattice's value says, with the
targets interpolated in x between factor levels. Specific to the one-factor model, as the
lattice is; at zero volatility the head starts on the intrinsic schedule instead.
"""

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np

from snapo_ode import Scene

from ._basestock import inventory_bounds, target_logits
from ._inputs import StorageInputs
from ._lattice import (
    FactorLattice,
    interpolate_factor,
    lattice_grid,
    solve_factor_lattice,
)
from ._lsmc import InventoryGrid, continuation_targets, interpolate_levels, inventory_grid
from ._model import factor_transition

START_POINTS = 200  # factor levels of the lattice the start is read from (docs/gas_storage.md, Where the policy starts)
START_WORK = 1e9  # and its inventory grid: the finest of 101, 201, 401, ... levels this work affords (`lattice_grid`)


def basestock_start(inputs: StorageInputs, scene: Scene, *, points: int = START_POINTS,
                    work: float = START_WORK) -> tuple[jax.Array, jax.Array]:
    """`lattice_start` of a lattice on `points` factor levels and the finest inventory grid of
    101, 201, 401, ... levels whose lattice costs at most `work` (days x points x levels x the
    levels a day reaches)."""
    grid = lattice_grid(inputs, scene, inventory_grid(inputs, scene, 101), points=points, work=work)
    return lattice_start(solve_factor_lattice(inputs, scene, grid, points=points), inputs, scene, grid)


@eqx.filter_jit
def lattice_targets(lattice: FactorLattice, inputs: StorageInputs, scene: Scene,
                    grid: InventoryGrid) -> tuple[jax.Array, jax.Array, jax.Array]:
    """`(factor, low, high)`: the levels of x = log(spot / F) the targets are given on, shape
    (G,) (the lattice's levels), and b_L, b_U [MMBtu] for tomorrow's inventory, each (T, G)."""
    levels = jnp.asarray(grid.levels)
    floor, ceiling = (bound[1:] for bound in inventory_bounds(inputs, scene, None))
    shift = factor_transition(inputs).variance / 2  # the lattice's factor is X = x + Var(X_t) / 2

    def day_targets(day, forward, half_variance, continuation, floor_tomorrow, ceiling_tomorrow):
        # The levels inside [floor, ceiling] and its two ends (where no level lies inside, the ends alone).
        positions = jnp.clip(levels, floor_tomorrow, ceiling_tomorrow)
        value = interpolate_levels(interpolate_factor(lattice.factor, continuation, lattice.factor + half_variance),
                                   positions, grid.spacing)  # (G, N)
        return continuation_targets(inputs, scene, value, positions, forward * jnp.exp(lattice.factor), day,
                                    grid.spacing)

    low, high = jax.vmap(day_targets)(jnp.arange(inputs.n_days), inputs.forward_curve, shift, lattice.continuation,
                                      floor, ceiling)
    return lattice.factor, low, high


def lattice_start(lattice: FactorLattice, inputs: StorageInputs, scene: Scene,
                  grid: InventoryGrid) -> tuple[jax.Array, jax.Array]:
    """`(factor, table)`: the basestock head's starting logits (mid-point, band) on the factor
    levels, table shape (T, G, 2), from `lattice_targets`."""
    factor, low, high = lattice_targets(lattice, inputs, scene, grid)
    return factor, jnp.asarray(np.stack(target_logits(inputs, scene, np.asarray(low), np.asarray(high)), -1))
