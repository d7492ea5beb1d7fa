"""The gas-storage model: a policy chooses each day's net flow inside the feasible interval.

Day t = 0..T-1, start-of-day inventory V_t:

    V_{t+1} = V_t + (1 - fuel_loss) inj_t - wd_t,      0 <= V_t <= capacity,  V_T >= V_min
    inj_t <= max_injection  g_in(V_t / capacity),      wd_t <= max_withdrawal g_out(V_t / capacity)
    CF_t = -(P_t + injection_cost) inj_t + (P_t - withdrawal_cost) wd_t,   value = sum DF_t CF_t

with P_t the forward curve F_t (deterministic, intrinsic) or the simulated spot (stochastic).
The policy's action a in [-1, 1] asks for a fraction of the largest injection (a > 0) or
withdrawal (a < 0); the request is clipped to the feasible interval of net flows, whose lower
end also keeps the terminal requirement reachable (`inventory_floor`). With `sharpness=None`
every max/min/clip/ratchet is exact (the hard evaluation); with a float they are the smooth
surrogates of `snapo_ode.smooth` (training), and the inventory still never leaves [0, capacity].
"""

from typing import NamedTuple

import jax
import jax.numpy as jnp

from snapo_ode import EffectCatalogue, MLPPolicy, RolloutMethod, Scene, rollout, smooth

from ._inputs import DAYS_PER_YEAR, StorageInputs

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


def _flow_sharpness(inputs: StorageInputs, sharpness: float | None):
    """Sharpness for quantities in MMBtu: the dimensionless `sharpness` per the largest daily
    rate, so the smoothing gap is about log(2)/sharpness of a day's maximum flow."""
    if sharpness is None:
        return None
    return sharpness / jnp.maximum(inputs.max_injection, inputs.max_withdrawal)


def inventory_floor(inputs: StorageInputs, scene: Scene, sharpness: float | None) -> jax.Array:
    """L_t, shape (T+1,): the least start-of-day inventory from which V_T >= V_min can still be
    reached at the maximum injection rate: L_T = V_min, L_t = max(L_{t+1} - (1 - fuel_loss)
    max_injection g_in(L_{t+1} / capacity), 0). Exact when g_in does not increase with fill
    (as injection ratchets do), conservative otherwise."""
    kept = kept_fraction(inputs, scene)
    flow_k = _flow_sharpness(inputs, sharpness)

    def back(later, _):
        fill = later / inputs.capacity
        room = kept * inputs.max_injection * rate_fraction(inputs.injection_ratchet, fill, scene, sharpness)
        earlier = smooth.relu(later - room, flow_k)
        return earlier, earlier

    _, floors = jax.lax.scan(back, inputs.terminal_inventory_min, None, length=inputs.n_days)
    return jnp.concatenate([floors[::-1], inputs.terminal_inventory_min[None]])


HARMONICS = 24  # seasonal harmonics of the day: periods down to about two weeks on a 365-day year


def calendar_features(n_days: int) -> jax.Array:
    """Features of the day alone, shape (T, 1 + 2 HARMONICS): the day as a fraction of the
    horizon and the sine and cosine of `HARMONICS` harmonics, so that schedules with monthly or
    fortnightly swings can be represented. Computed once, outside the daily loop."""
    day = jnp.arange(n_days)
    phases = 2 * jnp.pi * day[:, None] / n_days * jnp.arange(1, HARMONICS + 1)
    return jnp.concatenate([(day / n_days)[:, None], jnp.sin(phases), jnp.cos(phases)], axis=1)


def policy_features(calendar, fill, headroom, log_spot_ratio, price, scene: Scene):
    """The day's `calendar_features`, the fill fraction and the headroom (inventory above
    tomorrow's floor as a fraction of capacity: what may still be withdrawn without missing the
    terminal requirement). In stochastic mode also the spot/forward log-ratio and the log spot
    price, since a desk's decision depends on the price level (as least-squares Monte Carlo
    regresses on spot). The deterministic policy sees day and inventory only, so its schedule
    does not depend on the forward curve."""
    features = [calendar, jnp.stack([fill, headroom])]
    if scene.has("stochastic_spot"):
        features.append(jnp.stack([log_spot_ratio, jnp.log(price)]))
    return jnp.concatenate(features)


# The split policy's scores are learned at any scale, so this only sets how soft training starts.
SCORE_SHARPNESS = 1.0


def make_policy(scene: Scene, inputs: StorageInputs, *, key, width: int = 32, depth: int = 2,
                spot_scale: float = 1.0, split_actions: bool = False) -> MLPPolicy:
    """A policy with one action in [-1, 1] (withdraw all ... inject all), or with
    `split_actions` two scores s_in, s_out: the request is step(s_in) times the largest injection
    less step(s_out) times the largest withdrawal, with the logistic step when training and the
    exact one in the hard evaluation, so the reported policy trades bang-bang (inject fully,
    withdraw fully or hold), as the optimal and the LSMC policies do. In
    stochastic mode the spot features are normalised by `spot_scale` (the factor's stationary
    standard deviation) around the training curve's mean log price (fixed at creation, not
    traced)."""
    n_day_features = 3 + 2 * HARMONICS
    actions = {} if split_actions else dict(action_low=-1.0, action_high=1.0)
    n_actions = 2 if split_actions else 1
    if not scene.has("stochastic_spot"):
        return MLPPolicy(n_day_features, n_actions, key=key, width=width, depth=depth, **actions)
    mean_log_price = float(jnp.mean(jnp.log(inputs.forward_curve)))
    offset = jnp.zeros(n_day_features + 2).at[-1].set(mean_log_price)
    scale = jnp.ones(n_day_features + 2).at[-2:].set(spot_scale)
    return MLPPolicy(n_day_features + 2, n_actions, key=key, width=width, depth=depth, feature_offset=offset,
                     feature_scale=scale, **actions)


