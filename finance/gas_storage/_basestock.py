"""The basestock head (Secomandi 2010, Management Science 56(3)): the policy outputs two
inventory targets b_L <= b_U from the day and the price, and the day's net flow moves the
inventory towards them at the largest feasible rate:

    net = clip(b_L - V, 0, max_in) - clip(V - b_U, 0, max_out),  then clipped to [lower, upper]

(inject up to b_L when below it, withdraw down to b_U when above it, hold in between), with
[lower, upper] the model's feasible interval (`feasible_flows`), so the terminal requirement
stays reachable. For one storage and a one-factor price the optimal policy has this form; with
no costs and no fuel loss the band closes (b_L = b_U).

The targets depend on the day and the price, not on the inventory, so the network runs once
over every (path, day) outside the daily loop, as one batched matrix product, and the loop only
moves the inventory. The targets live between tomorrow's floor (`inventory_floor`) and ceiling
(`inventory_ceiling`): gas above the ceiling can no longer be sold by the end.
"""

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np

from snapo_ode import Scene, rollout, smooth

from ._inputs import StorageInputs
from ._lattice import interpolate_factor
from ._model import (
    Schedule,
    backward_recursion,
    calendar_features,
    feasible_flows,
    floor_step,
    flow_sharpness,
    flows_and_cash,
    rate_fraction,
    spot_prices,
)

BASESTOCK_HARMONICS = 4  # the B&dJ targets vary over the season, not week to week
# Targets span the floor-to-ceiling range extended by this fraction on each side, so that the
# logistic output reaches the bounds exactly (the clip then saturates: full injection or
# withdrawal) with finite logits.
TARGET_OVERSHOOT = 0.1
BAND_INIT = -9.0  # softplus(-9) = 1.2e-4: the band starts closed, as optimal without costs (Adam still opens it)
PRICE_DEGREE = 3  # the targets' logits are cubic in the standardised spot/forward log-ratio
# Up to this many paths the daily rollout's reverse pass is the closed form of an elementwise
# recursion, the faster up to here; beyond it, the scan's own (docs/dev/gas_storage_notes.md, Measurements
# behind the design).
ELEMENTWISE_PATHS = 128


def _ceiling_step(inputs: StorageInputs, scene: Scene, sharpness: float | None):
    """`inventory_ceiling`'s backward step, (day, U_{t+1}, _) -> U_t."""
    flow_k = flow_sharpness(inputs, sharpness)

    def back(day, later, _):
        fill = later / inputs.capacity
        room = inputs.max_withdrawal * rate_fraction(inputs.withdrawal_ratchet, fill, scene, sharpness)
        return smooth.minimum(later + room, inputs.capacity, flow_k)

    return back


def inventory_ceiling(inputs: StorageInputs, scene: Scene, sharpness: float | None) -> jax.Array:
    """U_t, shape (T+1,): the most start-of-day inventory that can still be withdrawn down to the
    terminal requirement by the end: U_T = V_min, U_t = min(U_{t+1} + max_withdrawal
    g_out(U_{t+1} / capacity), capacity). Gas above it cannot be sold before the end. Exact when
    g_out does not increase with fill, conservative (lower) otherwise."""
    return backward_recursion(_ceiling_step(inputs, scene, sharpness), inputs, scene, inputs.terminal_inventory_min)


def inventory_bounds(inputs: StorageInputs, scene: Scene, sharpness: float | None) -> tuple[jax.Array, jax.Array]:
    """(`inventory_floor`, `inventory_ceiling`), each shape (T+1,), from one recursion over the
    pair (one loop instead of two, in the forward pass and the reverse one)."""
    floor_back, ceiling_back = floor_step(inputs, scene, sharpness), _ceiling_step(inputs, scene, sharpness)

    def back(day, later, _):
        return jnp.stack([floor_back(day, later[0], _), ceiling_back(day, later[1], _)])

    bounds = backward_recursion(back, inputs, scene, jnp.stack([inputs.terminal_inventory_min] * 2))
    return bounds[:, 0], bounds[:, 1]


