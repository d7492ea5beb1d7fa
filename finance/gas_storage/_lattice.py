"""A reference valuation for the one-factor spot: dynamic programming on a lattice of the factor,
its decision rule, and the dual penalty built from its value function (the tightest measured).

The spot's only state is the Ornstein-Uhlenbeck factor X (spot_t = F_t exp(X_t - v_t / 2),
X_{t+1} = a X_t + s eps), so the value of the storage is V_t(n, X) on the inventory grid of
`_lsmc.py`. On `points` equally spaced levels x_g spanning +- `width` standard deviations of X,
V is represented by its piecewise-linear interpolant in X (flat beyond the ends), whose
expectation under a normal N(mu, s^2) is exact and linear in the level values:

    E[V~(Y)] = V_0 + sum_g (m_g - m_{g-1}) [(mu - x_g) N(d_g) + s n(d_g)],   d_g = (mu - x_g) / s,

with m_g the slope of V~ right of x_g (m_{-1} = m_{G-1} = 0). Backward over days,
C_t(n', x_g) = E[V~_{t+1}(n', a x_g + s eps)] and V_t(n, x_g) = max over the candidate inventories y
of `_lsmc.candidate_inventories` (continuous: the exact rates, ratchets and fuel loss included) of
[cash_t(y - V_n, S_t(x_g)) + C_t(y, x_g)], C_t interpolated linearly between levels. The lattice value at X_0 = 0 is an approximation (discretisation), not a bound;
its decision rule, run on paths with C_t interpolated at the path's X_t, is a non-anticipative
policy (a lower bound out of sample); and w_t(n') = V~_{t+1}(n', X_{t+1}) - E_t V~_{t+1}(n',
X_{t+1}), with the expectation above (exact), is a penalty for `_dual.py`. Specific to the
one-factor model: LSMC's regressions carry over to richer price models, this does not.
"""

from typing import NamedTuple

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
from jax.scipy.stats import norm

from snapo_ode import InputError, Scene, check_count, check_range

from ._inputs import StorageInputs
from ._lsmc import InventoryGrid, inventory_grid, level_decisions, run_continuation_policy, start_value
from ._model import Schedule, factor_transition, inventory_floor
from ._penalty import AbstractPenalty


LATTICE_WORK = 2e9  # days x factor levels x inventory levels x window of the lattice, at most (`lattice_grid`)
LATTICE_NODES = 4_001  # the most inventory levels `lattice_grid` gives


def lattice_grid(inputs: StorageInputs, scene: Scene, grid: InventoryGrid, *, points: int = 200,
                 work: float = LATTICE_WORK) -> InventoryGrid:
    """The finest inventory grid, `grid` or finer (up to LATTICE_NODES levels), whose lattice
    costs at most `work` (days x `points` x levels x the window a day reaches). The lattice's
    value function is the bound's penalty and its rule a reference policy: on a coarse grid both
    lose what the rates between levels are worth (on a ratcheted 90-day facility, 101 levels: the
    rule 2% below, the gap 3.2%; 1,001: 1.0%; docs/gas_storage.md)."""
    finest = grid
    nodes = grid.nodes
    while nodes < LATTICE_NODES:
        nodes = min(2 * nodes - 1, LATTICE_NODES)
        candidate = inventory_grid(inputs, scene, nodes)
        if inputs.n_days * points * candidate.nodes * candidate.window.size > work:
            break
        finest = candidate
    return finest


class FactorLattice(NamedTuple):
    """`factor`: the levels x_g, shape (G,); `continuation`: C_t(n', x_g), shape (T, G, N);
    `values`: V_t(n, x_g), shape (T, G, N) [$] (below the floor, the value of the forced largest
    injection); `value`: V_0 at the initial inventory and X_0 = 0 [$]."""

    factor: jax.Array
    continuation: jax.Array
    values: jax.Array
    value: jax.Array


def _calls(factor: jax.Array, mean: jax.Array, sd) -> jax.Array:
    """E (Y - x_g)^+ for Y ~ N(mean, sd^2), shape mean.shape + (G,)."""
    d = (mean[..., None] - factor) / sd
    return (mean[..., None] - factor) * norm.cdf(d) + sd * norm.pdf(d)


def _kinks(factor: jax.Array) -> jax.Array:
    """K, shape (G, G): K @ V are the slope changes m_g - m_{g-1} of the interpolant of levels V,
    so that E[V~(Y)] = V_0 + calls @ (K @ V)."""
    size = factor.shape[0]
    slopes = np.eye(size, k=1) - np.eye(size)  # row g: V_{g+1} - V_g = m_g dx; flat beyond the end
    slopes[-1] = 0.0
    return jnp.asarray(slopes - np.eye(size, k=-1) @ slopes) / (factor[1] - factor[0])


