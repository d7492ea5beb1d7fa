"""The action heads: an MLP reads the day, the inventory and (stochastic) the price, and asks for
a fraction of the day's largest flow (`"fraction"`: one action in [-1, 1], withdraw all ...
inject all) or scores injection and withdrawal apart (`"split"`, bang-bang in the hard
evaluation). The inventory is an input, so the network runs inside the daily loop.
"""

import jax
import jax.numpy as jnp

from snapo_ode import MLPPolicy, RolloutMethod, Scene, rollout, smooth

from ._inputs import StorageInputs
from ._model import (
    HARMONICS,
    Schedule,
    calendar_features,
    feasible_flows,
    flow_sharpness,
    flows_and_cash,
    inventory_floor,
    kept_fraction,
    spot_prices,
)


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


def make_action_policy(scene: Scene, inputs: StorageInputs, *, key, width: int = 32, depth: int = 2,
                       spot_scale: float = 1.0, split: bool = False) -> MLPPolicy:
    """A policy with one action in [-1, 1] (withdraw all ... inject all), or with `split` two
    scores s_in, s_out: the request is step(s_in) times the largest injection less step(s_out)
    times the largest withdrawal, with the logistic step when training and the exact one in the
    hard evaluation, so the reported policy trades bang-bang (inject fully, withdraw fully or
    hold). In stochastic mode the spot features are normalised by `spot_scale` (the factor's
    stationary standard deviation) around the training curve's mean log price (fixed at
    creation, not traced)."""
    n_day_features = 3 + 2 * HARMONICS
    actions = {} if split else dict(action_low=-1.0, action_high=1.0)
    n_actions = 2 if split else 1
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
    """Run an action policy over one price path. `prices` and `log_spot_ratio`: shape (T,);
    `method` and `remat`: as in `snapo_ode.rollout`."""
    n_days = inputs.n_days
    kept = kept_fraction(inputs, scene)
    flow_k = flow_sharpness(inputs, sharpness)
    floor = inventory_floor(inputs, scene, sharpness)

    def step(day, state, _, today):
        price, spot_ratio, floor_tomorrow, calendar = today
        inventory, value, _, _ = state
        max_out, lower, upper = feasible_flows(inputs, scene, inventory, floor_tomorrow, sharpness)
        headroom = (inventory - floor_tomorrow) / inputs.capacity
        action = policy(policy_features(calendar, inventory / inputs.capacity, headroom, spot_ratio, price, scene))
        if action.shape[0] == 2:  # split: inject and withdraw scores, a smooth step when training
            inject, withdraw = smooth.step(action, None if sharpness is None else SCORE_SHARPNESS)
            request = inject * upper - withdraw * max_out
        else:
            request = smooth.relu(action[0], sharpness) * upper - smooth.relu(-action[0], sharpness) * max_out
        net = smooth.clip(request, lower, upper, flow_k)
        injection, withdrawal, cash = flows_and_cash(inputs, scene, net, price, day, sharpness)
        return inventory + kept * injection - withdrawal, value + cash, injection, withdrawal

    zero = jnp.zeros_like(inputs.capacity)
    states = rollout(step, (inputs.initial_inventory, zero, zero, zero), n_days, method=method, remat=remat,
                     per_step=(prices, log_spot_ratio, floor[1:], calendar_features(n_days)))
    inventory, value, injection, withdrawal = states
    return Schedule(value[-1], injection[1:], withdrawal[1:], inventory)


def simulate_actions(policy: MLPPolicy, inputs: StorageInputs, scene: Scene, *, sharpness: float | None,
                     shocks: jax.Array | None = None) -> Schedule:
    """Simulate an action policy on the forward curve (deterministic scene) or on the spot paths
    of `shocks` (paths, T)."""
    if not scene.has("stochastic_spot"):
        zeros = jnp.zeros_like(inputs.forward_curve)
        return simulate_path(policy, inputs, scene, inputs.forward_curve, zeros, sharpness=sharpness)
    prices, factor = spot_prices(inputs, shocks)
    # Recomputing each day in the reverse pass beats storing every path's activations (a faster
    # gradient: docs/dev/gas_storage_notes.md, Measurements behind the design).
    return jax.vmap(lambda p, f: simulate_path(policy, inputs, scene, p, f, sharpness=sharpness, remat=True))(
        prices, factor)