class BasestockPolicy(eqx.Module):
    """The logits of two inventory targets (mid-point and band) as functions of the day and the
    price.

    With `degree` d (static), each logit is a polynomial of degree d in the standardised
    spot/forward log-ratio x = log(spot_t / F_t) / `spot_scale`, whose coefficients an MLP
    computes from the day's calendar features: the MLP runs on the T days only, and each path
    and day costs a polynomial (for a one-factor spot, the day and x are the whole price state).
    With `degree` None the MLP reads the calendar features, x and the standardised log spot
    of every path and day (general, and slower: docs/gas_storage.md).

    **Fields:** `mlp` (tanh); `warm_start`: per-day mid-point logits, shape (T,), not trained
    (the intrinsic LP's inventory path, so that the untrained policy follows the intrinsic
    schedule); `day_features`: what the contract offers each day beside the calendar, shape
    (T, K), not trained (`curve_features`; K = 0 reads the calendar alone); `spot_scale` (the
    factor's stationary standard deviation) and `mean_log_price`, not trained; `harmonics`,
    `degree` (static); `start_factor` (G,) and `start_table` (T, G, 2), not trained, or None:
    starting logits (mid-point, band) on levels of the factor x, interpolated linearly in x (flat
    beyond the ends) and added to the network's output in place of `warm_start` and the closed
    band (`_lattice_start.py`: the targets the factor lattice implies).
    """

    mlp: eqx.nn.MLP
    warm_start: jax.Array
    day_features: jax.Array
    spot_scale: jax.Array
    mean_log_price: jax.Array
    harmonics: int = eqx.field(static=True)
    degree: int | None = eqx.field(static=True)
    start_factor: jax.Array | None = None
    start_table: jax.Array | None = None

    def logits(self, calendar: jax.Array, log_curve: jax.Array, log_spot_ratio: jax.Array | None) -> jax.Array:
        """Target logits (mid-point, band), shape (paths, T, 2), or (T, 2) when `log_spot_ratio`
        (paths, T) is None; `calendar` (T, C), `log_curve` = log F_t (T,)."""
        calendar = jnp.concatenate([calendar, jax.lax.stop_gradient(self.day_features)], -1).astype(self.warm_start.dtype)
        if self.start_table is None or log_spot_ratio is None:
            start = jnp.stack([jax.lax.stop_gradient(self.warm_start), jnp.full_like(self.warm_start, BAND_INIT)], -1)
        else:
            start = self._table_start(log_spot_ratio)
        scale = jax.lax.stop_gradient(self.spot_scale)
        if self.degree is None:
            return start + self._mlp_on_paths(calendar, log_curve, log_spot_ratio, scale)
        coefficients = jax.vmap(self.mlp)(calendar).reshape(-1, 2, self.degree + 1)  # (T, 2, d + 1)
        if log_spot_ratio is None:
            return coefficients[:, :, 0] + start
        # Horner's rule, elementwise over (paths, T): faster than a batched contraction of the
        # powers with the coefficients, gradient included (docs/dev/gas_storage_notes.md, Measurements
        # behind the design).
        x = log_spot_ratio / scale
        logits = []
        for output in range(2):
            value = coefficients[:, output, self.degree]
            for power in range(self.degree - 1, -1, -1):
                value = value * x + coefficients[:, output, power]
            logits.append(value)
        return jnp.stack(logits, axis=-1) + start

    def _table_start(self, log_spot_ratio: jax.Array) -> jax.Array:
        """`start_table` at each path's and day's x, shape (paths, T, 2)."""
        factor, table = jax.lax.stop_gradient((self.start_factor, self.start_table))
        factor, table = factor.astype(log_spot_ratio.dtype), table.astype(log_spot_ratio.dtype)
        return jax.vmap(interpolate_factor, in_axes=(None, 0, 1), out_axes=1)(factor, table, log_spot_ratio)

    def _mlp_on_paths(self, calendar, log_curve, log_spot_ratio, scale):
        # The first layer's calendar part is computed once per day, not once per path and day.
        first, *hidden_layers, last = self.mlp.layers
        n_calendar = calendar.shape[-1]
        hidden = calendar @ first.weight[:, :n_calendar].T + first.bias
        if log_spot_ratio is not None:
            mean_log_price = jax.lax.stop_gradient(self.mean_log_price)
            features = jnp.stack([log_spot_ratio, log_curve + log_spot_ratio - mean_log_price], -1) / scale
            hidden = hidden + features @ first.weight[:, n_calendar:].T
        hidden = self.mlp.activation(hidden)
        for layer in hidden_layers:
            hidden = self.mlp.activation(hidden @ layer.weight.T + layer.bias)
        return hidden @ last.weight.T + last.bias


