"""Price models a desk values storage on: Gaussian factor models of the log spot around the
forward curve, one `equinox.Module` per model.

Every model here is a linear Gaussian state X_t in R^k (X_0 = 0, daily steps, exact
discretisation) with a per-day loading c_t in R^k on the log spot:

    X_{t+1} = a * X_t + L eps_{t+1},   eps ~ N(0, I_k),  L L' = Q (the step covariance),
    log S_t = log F_t + c_t . X_t - v_t / 2,   v_t = c_t' Sigma_t c_t,  Sigma_{t+1} = A Sigma_t A + Q,

with A = diag(a) (a_i = exp(-kappa_i dt), 1 for a random walk). So E[S_t] = F_t by construction
(exactly, not by a Monte Carlo adjustment), and every conditional expectation is in closed form:
given X_t, log S_u (u >= t) is normal with mean log F_u + c_u . A^(u-t) X_t - v_u / 2 and
variance v_u - c_u' A^(u-t) Sigma_t A^(u-t) c_u, so the conditional forward curve is

    E_t[S_u] = F_u exp(c_u . A^(u-t) X_t - c_u' A^(u-t) Sigma_t A^(u-t) c_u / 2)      (`conditional_curve`).

The models (parameters per year; dt = 1 / 365):
- `OneFactorModel` (kappa, sigma): the built-in Ornstein-Uhlenbeck log spot (`_model.spot_prices`).
- `TwoFactorModel` (Schwartz & Smith 2000): a short-term OU factor chi (kappa, sigma_chi) and a
  long-term random walk xi (sigma_xi), correlated (rho); log S = log F + chi + xi - v / 2.
- `ThreeFactorSeasonalModel` (the three-factor seasonal model of cmdty-storage): a mean-reverting
  spot factor, a long-term random walk and a seasonal random walk whose loading on day d is
  cos(2 pi (d - peak_day) / 365): a shock to it moves the peak season's prices one way and
  those half a year away the other (the summer-winter spread), independent factors.
"""

import abc
import math

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np

from ._inputs import DAYS_PER_YEAR
from ._paths import PricePaths


