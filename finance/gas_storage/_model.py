"""The gas-storage model: a policy chooses each day's net flow inside the feasible interval.

Day t = 0..T-1, start-of-day inventory V_t:

    V_{t+1} = V_t + (1 - fuel_loss) inj_t - wd_t,      0 <= V_t <= capacity,  V_T >= V_min
    inj_t <= max_injection  g_in(V_t / capacity),      wd_t <= max_withdrawal g_out(V_t / capacity)
    CF_t = -(P_t + injection_cost) inj_t + (P_t - withdrawal_cost) wd_t,   value = sum DF_t CF_t

with P_t the forward curve F_t (deterministic, intrinsic) or the simulated spot (stochastic).
A policy chooses a net flow, which is clipped to the day's feasible interval (`feasible_flows`),
whose lower end also keeps the terminal requirement reachable (`inventory_floor`); the flows
then give the day's cash (`flows_and_cash`). This module holds what every policy head shares:
the effects, the constraints, the cash, the spot paths and the calendar features; the heads
live in `_action_heads.py` and `_basestock.py`, and `_policy.py` picks one. With
`sharpness=None` every max/min/clip/ratchet is exact (the hard evaluation); with a float they are
the smooth surrogates of `snapo_ode.smooth` (training), and the inventory still never leaves
[0, capacity].
"""

from typing import NamedTuple

import jax
import jax.numpy as jnp

from snapo_ode import EffectCatalogue, Scene, rollout, smooth

from ._inputs import DAYS_PER_YEAR, StorageInputs
from ._paths import PricePaths

GAS_EFFECTS = EffectCatalogue(
    "gas storage",
    {
        "ratchets": "inventory-dependent injection and withdrawal rate limits (the ratchet tables)",
        "fuel_loss": "a fraction fuel_loss of injected gas is lost",
        "costs": "per-unit injection and withdrawal costs",
        "discounting": "cash flows discounted at the continuously compounded rate",
        "stochastic_spot": "trade at a simulated one-factor spot around the forward curve",
    },
)


def deterministic_scene() -> Scene:
    """Every effect but the stochastic spot: the intrinsic problem."""
    return GAS_EFFECTS.scene(without=["stochastic_spot"])


def stochastic_scene() -> Scene:
    """Every effect."""
    return GAS_EFFECTS.scene()


class Schedule(NamedTuple):
    """One simulation. Shapes: (T,) per path for flows, (T+1,) for inventory, with a leading
    paths axis in stochastic mode. `value` [$] per path; flows [MMBtu/day]; inventory [MMBtu]."""

    value: jax.Array
    injection: jax.Array
    withdrawal: jax.Array
    inventory: jax.Array


def rate_fraction(table: jax.Array, fill: jax.Array, scene: Scene, sharpness: float | None):
    """The ratchet's rate fraction at a fill fraction; 1 when the ratchets effect is off."""
    if not scene.has("ratchets"):
        return jnp.ones_like(fill)
    return smooth.piecewise_linear(fill, table[:, 0], table[:, 1], sharpness)


def kept_fraction(inputs: StorageInputs, scene: Scene):
    """1 - fuel_loss, or exactly 1 when the fuel-loss effect is off."""
    return 1.0 - inputs.fuel_loss if scene.has("fuel_loss") else 1.0


def flow_sharpness(inputs: StorageInputs, sharpness: float | None):
    """Sharpness for quantities in MMBtu: the dimensionless `sharpness` per the largest daily
    rate, so the smoothing gap is about log(2)/sharpness of a day's maximum flow."""
    if sharpness is None:
        return None
    return sharpness / jnp.maximum(inputs.max_injection, inputs.max_withdrawal)


def largest_flows(inputs: StorageInputs, scene: Scene) -> tuple[float, float]:
    """The largest daily net injection (after fuel loss) and withdrawal at any fill [MMBtu/day],
    as host floats: the rates times the ratchets' largest fractions (1 without the ratchets effect)."""
    kept = float(kept_fraction(inputs, scene))
    fraction = lambda table: float(jnp.max(table[:, 1])) if scene.has("ratchets") else 1.0  # noqa: E731
    return (kept * float(inputs.max_injection) * fraction(inputs.injection_ratchet),
            float(inputs.max_withdrawal) * fraction(inputs.withdrawal_ratchet))


def floor_step(inputs: StorageInputs, scene: Scene, sharpness: float | None):
    """`inventory_floor`'s backward step, (day, L_{t+1}, _) -> L_t, for `snapo_ode.rollout`."""
    kept = kept_fraction(inputs, scene)
    flow_k = flow_sharpness(inputs, sharpness)

    def back(day, later, _):
        fill = later / inputs.capacity
        room = kept * inputs.max_injection * rate_fraction(inputs.injection_ratchet, fill, scene, sharpness)
        return smooth.relu(later - room, flow_k)

    return back


def backward_recursion(step, inputs: StorageInputs, scene: Scene, terminal: jax.Array) -> jax.Array:
    """The states of a recursion from the last day back, `terminal` at T, shape (T+1, ...), with
    the closed-form reverse pass where the simulation is one path too (beside Monte Carlo paths
    such a recursion's reverse pass is negligible, and the scan compiles faster)."""
    return rollout(step, terminal, inputs.n_days, elementwise=not scene.has("stochastic_spot"))[::-1]


def inventory_floor(inputs: StorageInputs, scene: Scene, sharpness: float | None) -> jax.Array:
    """L_t, shape (T+1,): the least start-of-day inventory from which V_T >= V_min can still be
    reached at the maximum injection rate: L_T = V_min, L_t = max(L_{t+1} - (1 - fuel_loss)
    max_injection g_in(L_{t+1} / capacity), 0). Exact when g_in does not increase with fill
    (as injection ratchets do), conservative otherwise."""
    return backward_recursion(floor_step(inputs, scene, sharpness), inputs, scene, inputs.terminal_inventory_min)