def interpolate_factor(factor: jax.Array, table: jax.Array, x: jax.Array) -> jax.Array:
    """Rows of `table` (G, N) interpolated linearly at `x` (paths,), flat beyond the ends."""
    spacing = factor[1] - factor[0]
    position = jnp.clip((x - factor[0]) / spacing, 0, factor.shape[0] - 1)
    low = jnp.clip(jnp.floor(position).astype(int), 0, factor.shape[0] - 2)
    weight = (position - low)[:, None]
    return (1 - weight) * table[low] + weight * table[low + 1]


def _factor(inputs: StorageInputs, prices: jax.Array) -> jax.Array:
    """X_t = log(S_t / F_t) + v_t / 2, shape (paths, T)."""
    return jnp.log(prices / inputs.forward_curve) + factor_transition(inputs).variance / 2


def solve_factor_lattice(inputs: StorageInputs, scene: Scene, grid: InventoryGrid, *, points: int = 200,
                         width: float = 7.0) -> FactorLattice:
    """Backward induction on `points` factor levels over +- `width` times the largest standard
    deviation of X_t over the horizon.

    **Raises:** `InputError` at zero volatility (nothing to discretise: use the intrinsic LP).
    """
    check_count("points", points, 3, 100_000)
    check_range("width", width, 1.0, 50.0)
    if float(inputs.volatility) <= 0:
        raise InputError("volatility = 0: the factor lattice needs a random spot; the intrinsic LP is exact here.")
    return _solve(inputs, scene, grid, int(points), float(width))


@eqx.filter_jit
def _solve(inputs: StorageInputs, scene: Scene, grid: InventoryGrid, points: int, width: float) -> FactorLattice:
    transition = factor_transition(inputs)
    spread = width * jnp.sqrt(jnp.max(transition.variance))
    factor = jnp.linspace(-spread, spread, points)
    # E[V~_{t+1}(a x_g + s eps)] = weights @ V_{t+1}, the same (G, G) matrix every day.
    weights = jnp.zeros(points).at[0].set(1.0) + _calls(factor, transition.decay * factor, transition.step_sd) @ _kinks(
        factor)

    def back(later, today):
        day, forward, variance, floor_tomorrow = today
        continuation = weights @ later
        _, values = level_decisions(inputs, scene, grid, forward * jnp.exp(factor - variance / 2), day,
                                    floor_tomorrow, continuation)
        return values, (continuation, values)

    _, (continuation, values) = jax.lax.scan(
        back, jnp.zeros((points, grid.nodes)),
        (jnp.arange(inputs.n_days), inputs.forward_curve, transition.variance, inventory_floor(inputs, scene, None)[1:]),
        reverse=True)
    value = start_value(inputs, grid, interpolate_factor(factor, values[0], jnp.zeros(1)))[0]
    return FactorLattice(factor, continuation, values, value)


@eqx.filter_jit
def run_lattice_policy(lattice: FactorLattice, inputs: StorageInputs, scene: Scene, grid: InventoryGrid,
                       prices: jax.Array) -> Schedule:
    """The lattice's decision rule on `prices` (paths, T): each day the candidate inventory
    maximising today's cash plus C_t interpolated at the path's X_t and between levels. Returns
    the hard schedule, as `run_lsmc_policy` does."""

    def continuation(today, _):
        x, table = today
        return interpolate_factor(lattice.factor, table, x)

    return run_continuation_policy(inputs, scene, grid, prices, continuation,
                                   (_factor(inputs, prices).T, lattice.continuation))


class LatticePenalty(AbstractPenalty):
    """w_t(n') = V~_{t+1}(n', X_{t+1}) - E_t V~_{t+1}(n', X_{t+1}) from a `FactorLattice`'s
    values, the expectation exact (see the module docstring); 0 on the last day."""

    factor: jax.Array
    later_values: jax.Array  # V_{t+1}, shape (T, G, N), zero for t = T - 1

    def __init__(self, lattice: FactorLattice):
        self.factor = lattice.factor
        self.later_values = jnp.concatenate([lattice.values[1:], jnp.zeros_like(lattice.values[:1])])

    def daily(self, inputs: StorageInputs, prices: jax.Array, paths=None):
        transition = factor_transition(inputs)
        factor = _factor(inputs, prices)
        following = jnp.concatenate([factor[:, 1:], factor[:, -1:]], axis=1)
        sd = jnp.broadcast_to(transition.step_sd, (inputs.n_days,))
        return transition.decay * factor.T, following.T, sd, self.later_values

    def today(self, day_inputs) -> jax.Array:
        mean, following, sd, later = day_inputs
        # At zero volatility (sd 0) the lattice is refused; the guard keeps the trace finite.
        calls = _calls(self.factor, mean, jnp.maximum(sd, 1e-300))
        expected = later[0] + calls @ (_kinks(self.factor) @ later)
        return interpolate_factor(self.factor, later, following) - expected
