"""Penalties for the dual bound (`_dual.py`): zero-mean martingale increments built from a
value-function approximation, w_t(n') = sum_q beta_{t,q}(n', x_t) [phi_q(S_{t+1}) - E_t phi_q(S_{t+1})],
with E_t phi exact under the Ornstein-Uhlenbeck spot (never estimated), and beta regressed on the
LSMC's fitting paths (see `_dual.py` for the bound and the references).

Under the model, X_t = log(S_t / F_t) + v_t / 2 and, given day t, log(S_{t+1} / F_{t+1}) is
normal with mean m_t = a X_t - v_{t+1} / 2 and standard deviation s (`factor_transition`), so the
shock eps_{t+1} = (log(S_{t+1} / F_{t+1}) - m_t) / s is standard normal and independent of day t.
The bases:

- `SpotPowers(D)`: u^d, d = 1..D, of u = (S_{t+1} / F_{t+1} - 1) / c_{t+1} (c the LSMC's spot
  scale), with E_t (S / F)^i = exp(i m_t + i^2 s^2 / 2) expanded binomially.
- `ShockHermite(K)`: He_k(eps_{t+1}) / sqrt(k!), k = 1..K, of conditional mean 0.
- `SpotCalls(strikes)`: max(S_{t+1} / F_{t+1} - K, 0) less its Black price
  exp(m_t + s^2 / 2) N(d_1) - K N(d_1 - s), d_1 = (m_t + s^2 - log K) / s.

Each is multiplied by 1, x_t, ..., x_t^J (`state_degree` J; x_t the LSMC's standardised spot of
day t), so beta may depend on day t's spot: the features stay of conditional mean zero. beta_t is
the coefficient of these features in a least-squares regression, on paths other than the
evaluation's, of the value of the days after t from each node together with 1, x_t, ..., x_t^degree
(which absorb the conditional mean): either the realised cash flows of the LSMC's decision rule
(`target="realised"`) or the LSMC's own value estimate max_k [cash_{t+1}(k) +
continuation_{t+1}(n' + k)] (`target="fitted"`). Any other value-function approximation gives a
penalty the same way, as an `AbstractPenalty` (the factor lattice of `_lattice.py`).
"""

import abc
import math
from typing import Literal, NamedTuple

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
from jax.scipy.special import ndtr

from snapo_ode import Scene, check_count

from ._inputs import StorageInputs
from ._lsmc import InventoryGrid, LSMCFit, _basis, level_decisions
from ._model import factor_transition, inventory_floor

PenaltyTarget = Literal["realised", "fitted"]


class DayStep(NamedTuple):
    """What the bases see of one day's step, per path: `log_ratio_next` log(S_{t+1} / F_{t+1}),
    its conditional `mean` m_t given day t, the (common) `step_sd` s > 0 or 1 where the step is
    deterministic (`random` False), and `next_scale` c_{t+1}."""

    log_ratio_next: jax.Array
    mean: jax.Array
    step_sd: jax.Array
    random: jax.Array
    next_scale: jax.Array


class AbstractInnovationBasis(eqx.Module):
    """Functions phi_p of the next day's spot, returned as phi_p(S_{t+1}) - E_t phi_p(S_{t+1})
    with the conditional expectation in closed form."""

    @abc.abstractmethod
    def innovations(self, step: DayStep) -> jax.Array:
        """Shape (paths, P)."""

    @property
    @abc.abstractmethod
    def size(self) -> int:
        """P."""


class SpotPowers(AbstractInnovationBasis):
    degree: int = eqx.field(static=True)

    @property
    def size(self) -> int:
        return self.degree

    def innovations(self, step: DayStep) -> jax.Array:
        powers = jnp.arange(self.degree + 1)
        # E_t (S/F)^i, i = 0..D, for lognormal S/F: exp(i m + i^2 s^2 / 2).
        raw = jnp.exp(powers * step.mean[:, None] + 0.5 * (powers * step.step_sd) ** 2)
        u = (jnp.exp(step.log_ratio_next) - 1.0) / step.next_scale
        columns = []
        for d in range(1, self.degree + 1):
            signs = np.array([math.comb(d, i) * (-1.0) ** (d - i) for i in range(d + 1)])
            expected = raw[:, : d + 1] @ signs / step.next_scale**d
            columns.append(u**d - expected)
        return jnp.stack(columns, axis=-1)


class ShockHermite(AbstractInnovationBasis):
    degree: int = eqx.field(static=True)

    @property
    def size(self) -> int:
        return self.degree

    def innovations(self, step: DayStep) -> jax.Array:
        shock = (step.log_ratio_next - step.mean) / step.step_sd
        previous, current = jnp.ones_like(shock), shock
        columns = [current]
        for k in range(1, self.degree):
            previous, current = current, shock * current - k * previous
            columns.append(current / math.sqrt(math.factorial(k + 1)))
        return jnp.stack(columns, axis=-1)


