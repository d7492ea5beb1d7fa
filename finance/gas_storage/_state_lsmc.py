"""Least-squares Monte Carlo on any price model: the continuation value of each inventory level
regressed on a polynomial in the model's state (Boogert & de Jong's multi-factor LSMC), not on
the spot alone.

The basis (`StateBasis`) is every monomial of total degree <= `degree` in the standardised state
z_t = (state_t - mean_t) / sd_t (the factors of a price model, or the log spot ratio where a
paths file gives no factors), with the mean and sd of each day taken on the fitting paths and
kept for any other paths. The backward induction, the candidates and the Longstaff-Schwartz
crediting are `_lsmc.py`'s (`level_decisions`, `run_continuation_policy`); only the regressors
change.
"""

import functools
import itertools
import operator
from typing import NamedTuple

import equinox as eqx
import jax
import jax.numpy as jnp

from snapo_ode import Scene, check_count

from ._inputs import StorageInputs
from ._lsmc import InventoryGrid, level_decisions, run_continuation_policy, start_value
from ._model import Schedule, inventory_floor, spot_prices
from ._paths import PricePaths


class StateBasis(eqx.Module):
    """The regressors of the state: `mean`, `scale` (T, k) of the fitting paths' state and the
    monomials' `exponents` (static, a tuple of k-tuples)."""

    mean: jax.Array
    scale: jax.Array
    exponents: tuple[tuple[int, ...], ...] = eqx.field(static=True)

    def __call__(self, state: jax.Array) -> jax.Array:
        """The basis of `state` (paths, T, k), shape (paths, T, B)."""
        z = (state - self.mean) / self.scale
        columns = []
        for exponent in self.exponents:
            # Products of powers only: a power 0 (a constant) reduced over would be folded at compile time.
            terms = [z[..., i] ** power for i, power in enumerate(exponent) if power > 0]
            columns.append(functools.reduce(operator.mul, terms) if terms else jnp.ones(z.shape[:-1], z.dtype))
        return jnp.stack(columns, axis=-1)


def state_basis(paths: PricePaths, degree: int) -> StateBasis:
    """Every monomial of total degree <= `degree` in the state of `paths`, standardised per day
    on them (days where the state does not vary, such as day 0, read 0).

    **Raises:** `InputError` for a degree outside [1, 6]."""
    check_count("degree", degree, 1, 6)
    state = paths.state()
    k = state.shape[-1]
    exponents = tuple(e for total in range(degree + 1) for e in itertools.product(range(total + 1), repeat=k)
                      if sum(e) == total)
    spread = jnp.std(state, axis=0)
    return StateBasis(jnp.mean(state, axis=0), jnp.where(spread > 1e-12, spread, 1.0), exponents)


class StateLSMCFit(NamedTuple):
    """`coefficients` (T, B, N): the continuation value [$] of ending day t at each level in the
    basis; `basis`: the `StateBasis`; `values`: the in-sample realised value per fitting path."""

    coefficients: jax.Array
    basis: StateBasis
    values: jax.Array


@eqx.filter_jit
def _fit(inputs: StorageInputs, scene: Scene, grid: InventoryGrid, prices, regressors, also=None, also_inputs=None):
    """The backward induction; `also(basis, estimate_later, day_inputs)`, where given, runs beside
    it on each day t with the LSMC's own value estimate of the days after t (paths, N) and day t's
    slice of `also_inputs` (leading axis paths, then days), and its results are returned stacked
    on a leading day axis (the dual penalty's regressions: `_state_penalty.fit_state_lsmc_and_penalty`)."""
    floor = inventory_floor(inputs, scene, None)

    def back(later, today):
        day, price, basis, floor_tomorrow, extra = today
        realised_later, estimate_later = later
        coefficients = jnp.linalg.lstsq(basis, realised_later)[0]
        realised, estimate = level_decisions(inputs, scene, grid, price, day, floor_tomorrow, coefficients,
                                             realised_later, regressors=basis)
        return (realised, estimate), (coefficients, None if also is None else also(basis, estimate_later, extra))

    later = jnp.zeros((prices.shape[0], grid.nodes))
    extra = None if also_inputs is None else jax.tree.map(lambda a: jnp.swapaxes(a, 0, 1), also_inputs)
    (values, _), (coefficients, side) = jax.lax.scan(
        back, (later, later), (jnp.arange(inputs.n_days), prices.T, jnp.swapaxes(regressors, 0, 1), floor[1:], extra),
        reverse=True)
    return coefficients, start_value(inputs, grid, values), side


def fit_state_lsmc(inputs: StorageInputs, scene: Scene, grid: InventoryGrid, paths: PricePaths,
                   degree: int = 2) -> StateLSMCFit:
    """Longstaff-Schwartz backward induction on `paths`, regressing on `state_basis(paths, degree)`."""
    basis = state_basis(paths, degree)
    coefficients, values, _ = _fit(inputs, scene, grid, spot_prices(inputs, paths)[0], basis(paths.state()))
    return StateLSMCFit(coefficients, basis, values)


@eqx.filter_jit
def run_state_lsmc(fit: StateLSMCFit, inputs: StorageInputs, scene: Scene, grid: InventoryGrid,
                   paths: PricePaths) -> Schedule:
    """The fitted rule run forward on `paths` (out of sample); the hard schedule of every path.
    The state is data: a forward-curve delta moves the spot (through F exp(log ratio)), not the
    regressors."""
    regressors = jnp.swapaxes(fit.basis(paths.state()), 0, 1)

    def continuation(today, _):
        basis, coefficients = today
        return basis @ coefficients

    return run_continuation_policy(inputs, scene, grid, spot_prices(inputs, paths)[0], continuation,
                                   (regressors, fit.coefficients))


@eqx.filter_jit
def state_lsmc_value_and_deltas(fit: StateLSMCFit, inputs: StorageInputs, scene: Scene, grid: InventoryGrid,
                                paths: PricePaths) -> tuple[jax.Array, jax.Array]:
    """The out-of-sample value [$] of the frozen rule on `paths` and its forward-curve deltas
    (T,) from one reverse pass (pathwise: the decisions fixed, the cash moved)."""

    def value(curve):
        moved = eqx.tree_at(lambda i: i.forward_curve, inputs, curve)
        return jnp.mean(run_state_lsmc(fit, moved, scene, grid, paths).value)

    return jax.value_and_grad(value)(inputs.forward_curve)
