"""Pick a policy head, simulate any head, and write a trained policy to bytes and back.

Heads: `"basestock"` (two inventory targets, `_basestock.py`), `"fraction"` and `"split"` (an
action per day, `_action_heads.py`). The study's default is the basestock head (`DEFAULT_HEAD`):
on the Boogert & de Jong contract it values above least-squares Monte Carlo and trains in under
a minute, and on the deterministic sample it reaches the intrinsic LP (docs/gas_storage.md,
"Policy heads").
"""

import io
import json
import os
from typing import Literal

import equinox as eqx
import jax
import jax.numpy as jnp

from snapo_ode import MLPPolicy, Scene, check_choice, load_policy, policy_bytes

from ._action_heads import make_action_policy, simulate_actions
from ._basestock import BasestockPolicy, make_basestock_policy, simulate_basestock
from ._inputs import StorageInputs
from ._model import Schedule

PolicyHead = Literal["basestock", "fraction", "split"]
POLICY_HEADS = ("basestock", "fraction", "split")
DEFAULT_HEAD: PolicyHead = "basestock"


def make_policy(scene: Scene, inputs: StorageInputs, *, key, width: int = 32, depth: int = 2,
                spot_scale: float = 1.0, head: PolicyHead = "fraction", split_actions: bool = False,
                intrinsic_inventory=None, start=None):
    """A policy of the given `head` (`split_actions=True` is `head="split"`). `spot_scale`: the
    spot factor's stationary standard deviation, the unit of the price features (stochastic
    scene). `intrinsic_inventory` (the LP's V_t, shape (T+1,)): the basestock head starts on
    the intrinsic schedule."""
    head = "split" if split_actions else head
    check_choice("head", head, POLICY_HEADS)
    if head == "basestock":
        return make_basestock_policy(scene, inputs, key=key, width=width, depth=depth, spot_scale=spot_scale,
                                     intrinsic_inventory=intrinsic_inventory, start=start)
    return make_action_policy(scene, inputs, key=key, width=width, depth=depth, spot_scale=spot_scale,
                              split=head == "split")


def simulate(policy, inputs: StorageInputs, scene: Scene, *, sharpness: float | None,
             shocks: jax.Array | None = None) -> Schedule:
    """Simulate a policy of any head: on the forward curve (deterministic scene; `shocks` None),
    or on Monte Carlo spot paths spot_t = F_t exp(X_t - Var(X_t)/2) with `shocks` of shape
    (paths, T), common to every call that passes the same array."""
    if scene.has("stochastic_spot") and shocks is None:
        raise ValueError("the stochastic_spot effect needs shocks of shape (paths, T)")
    if isinstance(policy, BasestockPolicy):
        return simulate_basestock(policy, inputs, scene, sharpness=sharpness, shocks=shocks)
    return simulate_actions(policy, inputs, scene, sharpness=sharpness, shocks=shocks)


def expected_value(policy, inputs: StorageInputs, scene: Scene, *, sharpness: float | None,
                   shocks: jax.Array | None = None) -> jax.Array:
    """The value [$]: deterministic, or the Monte Carlo mean over the shock paths."""
    return jnp.mean(simulate(policy, inputs, scene, sharpness=sharpness, shocks=shocks).value)


def storage_policy_bytes(policy) -> bytes:
    """A trained policy of any head as bytes (read back with `load_storage_policy`): an action
    policy as `snapo_ode.policy_bytes` writes it; a basestock policy as a JSON header with its
    shape, then equinox-serialised leaves."""
    if isinstance(policy, MLPPolicy):
        return policy_bytes(policy)
    mlp = policy.mlp
    header = {"head": "basestock", "in_size": mlp.in_size, "out_size": mlp.out_size, "width": mlp.width_size,
              "depth": mlp.depth, "n_days": int(policy.warm_start.shape[0]), "harmonics": policy.harmonics,
              "day_features": int(policy.day_features.shape[1]),
              "degree": policy.degree,
              "start_levels": 0 if policy.start_factor is None else int(policy.start_factor.shape[0])}
    buffer = io.BytesIO()
    eqx.tree_serialise_leaves(buffer, policy)
    return json.dumps(header).encode() + b"\n" + buffer.getvalue()


def load_storage_policy(path: str | os.PathLike):
    """Load a policy written by `snapo gas` (`OUT.policy.eqx`), of any head, or by `snapo gas
    --price-model` (a `StatePolicy`)."""
    with open(path, "rb") as handle:
        header = json.loads(handle.readline())
    if header.get("head") == "state":
        from ._state_policy import load_state_policy

        return load_state_policy(path)
    if header.get("head") != "basestock":
        return load_policy(path)
    mlp = eqx.nn.MLP(header["in_size"], header["out_size"], header["width"], header["depth"], activation=jnp.tanh,
                     key=jax.random.key(0))
    days, levels = header["n_days"], header.get("start_levels", 0)
    start = (jnp.zeros(levels), jnp.zeros((days, levels, 2))) if levels else (None, None)
    like = BasestockPolicy(mlp, jnp.zeros(days), jnp.zeros((days, header.get("day_features", 0))),
                           jnp.zeros(()), jnp.zeros(()), header["harmonics"], header["degree"], *start)
    with open(path, "rb") as handle:
        handle.readline()
        return eqx.tree_deserialise_leaves(handle, like)
