"""Rebalancing policies: features of the fund's state -> portfolio weights over the market's
asset classes (`Market.asset_classes`).

`NeuralRebalancing` maps an MLP's logits to weights inside per-asset bounds that sum to 1;
`FixedMix` holds constant weights (the 60/40 and liability-matching baselines).
"""

import abc

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np

from snapo_ode import InputError, MLPPolicy, check_range

from ._market import Market, default_asset_classes

FEATURES = ("time", "funding_ratio", "short_rate", "long_rate", "inflation", "spread")
FEATURE_OFFSET = (0.5, 1.0, 0.03, 0.04, 0.02, 0.012)
FEATURE_SCALE = (0.3, 0.2, 0.02, 0.02, 0.01, 0.005)
BISECTION_STEPS = 40


def bounded_weights(logits, low, high):
    """Weights `low + (high - low) * sigmoid(logits + shift)` with the shift that makes them sum
    to 1: smooth in the logits, exactly inside [low, high] and on the simplex.

    **Arguments:** `logits` shape (..., n_assets); `low`, `high` shape (n_assets,) with
    sum(low) < 1 < sum(high).

    The shift is found without gradient (bisection, then two Newton steps to round-off), and a
    last Newton step from that stopped value carries the implicit-function derivative
    d shift / d logits = -(dF/dlogits) / (dF/dshift), so gradients are exact.
    """
    low = jnp.asarray(low)
    span = jnp.asarray(high) - low
    budget = 1.0 - jnp.sum(low)

    def excess_and_slope(z, shift):
        level = jax.nn.sigmoid(z + shift[..., None])
        return (jnp.sum(span * level, -1) - budget,
                jnp.sum(span * level * (1.0 - level), -1))

    frozen = jax.lax.stop_gradient(logits)

    def bisect(_, bracket):
        below, above = bracket
        middle = 0.5 * (below + above)
        too_much = excess_and_slope(frozen, middle)[0] > 0
        return jnp.where(too_much, below, middle), jnp.where(too_much, middle, above)

    below, above = jax.lax.fori_loop(
        0, BISECTION_STEPS, bisect, (-jnp.max(frozen, -1) - 40.0, -jnp.min(frozen, -1) + 40.0))
    shift = 0.5 * (below + above)
    for _ in range(2):
        excess, slope = excess_and_slope(frozen, shift)
        shift = shift - excess / slope
    shift = jax.lax.stop_gradient(shift)
    excess, slope = excess_and_slope(logits, shift)
    shift = shift - excess / jax.lax.stop_gradient(slope)
    return low + span * jax.nn.sigmoid(logits + shift[..., None])


class AbstractRebalancing(eqx.Module):
    """A rebalancing policy: features, shape (paths, len(FEATURES)), in the order of `FEATURES`
    -> target weights, shape (paths, asset classes), summing to 1."""

    @abc.abstractmethod
    def __call__(self, features: jax.Array) -> jax.Array:
        raise NotImplementedError


class NeuralRebalancing(AbstractRebalancing):
    """An `MLPPolicy` from the normalised features to logits, then `bounded_weights`.

    **Arguments:** `market` (its weight bounds are used); `key`; `width`, `depth` of the MLP.
    """

    network: MLPPolicy
    weight_low: tuple[float, ...] = eqx.field(static=True)
    weight_high: tuple[float, ...] = eqx.field(static=True)

    def __init__(self, market: Market, *, key, width: int = 32, depth: int = 2):
        self.network = MLPPolicy(len(FEATURES), len(market.asset_classes), key=key, width=width, depth=depth,
                                 feature_offset=FEATURE_OFFSET, feature_scale=FEATURE_SCALE)
        self.weight_low = market.weight_low
        self.weight_high = market.weight_high

    def __call__(self, features):
        return bounded_weights(jax.vmap(self.network)(features), self.weight_low, self.weight_high)


class FixedMix(AbstractRebalancing):
    """Constant target weights, rebalanced to every month.

    **Arguments:** `weights`, one per asset class, non-negative, summing to 1.
    """

    weights: jax.Array

    def __init__(self, weights):
        weights = check_range("weights", weights, 0.0, 1.0)
        if weights.ndim != 1 or abs(weights.sum() - 1.0) > 1e-12:
            raise InputError(f"weights = {weights} must have one entry per asset class and sum to 1.")
        self.weights = jnp.asarray(weights)

    def __call__(self, features):
        return jnp.broadcast_to(self.weights, (features.shape[0], self.weights.size))


def _bonds_for_matching(classes) -> list[int]:
    """The classes a fixed mix holds as bonds: the nominal ones, or without any, every bond class."""
    nominal = [k for k, c in enumerate(classes) if c.kind == "nominal"]
    return nominal or [k for k, c in enumerate(classes) if c.maturity is not None]


def sixty_forty(market: Market | None = None) -> FixedMix:
    """60% equities, 40% split equally over the nominal classes (the built-in fund's, without a
    `market`: half short, half long; cash where a market has no bond class)."""
    classes = default_asset_classes() if market is None else market.asset_classes
    weights = np.zeros(len(classes))
    weights[-1] = 0.6
    bonds = _bonds_for_matching(classes) or [0]
    weights[bonds] += 0.4 / len(bonds)
    return FixedMix(weights)


def liability_matching(market: Market, liability_duration: float) -> FixedMix:
    """80% in the shortest and longest nominal classes mixed so that their duration equals
    `liability_duration` [years] (clipped to their range; cash without a bond class), 20%
    equities."""
    classes = market.asset_classes
    bonds = _bonds_for_matching(classes)
    weights = np.zeros(len(classes))
    weights[-1] = 0.2
    if not bonds:
        weights[0] += 0.8
        return FixedMix(weights)
    maturities = [classes[k].maturity for k in bonds]
    low, high = bonds[int(np.argmin(maturities))], bonds[int(np.argmax(maturities))]
    short, long = min(maturities), max(maturities)
    share_long = float(np.clip((liability_duration - short) / (long - short), 0.0, 1.0)) if long > short else 1.0
    weights[low] += 0.8 * (1 - share_long)
    weights[high] += 0.8 * share_long
    return FixedMix(weights)