def feasible_flows(inputs: StorageInputs, scene: Scene, inventory, floor_tomorrow, sharpness: float | None):
    """The day's largest withdrawal `max_out` and the feasible interval [lower, upper] of net
    flows into store [MMBtu/day], elementwise in `inventory`: upper = (1 - fuel_loss) times the
    largest injection (ratchet, room left), lower = the largest withdrawal, or less where
    tomorrow's floor requires (so the terminal requirement stays reachable), never above upper."""
    kept = kept_fraction(inputs, scene)
    flow_k = flow_sharpness(inputs, sharpness)
    fill = inventory / inputs.capacity
    room = (inputs.capacity - inventory) / kept
    max_in = smooth.minimum(
        inputs.max_injection * rate_fraction(inputs.injection_ratchet, fill, scene, sharpness), room, flow_k)
    max_out = smooth.minimum(
        inputs.max_withdrawal * rate_fraction(inputs.withdrawal_ratchet, fill, scene, sharpness), inventory, flow_k)
    upper = kept * max_in
    lower = smooth.minimum(smooth.maximum(-max_out, floor_tomorrow - inventory, flow_k), upper, flow_k)
    return max_out, lower, upper


def flows_and_cash(inputs: StorageInputs, scene: Scene, net, price, day, sharpness: float | None):
    """Injection and withdrawal [MMBtu/day] of a feasible net flow into store, and the day's
    discounted cash flow [$] at `price`, elementwise."""
    kept = kept_fraction(inputs, scene)
    flow_k = flow_sharpness(inputs, sharpness)
    injection = smooth.relu(net, flow_k) / kept
    withdrawal = smooth.relu(-net, flow_k)
    if scene.has("costs"):
        cash = -(price + inputs.injection_cost) * injection + (price - inputs.withdrawal_cost) * withdrawal
    else:
        cash = price * (withdrawal - injection)
    if scene.has("discounting"):
        cash = cash * jnp.exp(-inputs.rate / DAYS_PER_YEAR * day)
    return injection, withdrawal, cash


HARMONICS = 24  # seasonal harmonics of the day: periods down to about two weeks on a 365-day year


def calendar_features(n_days: int, harmonics: int = HARMONICS) -> jax.Array:
    """Features of the day alone, shape (T, 1 + 2 harmonics): the day as a fraction of the
    horizon and the sine and cosine of `harmonics` harmonics, so that schedules with monthly or
    fortnightly swings can be represented. Computed once, outside the daily loop."""
    day = jnp.arange(n_days)
    phases = 2 * jnp.pi * day[:, None] / n_days * jnp.arange(1, harmonics + 1)
    return jnp.concatenate([(day / n_days)[:, None], jnp.sin(phases), jnp.cos(phases)], axis=1)


class FactorTransition(NamedTuple):
    """The exact daily step of the spot factor, as `spot_factor` takes it: `decay` a, `step_sd`
    s (scalars) and `variance` v_t = Var(X_t), shape (T,)."""

    decay: jax.Array
    step_sd: jax.Array
    variance: jax.Array


def factor_transition(inputs: StorageInputs) -> FactorTransition:
    """The exact daily step of the Ornstein-Uhlenbeck factor X (X_0 = 0): a = exp(-kappa dt),
    s^2 = sigma^2 (1 - a^2) / (2 kappa) (sigma^2 dt at kappa = 0) and Var(X_t)."""
    dt = 1.0 / DAYS_PER_YEAR
    kappa, sigma = inputs.mean_reversion, inputs.volatility
    positive = kappa > 1e-12
    safe_kappa = jnp.where(positive, kappa, 1.0)
    step_variance = jnp.where(positive, -jnp.expm1(-2 * safe_kappa * dt) / (2 * safe_kappa), dt)
    decay = jnp.exp(-kappa * dt)

    def advance(variance, _):
        return decay**2 * variance + sigma**2 * step_variance, variance

    _, variance = jax.lax.scan(advance, jnp.zeros_like(sigma), None, length=inputs.n_days)
    return FactorTransition(decay, sigma * jnp.sqrt(step_variance), variance)


def spot_factor(inputs: StorageInputs, shocks: jax.Array) -> jax.Array:
    """The Ornstein-Uhlenbeck factor less half its variance, X_t - Var(X_t)/2, on daily steps
    from X_0 = 0, for shocks of shape (paths, T). Exact discretisation (`factor_transition`);
    mean_reversion 0 is Brownian motion."""
    transition = factor_transition(inputs)

    def advance(x, shock):
        return transition.decay * x + transition.step_sd * shock, x

    _, factor = jax.lax.scan(advance, jnp.zeros(shocks.shape[0], shocks.dtype), shocks.T)
    return factor.T - transition.variance / 2


def spot_prices(inputs: StorageInputs, shocks) -> tuple[jax.Array, jax.Array]:
    """Monte Carlo spot paths spot_t = F_t exp(X_t - Var(X_t)/2) [$/MMBtu] and the factor
    X_t - Var(X_t)/2, both shape (paths, T), for `shocks` of shape (paths, T); or, for given
    `PricePaths` (`_paths.py`: a paths file, a multi-factor model), F_t exp(log ratio) and the
    log ratio."""
    if isinstance(shocks, PricePaths):
        return inputs.forward_curve * jnp.exp(shocks.log_ratio), shocks.log_ratio
    factor = spot_factor(inputs, shocks)
    return inputs.forward_curve * jnp.exp(factor), factor