def _position_logits(inputs: StorageInputs, scene: Scene, target: np.ndarray) -> np.ndarray:
    """The logits z with `basestock_targets`' position(z) = `target` [MMBtu] for tomorrow's
    inventory, shape (T, ...): the inverse of its map, the target clipped to [floor, ceiling]."""
    floor, ceiling = (np.asarray(bound)[1:] for bound in inventory_bounds(inputs, scene, None))
    floor, ceiling = (np.reshape(bound, bound.shape + (1,) * (np.ndim(target) - 1)) for bound in (floor, ceiling))
    span = np.maximum(ceiling - floor, 1e-9 * float(inputs.capacity))
    position = np.clip((np.asarray(target) - floor) / span, 0.0, 1.0)
    scaled = (position + TARGET_OVERSHOOT) / (1 + 2 * TARGET_OVERSHOOT)
    return np.log(scaled / (1 - scaled))


def intrinsic_warm_start(inputs: StorageInputs, scene: Scene, intrinsic_inventory) -> jax.Array:
    """Logits of the target mid-point that reproduce the intrinsic inventory path V*_{t+1}, shape (T,)."""
    return jnp.asarray(_position_logits(inputs, scene, np.asarray(intrinsic_inventory)[1:]))


def target_logits(inputs: StorageInputs, scene: Scene, low: np.ndarray, high: np.ndarray):
    """`(mid, band)`: the logits that give the targets `low` <= `high` [MMBtu], each shape (T, ...)
    (the band at least softplus(BAND_INIT), as a closed band starts)."""
    low, high = _position_logits(inputs, scene, low), _position_logits(inputs, scene, high)
    band = np.maximum(high - low, float(jax.nn.softplus(BAND_INIT)))
    return (low + high) / 2, band + np.log(-np.expm1(-band))  # softplus^-1(band)


CURVE_FEATURES = 5


def curve_features(inputs: StorageInputs, intrinsic_inventory) -> jax.Array:
    """What the curve and the intrinsic schedule say of each day, shape (T, CURVE_FEATURES), each
    column standardised over the days: the price level F_t, the spreads to tomorrow and to the
    next week's mean, the spread from last week's mean (weekly shapes, holidays and spikes show in
    them), and the intrinsic schedule's net flow that day as a share of the largest flow. Fixed
    when the policy is made (a policy is a function of the contract it was trained on)."""
    curve = np.asarray(inputs.forward_curve, dtype=float)
    days = curve.size
    unit = np.mean(np.abs(curve))
    padded = np.concatenate([np.full(7, curve[0]), curve, np.full(7, curve[-1])])
    window = np.lib.stride_tricks.sliding_window_view(padded, 7)
    next_week, last_week = window[8:8 + days].mean(1), window[:days].mean(1)
    tomorrow = np.concatenate([curve[1:], curve[-1:]])
    flow = np.diff(np.asarray(intrinsic_inventory, dtype=float)) / max(float(inputs.max_injection),
                                                                      float(inputs.max_withdrawal))
    columns = np.stack([curve / unit, (tomorrow - curve) / unit, (next_week - curve) / unit, (curve - last_week) / unit,
                        flow], -1)
    spread = columns.std(0)
    return jnp.asarray((columns - columns.mean(0)) / np.where(spread > 1e-12, spread, 1.0))


