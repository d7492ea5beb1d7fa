"""The penalty of the dual bound under any price model (`_price_models.py`): zero-mean
martingale increments from the state LSMC's value function, with conditional expectations exact
under the model (never estimated), so the bound (`_dual.py`) is valid for every model.

    w_t(n') = sum_q beta_{t,q}(n') m_j(state_t) g_p(t+1),

with m_j the monomials of degree <= `multiplier_degree` of day t's standardised state (known on
day t) and g_p innovations of conditional mean zero given day t:
- the model's standardised factor shocks eps_{t+1} = L^-1 (X_{t+1} - a X_t) (k of them, N(0, I)
  and independent of day t), and He_2(eps_i) / sqrt(2);
- a basis of the next day's spot (`_penalty.AbstractInnovationBasis`, default calls on
  S_{t+1} / F_{t+1}), with the log ratio's conditional mean and standard deviation in closed
  form (`AbstractPriceModel.next_day_moments`).
beta is regressed, level by level, on paths other than the evaluation's, of the state LSMC's
own value estimate of the days after t (`"fitted"` in `_penalty.py`) on [state basis, features].
"""

from typing import ClassVar

import equinox as eqx
import jax
import jax.numpy as jnp

from snapo_ode import Scene

from ._inputs import StorageInputs
from ._lsmc import InventoryGrid, level_decisions
from ._model import inventory_floor, spot_prices
from ._paths import PricePaths
from ._penalty import AbstractInnovationBasis, AbstractPenalty, DayStep, SpotCalls, _penalty_regression
from ._price_models import AbstractPriceModel
from ._state_lsmc import StateBasis, StateLSMCFit, _fit, state_basis

DEFAULT_SPOT_BASIS = SpotCalls((0.8, 0.9, 1.0, 1.1, 1.25))


def _innovations(model: AbstractPriceModel, spot_basis: AbstractInnovationBasis, paths: PricePaths,
                 n_days: int) -> jax.Array:
    """g_p(t+1) for every path and day, shape (paths, T, P): zero on the last day."""
    mean, sd = model.next_day_moments(paths.factors, n_days)
    random = sd > 0
    next_log_ratio = jnp.concatenate([paths.log_ratio[:, 1:], paths.log_ratio[:, -1:]], axis=1)
    def day(log_ratio_next, mean_t, sd_t, random_t):  # one day, as the one-factor bases take it
        step = DayStep(log_ratio_next, mean_t, jnp.where(random_t, sd_t, 1.0), random_t, jnp.ones(()))
        return jnp.where(random_t, spot_basis.innovations(step), 0.0)

    spot = jax.vmap(day, in_axes=(1, 1, 0, 0), out_axes=1)(next_log_ratio, mean, sd, random)
    eps = model.factor_innovations(paths.factors)
    features = jnp.concatenate([eps, (eps**2 - 1) / jnp.sqrt(2.0), spot], axis=-1)
    return features.at[:, -1].set(0.0)


def _features(multipliers: jax.Array, innovations: jax.Array) -> jax.Array:
    """m_j g_p, shape (paths, J P), of one day's multipliers (paths, J) and innovations (paths, P)."""
    return (multipliers[:, :, None] * innovations[:, None, :]).reshape(multipliers.shape[0], -1)


class StatePenalty(AbstractPenalty):
    """**Fields:** the `model` and `spot_basis` of the innovations, the `multipliers`' basis of
    the state, `coefficients` beta of shape (T, J P, N), zero on the last day."""

    label: ClassVar[str] = "state LSMC value"
    model: AbstractPriceModel
    spot_basis: AbstractInnovationBasis
    multipliers: StateBasis
    coefficients: jax.Array

    def daily(self, inputs: StorageInputs, prices: jax.Array, paths=None):
        if paths is None or paths.factors is None:
            raise ValueError("a StatePenalty needs the paths' factors (PricePaths with factors)")
        innovations = _innovations(self.model, self.spot_basis, paths, inputs.n_days)
        multipliers = self.multipliers(paths.state())
        return jnp.swapaxes(multipliers, 0, 1), jnp.swapaxes(innovations, 0, 1), self.coefficients

    def today(self, day_inputs) -> jax.Array:
        multipliers, innovations, beta = day_inputs
        return _features(multipliers, innovations) @ beta


def _regression_today(basis, estimate_later, day_inputs):
    """beta_t (J P, N): the features' coefficients in the fit of the value estimate of the days
    after t on [state basis, features]; 0 on the last day, whose estimate and innovations are 0."""
    multipliers, innovations = day_inputs
    return _penalty_regression(basis, _features(multipliers, innovations), estimate_later)


@eqx.filter_jit
def _regressions(fit: StateLSMCFit, inputs: StorageInputs, scene: Scene, grid: InventoryGrid, prices, regressors,
                 multipliers, innovations):
    def back(estimate_later, today):
        day, price, basis, multiplier, innovation, coefficients, floor_tomorrow = today
        beta = _regression_today(basis, estimate_later, (multiplier, innovation))
        _, estimate = level_decisions(inputs, scene, grid, price, day, floor_tomorrow, coefficients, regressors=basis)
        return estimate, beta

    per_day = (jnp.arange(inputs.n_days), prices.T,
               *(jnp.swapaxes(a, 0, 1) for a in (regressors, multipliers, innovations)),
               fit.coefficients, inventory_floor(inputs, scene, None)[1:])
    _, beta = jax.lax.scan(back, jnp.zeros((prices.shape[0], grid.nodes)), per_day, reverse=True)
    return beta


def fit_state_penalty(fit: StateLSMCFit, model: AbstractPriceModel, inputs: StorageInputs, scene: Scene,
                      grid: InventoryGrid, paths: PricePaths, *, spot_basis: AbstractInnovationBasis = DEFAULT_SPOT_BASIS,
                      multiplier_degree: int = 1) -> StatePenalty:
    """Fit beta on `paths` (with factors; the LSMC's fitting paths or others, never the
    evaluation's), the LSMC rule `fit` frozen (module docstring). On the LSMC's own fitting
    paths `fit_state_lsmc_and_penalty` gives the same penalty without replaying the rule."""
    multipliers = state_basis(paths, multiplier_degree)
    beta = _regressions(fit, inputs, scene, grid, spot_prices(inputs, paths)[0], fit.basis(paths.state()),
                        multipliers(paths.state()), _innovations(model, spot_basis, paths, inputs.n_days))
    return StatePenalty(model, spot_basis, multipliers, beta)


def fit_state_lsmc_and_penalty(model: AbstractPriceModel, inputs: StorageInputs, scene: Scene, grid: InventoryGrid,
                               paths: PricePaths, degree: int = 2, *,
                               spot_basis: AbstractInnovationBasis = DEFAULT_SPOT_BASIS,
                               multiplier_degree: int = 1) -> tuple[StateLSMCFit, StatePenalty]:
    """`fit_state_lsmc(inputs, scene, grid, paths, degree)` and `fit_state_penalty` of it on the
    same `paths`, from one backward pass: each day's penalty regression takes the LSMC's value
    estimate as the induction computes it (the separate replay cost as much as the fit itself:
    docs/dev/gas_storage_notes.md, Measurements behind the design)."""
    basis, multipliers = state_basis(paths, degree), state_basis(paths, multiplier_degree)
    coefficients, values, beta = _fit(
        inputs, scene, grid, spot_prices(inputs, paths)[0], basis(paths.state()), _regression_today,
        (multipliers(paths.state()), _innovations(model, spot_basis, paths, inputs.n_days)))
    return StateLSMCFit(coefficients, basis, values), StatePenalty(model, spot_basis, multipliers, beta)
