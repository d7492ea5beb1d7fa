"""Neural policies: a multilayer perceptron from normalised features to bounded actions."""

import io
import json
import os

import equinox as eqx
import jax
import jax.numpy as jnp

from ._platform.files import atomic_write_bytes
from ._platform.validation import InputError


class MLPPolicy(eqx.Module):
    """An MLP policy: `action = low + (high - low) * sigmoid(mlp((features - offset) / scale))`,
    or the raw MLP output when no bounds are given.

    **Arguments:**
    - `in_features`, `out_features`: sizes of the feature and action vectors.
    - `key`: a `jax.random.key`; the same key gives the same initial weights.
    - `width`, `depth`: hidden width and number of hidden layers (tanh activations).
    - `feature_offset`, `feature_scale`: shape (in_features,); features are normalised as
      (features - offset) / scale before the MLP (defaults 0 and 1). Not trained.
    - `action_low`, `action_high`: shape (out_features,) or scalars; both or neither.
    - `output_gain`: the last layer's initial weights are scaled by this, so that a new policy
      starts near the middle of its action range rather than saturated.
    """

    mlp: eqx.nn.MLP
    feature_offset: jax.Array
    feature_scale: jax.Array
    action_low: jax.Array | None
    action_high: jax.Array | None
    config: dict = eqx.field(static=True)

    def __init__(
        self,
        in_features: int,
        out_features: int,
        *,
        key,
        width: int = 32,
        depth: int = 2,
        feature_offset=None,
        feature_scale=None,
        action_low=None,
        action_high=None,
        output_gain: float = 0.1,
    ):
        if (action_low is None) != (action_high is None):
            raise InputError("action_low and action_high must be given together (or neither).")
        for name, value in (("in_features", in_features), ("out_features", out_features),
                            ("width", width), ("depth", depth)):
            if not isinstance(value, int) or value < (0 if name == "depth" else 1):
                raise InputError(f"{name} = {value!r} must be a positive integer.")
        mlp = eqx.nn.MLP(in_features, out_features, width, depth, activation=jnp.tanh, key=key)
        last = mlp.layers[-1]
        self.mlp = eqx.tree_at(lambda m: m.layers[-1].weight, mlp, last.weight * output_gain)
        self.feature_offset = jnp.zeros(in_features) if feature_offset is None else jnp.asarray(
            feature_offset, dtype=float) * jnp.ones(in_features)
        self.feature_scale = jnp.ones(in_features) if feature_scale is None else jnp.asarray(
            feature_scale, dtype=float) * jnp.ones(in_features)
        if action_low is None:
            self.action_low = self.action_high = None
        else:
            self.action_low = jnp.asarray(action_low, dtype=float) * jnp.ones(out_features)
            self.action_high = jnp.asarray(action_high, dtype=float) * jnp.ones(out_features)
        self.config = dict(in_features=in_features, out_features=out_features, width=width,
                           depth=depth, bounded=action_low is not None)

    def __call__(self, features: jax.Array) -> jax.Array:
        """Actions for one feature vector, shape (in_features,) -> (out_features,)."""
        offset = jax.lax.stop_gradient(self.feature_offset)
        scale = jax.lax.stop_gradient(self.feature_scale)
        raw = self.mlp((features - offset) / scale)
        if self.action_low is None:
            return raw
        low = jax.lax.stop_gradient(self.action_low)
        high = jax.lax.stop_gradient(self.action_high)
        return low + (high - low) * jax.nn.sigmoid(raw)


def policy_bytes(policy: MLPPolicy) -> bytes:
    """A policy as bytes: a JSON header with its shape, then equinox-serialised leaves (what
    `save_policy` writes and `load_policy` reads)."""
    buffer = io.BytesIO()
    eqx.tree_serialise_leaves(buffer, policy)
    return json.dumps(policy.config).encode() + b"\n" + buffer.getvalue()


def save_policy(path: str | os.PathLike, policy: MLPPolicy) -> None:
    """Save a policy atomically (`policy_bytes`)."""
    atomic_write_bytes(path, policy_bytes(policy))


def load_policy(path: str | os.PathLike) -> MLPPolicy:
    """Load a policy written by `save_policy`."""
    with open(path, "rb") as handle:
        config = json.loads(handle.readline())
        bounds = {}
        if config.pop("bounded"):
            bounds = dict(action_low=0.0, action_high=1.0)
        like = MLPPolicy(**config, key=jax.random.key(0), **bounds)
        return eqx.tree_deserialise_leaves(handle, like)