def make_basestock_policy(scene: Scene, inputs: StorageInputs, *, key, width: int = 32, depth: int = 2,
                          spot_scale: float = 1.0, harmonics: int = BASESTOCK_HARMONICS,
                          degree: int | None = PRICE_DEGREE, intrinsic_inventory=None,
                          output_gain: float | None = None, read_curve: bool = True,
                          start: tuple[jax.Array, jax.Array] | None = None) -> BasestockPolicy:
    """A `BasestockPolicy`; with `intrinsic_inventory` (the LP's V_t, shape (T+1,)) it starts on
    the intrinsic schedule, else at mid-range, and with `read_curve` its network also reads
    `curve_features` (which need the intrinsic schedule); with `start` = (factor levels (G,),
    logits (T, G, 2)) on a random spot, it starts on those targets instead (`_lattice_start.py`).
    `spot_scale`: the factor's stationary standard deviation, the unit of x. In the deterministic
    scene the price polynomial has degree 0. `output_gain` scales the network's last layer at
    creation (default 0.1, or 0 with a `start`: a correction that starts at zero, so that the
    untrained policy is its start)."""
    day_features = (curve_features(inputs, intrinsic_inventory) if read_curve and intrinsic_inventory is not None
                    else jnp.zeros((inputs.n_days, 0)))
    n_calendar = 1 + 2 * harmonics + day_features.shape[1]
    stochastic = scene.has("stochastic_spot")
    start = start if stochastic else None  # a deterministic price has no factor to read a table at
    if degree is None:
        mlp = eqx.nn.MLP(n_calendar + (2 if stochastic else 0), 2, width, depth, activation=jnp.tanh, key=key)
    else:
        degree = degree if stochastic else 0
        mlp = eqx.nn.MLP(n_calendar, 2 * (degree + 1), width, depth, activation=jnp.tanh, key=key)
    # The last layer starts small (weights) and at zero (bias): the policy starts on the warm start.
    if output_gain is None:
        output_gain = 0.0 if start is not None else 0.1
    last = mlp.layers[-1]
    mlp = eqx.tree_at(lambda m: (m.layers[-1].weight, m.layers[-1].bias), mlp,
                      (last.weight * output_gain, jnp.zeros_like(last.bias)))
    warm = (jnp.zeros(inputs.n_days) if intrinsic_inventory is None
            else intrinsic_warm_start(inputs, scene, intrinsic_inventory))
    mean_log_price = jnp.mean(jnp.log(inputs.forward_curve))
    factor, table = (None, None) if start is None else start
    return BasestockPolicy(mlp, warm, day_features, jnp.asarray(spot_scale, dtype=float), mean_log_price, harmonics,
                           degree, factor, table)


def basestock_targets(policy: BasestockPolicy, inputs: StorageInputs, scene: Scene, log_spot_ratio,
                      sharpness: float | None, floor: jax.Array | None = None, ceiling: jax.Array | None = None):
    """The targets b_L, b_U [MMBtu] for tomorrow's inventory, each shape (paths, T), or (T,)
    when `log_spot_ratio` (the factor, shape (paths, T)) is None. `floor`, `ceiling`:
    `inventory_floor` and `inventory_ceiling` when the caller has them (their backward recursions
    then run once per simulation)."""
    if floor is None or ceiling is None:
        floor, ceiling = inventory_bounds(inputs, scene, sharpness)
    calendar = calendar_features(inputs.n_days, policy.harmonics)
    return targets_of_logits(policy.logits(calendar, jnp.log(inputs.forward_curve), log_spot_ratio), floor, ceiling)