class AbstractPriceModel(eqx.Module):
    """A linear Gaussian factor model of the log spot (module docstring). Concrete models give
    the daily `decay` a (k,), the step covariance `step_covariance` Q (k, k) and the loadings
    c_t (`loadings`, (T, k)); the simulation and the conditional expectations follow."""

    @abc.abstractmethod
    def decay(self) -> jax.Array:
        """a, shape (k,): each factor's daily decay (1 for a random walk)."""

    @abc.abstractmethod
    def step_covariance(self) -> jax.Array:
        """Q, shape (k, k): the covariance of a day's step of the factors."""

    @abc.abstractmethod
    def loadings(self, n_days: int) -> jax.Array:
        """c_t, shape (T, k): each factor's weight in log(spot / forward) on day t."""

    @property
    @abc.abstractmethod
    def factor_names(self) -> tuple[str, ...]:
        """The k factors' names (the columns of a paths file)."""

    def covariances(self, n_days: int) -> jax.Array:
        """Sigma_t = Cov(X_t), shape (T, k, k), Sigma_0 = 0."""
        a, q = self.decay(), self.step_covariance()

        def advance(sigma, _):
            return a[:, None] * sigma * a[None, :] + q, sigma

        _, sigma = jax.lax.scan(advance, jnp.zeros_like(q), None, length=n_days)
        return sigma

    def log_variance(self, n_days: int) -> jax.Array:
        """v_t = Var(log S_t), shape (T,)."""
        c = self.loadings(n_days)
        return jnp.einsum("ti,tij,tj->t", c, self.covariances(n_days), c)

    def simulate(self, forward_curve: jax.Array, shocks: jax.Array) -> PricePaths:
        """Paths of the model from standard normal `shocks` of shape (paths, T, k) (the last
        day's shocks are unused: X_0 = 0 and X_t uses the shocks of days before t); the spot
        around `forward_curve` (T,) [$/MMBtu]."""
        n_days = forward_curve.shape[0]
        a, chol = self.decay(), jnp.linalg.cholesky(self.step_covariance())

        def advance(x, shock):
            return a * x + shock @ chol.T, x

        _, factors = jax.lax.scan(advance, jnp.zeros(shocks.shape[::2], shocks.dtype), jnp.swapaxes(shocks, 0, 1))
        factors = jnp.swapaxes(factors, 0, 1)  # (paths, T, k)
        log_ratio = jnp.einsum("ptk,tk->pt", factors, self.loadings(n_days)) - self.log_variance(n_days) / 2
        return PricePaths(log_ratio, factors)

    def conditional_curve(self, factors: jax.Array, day: int | jax.Array, n_days: int) -> jax.Array:
        """E_t[S_u] / F_u for u = 0..T-1 given the factors X_t (paths, k) of day `t` = `day`,
        shape (paths, T); entries u < t are 1 (unused: the past is not traded again). Exact."""
        a, c = self.decay(), self.loadings(n_days)
        sigma_t = self.covariances(n_days)[day]
        ahead = jnp.maximum(jnp.arange(n_days) - day, 0)
        powers = a[None, :] ** ahead[:, None]  # (T, k): A^(u - t)
        weights = c * powers  # c_u A^(u-t)
        known = jnp.einsum("uk,kl,ul->u", weights, sigma_t, weights)
        ratio = jnp.exp(factors @ weights.T - known / 2)
        return jnp.where(jnp.arange(n_days) >= day, ratio, 1.0)

    def next_day_moments(self, factors: jax.Array, n_days: int) -> tuple[jax.Array, jax.Array]:
        """The conditional mean m_t and standard deviation s_t of log(S_{t+1} / F_{t+1}) given
        X_t, for every path and day: shapes (paths, T) and (T,) (the last day repeats the one
        before; it is never used)."""
        a, q, c = self.decay(), self.step_covariance(), self.loadings(n_days)
        v = self.log_variance(n_days)
        c_next = jnp.concatenate([c[1:], c[-1:]])
        v_next = jnp.concatenate([v[1:], v[-1:]])
        mean = jnp.einsum("ptk,tk->pt", factors, c_next * a) - v_next / 2
        sd = jnp.sqrt(jnp.einsum("tk,kl,tl->t", c_next, q, c_next))
        return mean, sd

    def factor_innovations(self, factors: jax.Array) -> jax.Array:
        """The standardised innovations of the factors, eps_{t+1} = L^-1 (X_{t+1} - a X_t), shape
        (paths, T, k) (the last day's row is 0): independent of day t, mean zero."""
        a, chol = self.decay(), jnp.linalg.cholesky(self.step_covariance())
        step = factors[:, 1:] - a * factors[:, :-1]
        eps = jax.scipy.linalg.solve_triangular(chol, step.reshape(-1, step.shape[-1]).T, lower=True).T
        return jnp.concatenate([eps.reshape(step.shape), jnp.zeros_like(factors[:, :1])], axis=1)


def _ou_step(kappa, sigma_a, sigma_b=None, rho=1.0):
    """The covariance of one daily step of two OU factors with mean reversions kappa (a pair,
    0 = random walk), volatilities sigma_a, sigma_b and correlation rho: rho sigma_a sigma_b
    (1 - exp(-(k_a + k_b) dt)) / (k_a + k_b) (dt at k_a + k_b = 0)."""
    dt = 1.0 / DAYS_PER_YEAR
    total = kappa[0] + kappa[1]
    positive = total > 1e-12
    safe = jnp.where(positive, total, 1.0)
    integral = jnp.where(positive, -jnp.expm1(-safe * dt) / safe, dt)
    sigma_b = sigma_a if sigma_b is None else sigma_b
    return rho * sigma_a * sigma_b * integral