class SpotCalls(AbstractInnovationBasis):
    strikes: tuple[float, ...] = eqx.field(static=True)

    @property
    def size(self) -> int:
        return len(self.strikes)

    def innovations(self, step: DayStep) -> jax.Array:
        strikes = jnp.asarray(self.strikes)
        ratio = jnp.exp(step.log_ratio_next)[:, None]
        mean, sd = step.mean[:, None], step.step_sd
        d1 = (mean + sd**2 - jnp.log(strikes)) / sd
        black = jnp.exp(mean + 0.5 * sd**2) * ndtr(d1) - strikes * ndtr(d1 - sd)
        return jnp.maximum(ratio - strikes, 0.0) - black


def _day_steps(inputs: StorageInputs, prices: jax.Array, spot_scale: jax.Array) -> DayStep:
    """The DayStep of every day t = 0..T-2 stacked on a leading day axis (paths on the second);
    the last day's row repeats day T-2's next day and is never used with a non-zero beta."""
    transition = factor_transition(inputs)
    log_ratio = jnp.log(prices / inputs.forward_curve)  # (paths, T)
    factor = log_ratio + transition.variance / 2
    next_log_ratio = jnp.concatenate([log_ratio[:, 1:], log_ratio[:, -1:]], axis=1)
    next_variance = jnp.concatenate([transition.variance[1:], transition.variance[-1:]])
    mean = transition.decay * factor - next_variance / 2
    random = transition.step_sd > 0
    step_sd = jnp.where(random, transition.step_sd, 1.0)
    next_scale = jnp.concatenate([spot_scale[1:], spot_scale[-1:]])
    return DayStep(next_log_ratio.T, mean.T, jnp.broadcast_to(step_sd, (inputs.n_days,)),
                   jnp.broadcast_to(random, (inputs.n_days,)), next_scale)


def _features(basis: AbstractInnovationBasis, step: DayStep, ratio, scale, state_degree: int):
    """The zero-mean features x_t^j (phi_p - E_t phi_p), shape (paths, (J + 1) P); exactly 0 when
    the day's step is deterministic (zero volatility)."""
    innovations = jnp.where(step.random, basis.innovations(step), 0.0)
    state = _basis(ratio, scale, state_degree)  # (paths, J + 1)
    return (state[:, :, None] * innovations[:, None, :]).reshape(ratio.shape[0], -1)


def _penalty_regression(predictable, features, target):
    """The coefficients of `features` (paths, Q) in the least-squares fit of `target` (paths, N)
    on [predictable, features]: normal equations of unit-RMS columns with a ridge of 1e-10 (the
    columns differ in scale by orders of magnitude and can be collinear, e.g. on day 0 where
    every path has the same spot; JAX's SVD `lstsq` cost more than the rest of a day's work:
    docs/dev/gas_storage_notes.md, Measurements behind the design). A feature
    that barely varies on these paths (std below 1e-8 of the largest, such as a far
    out-of-the-money call early on, whose payoff no fitting path sees) gets coefficient 0: fitted,
    its huge coefficient would make the penalty's sample mean on other paths heavy-tailed."""
    spread = jnp.std(features, axis=0)
    varies = spread > 1e-8 * jnp.max(spread)
    design = jnp.concatenate([predictable, jnp.where(varies, features, 0.0)], axis=1)
    rms = jnp.sqrt(jnp.mean(design**2, axis=0))
    safe = jnp.where(rms > 0, rms, 1.0)
    scaled = design / safe
    gram = scaled.T @ scaled + 1e-10 * design.shape[0] * jnp.eye(design.shape[1])
    solution = jax.scipy.linalg.solve(gram, scaled.T @ target, assume_a="pos")
    solution = jnp.where(rms[:, None] > 0, solution / safe[:, None], 0.0)
    return solution[predictable.shape[1]:]


class AbstractPenalty(eqx.Module):
    """A penalty w_t(n') of zero conditional mean given day t. `daily` gathers, from the prices,
    what each day needs (a pytree with a leading day axis, scanned over); `today` turns one
    day's slice into w_t for every path and node, shape (paths, N) [$]. `paths`: the same paths
    as `PricePaths` with the price model's state, for penalties that read more than the spot
    (None where the spot is the whole state). A subclass may name itself in reports by a class
    attribute `label`."""

    @abc.abstractmethod
    def daily(self, inputs: StorageInputs, prices: jax.Array, paths=None):
        """Per-day inputs of `today`, leading axis T."""

    @abc.abstractmethod
    def today(self, day_inputs) -> jax.Array:
        """w_t(n'), shape (paths, N)."""