def targets_of_logits(logits: jax.Array, floor: jax.Array, ceiling: jax.Array) -> tuple[jax.Array, jax.Array]:
    """b_L, b_U [MMBtu] of target logits (mid-point, band) of shape (..., T, 2), between
    tomorrow's floor and ceiling (`floor`, `ceiling`: shape (T+1,), as `inventory_bounds`)."""
    floor, ceiling = floor[1:], ceiling[1:]
    mid, band = logits[..., 0], jax.nn.softplus(logits[..., 1])
    span = (ceiling - floor) * (1 + 2 * TARGET_OVERSHOOT)
    position = lambda z: floor - TARGET_OVERSHOOT * (ceiling - floor) + span * jax.nn.sigmoid(z)  # noqa: E731
    return position(mid - band / 2), position(mid + band / 2)


def simulate_basestock(policy: BasestockPolicy, inputs: StorageInputs, scene: Scene, *, sharpness: float | None,
                       shocks: jax.Array | None = None) -> Schedule:
    """Simulate the basestock policy on the forward curve (deterministic scene) or on the spot
    paths of `shocks` (paths, T), as `simulate`. The hard simulation (`sharpness=None`) is
    continuous in the targets, the prices and the facility's parameters, so its pathwise
    gradient is informative, unlike that of a bang-bang rule."""
    stochastic = scene.has("stochastic_spot")
    floor, ceiling = inventory_bounds(inputs, scene, sharpness)
    if stochastic:
        if shocks is None:
            raise ValueError("the stochastic_spot effect needs shocks of shape (paths, T)")
        prices, factor = spot_prices(inputs, shocks)
        low, high = basestock_targets(policy, inputs, scene, factor, sharpness, floor, ceiling)
        low_t, high_t = low.T, high.T
        start = jnp.broadcast_to(inputs.initial_inventory, prices.shape[:1])
    else:
        low, high = basestock_targets(policy, inputs, scene, None, sharpness, floor, ceiling)
        prices, low_t, high_t = inputs.forward_curve, low, high
        start = inputs.initial_inventory
    return follow_targets(inputs, scene, low_t, high_t, prices, start, floor, sharpness)


def follow_targets(inputs: StorageInputs, scene: Scene, low_t, high_t, prices, start, floor,
                   sharpness: float | None) -> Schedule:
    """Move the inventory from `start` (paths,) or () towards the targets `low_t`, `high_t`
    (day-major: (T, paths) or (T,)) at the largest feasible rate each day, and trade at `prices`
    ((paths, T) or (T,)); `floor`: `inventory_floor` (T+1,)."""
    flow_k = flow_sharpness(inputs, sharpness)

    def step(day, inventory, _, today):
        low, high, floor_tomorrow = today
        max_out, lower, upper = feasible_flows(inputs, scene, inventory, floor_tomorrow, sharpness)
        request = (smooth.clip(low - inventory, 0.0, upper, flow_k)
                   - smooth.clip(inventory - high, 0.0, max_out, flow_k))
        return inventory + smooth.clip(request, lower, upper, flow_k)

    # Only the inventory is carried through the loop; the flows and cash follow from its daily
    # changes in one vectorised pass (the net flow is exactly the change, smooth or hard). Each
    # path's inventory depends on its own alone, so on few paths the reverse pass is the closed
    # form of `rollout(elementwise=True)`; on many, the scan's own, recomputing each day rather
    # than storing it (docs/dev/gas_storage_notes.md, Measurements behind the design).
    elementwise = start.size <= ELEMENTWISE_PATHS
    inventory = jnp.moveaxis(rollout(step, start, inputs.n_days, per_step=(low_t, high_t, floor[1:]),
                                     elementwise=elementwise, remat=not elementwise), 0, -1)
    net = jnp.diff(inventory, axis=-1)
    injection, withdrawal, cash = flows_and_cash(inputs, scene, net, prices, jnp.arange(inputs.n_days), sharpness)
    return Schedule(jnp.sum(cash, axis=-1), injection, withdrawal, inventory)