class OneFactorModel(AbstractPriceModel):
    """The built-in one-factor model: log(S_t / F_t) = X_t - v_t / 2, X an Ornstein-Uhlenbeck
    factor. **Fields:** `mean_reversion` kappa [1/yr], `volatility` sigma [1/sqrt(yr)]."""

    mean_reversion: jax.Array
    volatility: jax.Array

    @property
    def factor_names(self):
        return ("spot",)

    def decay(self):
        return jnp.exp(-self.mean_reversion / DAYS_PER_YEAR)[None]

    def step_covariance(self):
        kappa = jnp.asarray(self.mean_reversion)
        return _ou_step((kappa, kappa), self.volatility)[None, None]

    def loadings(self, n_days):
        return jnp.ones((n_days, 1))


class TwoFactorModel(AbstractPriceModel):
    """Schwartz & Smith (2000): log(S_t / F_t) = chi_t + xi_t - v_t / 2, chi an OU factor (short
    term) and xi a random walk (long term), correlated. **Fields:** `short_mean_reversion`
    kappa [1/yr], `short_volatility` sigma_chi and `long_volatility` sigma_xi [1/sqrt(yr)],
    `correlation` rho in [-1, 1]."""

    short_mean_reversion: jax.Array
    short_volatility: jax.Array
    long_volatility: jax.Array
    correlation: jax.Array

    @property
    def factor_names(self):
        return ("short_term", "long_term")

    def decay(self):
        return jnp.stack([jnp.exp(-self.short_mean_reversion / DAYS_PER_YEAR), jnp.ones(())])

    def step_covariance(self):
        kappa, zero = jnp.asarray(self.short_mean_reversion), jnp.zeros(())
        short = _ou_step((kappa, kappa), self.short_volatility)
        long = _ou_step((zero, zero), self.long_volatility)
        cross = _ou_step((kappa, zero), self.short_volatility, self.long_volatility, self.correlation)
        return jnp.array([[short, cross], [cross, long]])

    def loadings(self, n_days):
        return jnp.ones((n_days, 2))


class ThreeFactorSeasonalModel(AbstractPriceModel):
    """The three-factor seasonal model: a mean-reverting spot factor, a long-term random walk
    and a seasonal random walk loaded by cos(2 pi (d - peak_day) / 365), independent.
    **Fields:** `spot_mean_reversion` [1/yr], `spot_volatility`, `long_volatility`,
    `seasonal_volatility` [1/sqrt(yr)], `peak_day` (the curve's day on which the seasonal
    loading is +1; day 0 = the curve's first day)."""

    spot_mean_reversion: jax.Array
    spot_volatility: jax.Array
    long_volatility: jax.Array
    seasonal_volatility: jax.Array
    peak_day: jax.Array

    @property
    def factor_names(self):
        return ("spot", "long_term", "seasonal")

    def decay(self):
        return jnp.stack([jnp.exp(-self.spot_mean_reversion / DAYS_PER_YEAR), jnp.ones(()), jnp.ones(())])

    def step_covariance(self):
        kappa, zero = jnp.asarray(self.spot_mean_reversion), jnp.zeros(())
        return jnp.diag(jnp.stack([_ou_step((kappa, kappa), self.spot_volatility),
                                   _ou_step((zero, zero), self.long_volatility),
                                   _ou_step((zero, zero), self.seasonal_volatility)]))

    def loadings(self, n_days):
        season = jnp.cos(2 * math.pi * (jnp.arange(n_days) - self.peak_day) / DAYS_PER_YEAR)
        return jnp.stack([jnp.ones(n_days), jnp.ones(n_days), season], axis=-1)


PRICE_MODELS = {"one-factor": OneFactorModel, "two-factor": TwoFactorModel, "three-factor": ThreeFactorSeasonalModel}


def model_paths(model: AbstractPriceModel, forward_curve, paths: int, key) -> PricePaths:
    """`paths` paths of `model` around `forward_curve` from the normal shocks of `key`."""
    k = len(model.factor_names)
    shocks = jax.random.normal(key, (paths, np.shape(forward_curve)[0], k))
    return model.simulate(jnp.asarray(forward_curve), shocks)
