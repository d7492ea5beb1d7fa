"""Forward-curve deltas of the LSMC valuation: pathwise (one reverse pass, the fitted decision rule
frozen) and by central bumps of the whole valuation (refit and revalue per bump).

The pathwise value and all deltas cost about one out-of-sample run, where refitted bumps cost a
fit and a run per bump, two per day (docs/gas_storage.md, LSMC deltas, has the timings).

Pathwise: with the fit frozen, the out-of-sample value is the mean over paths of
sum_t cash_t(a_t, S_t) with S_t = F_t exp(f_t) (f the spot factor, independent of F), and the
decisions a_t piecewise constant in F; so d value / d F_t = mean over paths of (S_t / F_t)
d cash_t / d S_t, the decisions held. That is the exact derivative of the refitted valuation
wherever no decision sits on a tie: central bumps below the smallest decision margin (relative
step 1e-9) agree to round-off on every day (tested). Larger bumps move decisions, in the fit and
in the run; for an optimal rule their first-order effect is zero (envelope theorem), for LSMC's
it is not: larger refitted bumps differ from the pathwise deltas, systematically on a short case,
and LSMC's pathwise deltas differ by a few percent from those of a near-optimal rule (the factor
lattice's, same paths); docs/gas_storage.md, LSMC deltas, has the figures.
"""

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np

from snapo_ode import Scene, central_differences

from ._inputs import StorageInputs
from ._lsmc import InventoryGrid, LSMCFit, fit_lsmc, run_lsmc_policy
from ._model import spot_prices


def _with_curve(inputs: StorageInputs, curve: jax.Array) -> StorageInputs:
    return eqx.tree_at(lambda i: i.forward_curve, inputs, curve)


@eqx.filter_jit
def lsmc_value_and_deltas(fit: LSMCFit, inputs: StorageInputs, scene: Scene, grid: InventoryGrid,
                          shocks: jax.Array) -> tuple[jax.Array, jax.Array]:
    """The out-of-sample value [$] of the frozen LSMC rule `fit` on the spot paths of `shocks`
    (paths, T), and its derivative with respect to every day's forward price, shape (T,)
    [$ per $/MMBtu], from one reverse pass."""

    def value(curve):
        moved = _with_curve(inputs, curve)
        return jnp.mean(run_lsmc_policy(fit, moved, scene, grid, spot_prices(moved, shocks)[0]).value)

    return jax.value_and_grad(value)(inputs.forward_curve)


@eqx.filter_jit
def lsmc_valuation(inputs: StorageInputs, scene: Scene, grid: InventoryGrid, fit_shocks: jax.Array,
                   eval_shocks: jax.Array, degree: int) -> jax.Array:
    """The whole LSMC valuation [$]: fit on the spot paths of `fit_shocks`, value the rule on
    those of `eval_shocks` (both (paths, T), the curve entering through the prices)."""
    fit = fit_lsmc(inputs, scene, grid, spot_prices(inputs, fit_shocks)[0], degree)
    return jnp.mean(run_lsmc_policy(fit, inputs, scene, grid, spot_prices(inputs, eval_shocks)[0]).value)


def lsmc_bumped_deltas(inputs: StorageInputs, scene: Scene, grid: InventoryGrid, fit_shocks: jax.Array,
                       eval_shocks: jax.Array, degree: int, *, relative_step: float = 1e-2) -> np.ndarray:
    """Central differences of `lsmc_valuation` (refit per bump, the same fitting and evaluation
    shocks every time) for every day's forward price, F_t moved by +- relative_step F_t
    (`snapo_ode.central_differences`, all 2T valuations vmapped in one program: meant for small
    cases); shape (T,)."""
    def valuation(curve):
        return lsmc_valuation(_with_curve(inputs, curve), scene, grid, fit_shocks, eval_shocks, degree)

    return central_differences(valuation, inputs.forward_curve, relative_step=relative_step, step_floor=0.0)