def simulate_path(policy: MLPPolicy, inputs: StorageInputs, scene: Scene, prices: jax.Array,
                  log_spot_ratio: jax.Array, *, sharpness: float | None,
                  method: RolloutMethod = "scan", remat: bool = False) -> Schedule:
    """Run the policy over one price path. `prices` and `log_spot_ratio`: shape (T,);
    `method` and `remat`: as in `snapo_ode.rollout`."""
    n_days = inputs.n_days
    kept = kept_fraction(inputs, scene)
    flow_k = _flow_sharpness(inputs, sharpness)
    floor = inventory_floor(inputs, scene, sharpness)
    daily_rate = inputs.rate / DAYS_PER_YEAR

    def step(day, state, _, today):
        price, spot_ratio, floor_tomorrow, calendar = today
        inventory, value, _, _ = state
        fill = inventory / inputs.capacity
        room = (inputs.capacity - inventory) / kept
        max_in = smooth.minimum(
            inputs.max_injection * rate_fraction(inputs.injection_ratchet, fill, scene, sharpness), room, flow_k)
        max_out = smooth.minimum(
            inputs.max_withdrawal * rate_fraction(inputs.withdrawal_ratchet, fill, scene, sharpness),
            inventory, flow_k)
        upper = kept * max_in
        lower = smooth.minimum(smooth.maximum(-max_out, floor_tomorrow - inventory, flow_k), upper, flow_k)
        headroom = (inventory - floor_tomorrow) / inputs.capacity
        action = policy(policy_features(calendar, fill, headroom, spot_ratio, price, scene))
        if action.shape[0] == 2:  # split: inject and withdraw scores, a smooth step when training
            inject, withdraw = smooth.step(action, None if sharpness is None else SCORE_SHARPNESS)
            request = inject * upper - withdraw * max_out
        else:
            request = smooth.relu(action[0], sharpness) * upper - smooth.relu(-action[0], sharpness) * max_out
        net = smooth.clip(request, lower, upper, flow_k)
        injection = smooth.relu(net, flow_k) / kept
        withdrawal = smooth.relu(-net, flow_k)
        if scene.has("costs"):
            cash = -(price + inputs.injection_cost) * injection + (price - inputs.withdrawal_cost) * withdrawal
        else:
            cash = price * (withdrawal - injection)
        if scene.has("discounting"):
            cash = cash * jnp.exp(-daily_rate * day)
        return inventory + kept * injection - withdrawal, value + cash, injection, withdrawal

    zero = jnp.zeros_like(inputs.capacity)
    states = rollout(step, (inputs.initial_inventory, zero, zero, zero), n_days, method=method, remat=remat,
                     per_step=(prices, log_spot_ratio, floor[1:], calendar_features(n_days)))
    inventory, value, injection, withdrawal = states
    return Schedule(value[-1], injection[1:], withdrawal[1:], inventory)


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

    _, variance = jax.lax.scan(advance, jnp.zeros(()), None, length=inputs.n_days)
    return FactorTransition(decay, sigma * jnp.sqrt(step_variance), variance)


def spot_factor(inputs: StorageInputs, shocks: jax.Array) -> jax.Array:
    """The Ornstein-Uhlenbeck factor less half its variance, X_t - Var(X_t)/2, on daily steps
    from X_0 = 0, for shocks of shape (paths, T). Exact discretisation (`factor_transition`);
    mean_reversion 0 is Brownian motion."""
    transition = factor_transition(inputs)

    def advance(x, shock):
        return transition.decay * x + transition.step_sd * shock, x

    _, factor = jax.lax.scan(advance, jnp.zeros(shocks.shape[0]), shocks.T)
    return factor.T - transition.variance / 2


def spot_prices(inputs: StorageInputs, shocks: jax.Array) -> tuple[jax.Array, jax.Array]:
    """Monte Carlo spot paths spot_t = F_t exp(X_t - Var(X_t)/2) [$/MMBtu] and the factor
    X_t - Var(X_t)/2, both shape (paths, T), for `shocks` of shape (paths, T)."""
    factor = spot_factor(inputs, shocks)
    return inputs.forward_curve * jnp.exp(factor), factor


def simulate(policy: MLPPolicy, inputs: StorageInputs, scene: Scene, *, sharpness: float | None,
             shocks: jax.Array | None = None) -> Schedule:
    """Simulate the policy: on the forward curve (deterministic scene; `shocks` None), or on
    Monte Carlo spot paths spot_t = F_t exp(X_t - Var(X_t)/2) with `shocks` of shape
    (paths, T), common to every call that passes the same array."""
    if not scene.has("stochastic_spot"):
        zeros = jnp.zeros_like(inputs.forward_curve)
        return simulate_path(policy, inputs, scene, inputs.forward_curve, zeros, sharpness=sharpness)
    if shocks is None:
        raise ValueError("the stochastic_spot effect needs shocks of shape (paths, T)")
    prices, factor = spot_prices(inputs, shocks)
    # Recomputing each day in the reverse pass beats storing every path's activations (measured
    # 1.7x faster gradient at 1,000 paths).
    return jax.vmap(lambda p, f: simulate_path(policy, inputs, scene, p, f, sharpness=sharpness, remat=True))(
        prices, factor)


def expected_value(policy: MLPPolicy, inputs: StorageInputs, scene: Scene, *, sharpness: float | None,
                   shocks: jax.Array | None = None) -> jax.Array:
    """The value [$]: deterministic, or the Monte Carlo mean over the shock paths."""
    return jnp.mean(simulate(policy, inputs, scene, sharpness=sharpness, shocks=shocks).value)