class RegressionPenalty(AbstractPenalty):
    """w_t(n') = sum_q beta_{t,q}(n') x_t^j (phi_p(S_{t+1}) - E_t phi_p(S_{t+1})), q = (j, p).
    `coefficients`: shape (T, (J + 1) P, N), zero on the last day; `spot_scale`: the LSMC's c_t,
    shape (T,)."""

    basis: AbstractInnovationBasis
    coefficients: jax.Array
    spot_scale: jax.Array
    state_degree: int = eqx.field(static=True)

    def daily(self, inputs: StorageInputs, prices: jax.Array, paths=None):
        ratio = prices / inputs.forward_curve
        return _day_steps(inputs, prices, self.spot_scale), ratio.T, self.spot_scale, self.coefficients

    def today(self, day_inputs) -> jax.Array:
        step, ratio_t, scale, beta = day_inputs
        return _features(self.basis, step, ratio_t, scale, self.state_degree) @ beta


@eqx.filter_jit
def fit_penalty(fit: LSMCFit, inputs: StorageInputs, scene: Scene, grid: InventoryGrid, prices: jax.Array,
                basis: AbstractInnovationBasis, *, state_degree: int = 0, degree: int = 3,
                target: PenaltyTarget = "fitted") -> RegressionPenalty:
    """Fit beta by regressing the value of the days after t from every node on the zero-mean
    features (and on 1, x_t, ..., x_t^degree, which absorb the conditional mean), on `prices` of
    shape (paths, T) [$/MMBtu]: the LSMC's fitting paths or others, never the evaluation paths.
    The LSMC's decisions are replayed backward with `fit` frozen (on the fitting paths this
    reproduces `fit_lsmc`'s realised values exactly). `target`: see the module docstring
    ("fitted" gives the tighter bound: docs/gas_storage.md, the LSMC-penalty attempts).

    **Raises:** `InputError` for a degree outside [0, 12]; `ValueError` for an unknown `target`.
    """
    check_count("state_degree", state_degree, 0, 12)
    check_count("degree", degree, 0, 12)
    if target not in ("realised", "fitted"):
        raise ValueError(f'target = {target!r}: use "fitted" or "realised".')
    n_days = inputs.n_days
    steps = _day_steps(inputs, prices, fit.spot_scale)
    ratio = prices / inputs.forward_curve
    lsmc_degree = fit.coefficients.shape[1] - 1

    def back(later, today):
        realised_later, fitted_later = later
        day, price, ratio_t, scale, coefficients, floor_tomorrow, step = today
        features = _features(basis, step, ratio_t, scale, state_degree)
        value_after = realised_later if target == "realised" else fitted_later
        beta = _penalty_regression(_basis(ratio_t, scale, degree), features, value_after)
        beta = jnp.where(day < n_days - 1, beta, 0.0)
        # The LSMC's own decision at day t, as in fit_lsmc; "fitted" is its maximised score.
        continuation = _basis(ratio_t, scale, lsmc_degree) @ coefficients
        realised, fitted = level_decisions(inputs, scene, grid, price, day, floor_tomorrow, continuation,
                                           realised_later)
        return (realised, fitted), beta

    zeros = jnp.zeros((prices.shape[0], grid.nodes))
    per_day = (jnp.arange(n_days), prices.T, ratio.T, fit.spot_scale, fit.coefficients,
               inventory_floor(inputs, scene, None)[1:], steps)
    _, beta = jax.lax.scan(back, (zeros, zeros), per_day, reverse=True)
    return RegressionPenalty(basis, beta, fit.spot_scale, state_degree)


class BlendedPenalty(AbstractPenalty):
    """`weight` w1 + (1 - `weight`) w2 of two penalties `first` and `second` (each of conditional
    mean zero, so the blend is too). The dual bound is convex in the penalty, so the blend's
    bound is at most the same blend of the two bounds, and below both where their errors differ."""

    first: AbstractPenalty
    second: AbstractPenalty
    weight: float = eqx.field(static=True)

    @property
    def label(self) -> str:
        return f"{self.weight:g} x {self.first.label} + {1 - self.weight:g} x {self.second.label}"

    @property
    def model(self):
        """The price model of the first penalty (whose conditional means it takes)."""
        return self.first.model

    def daily(self, inputs: StorageInputs, prices: jax.Array, paths=None):
        return self.first.daily(inputs, prices, paths), self.second.daily(inputs, prices, paths)

    def today(self, day_inputs) -> jax.Array:
        first, second = day_inputs
        return self.weight * self.first.today(first) + (1 - self.weight) * self.second.today(second)
