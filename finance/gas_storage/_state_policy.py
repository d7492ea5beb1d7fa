"""The SNAPO policy on any price model: a basestock policy (`_basestock.py`) whose targets read the
model's state, started where no lattice exists: on the basestock targets of the state LSMC's
value function (`StateLSMCFit`).

Start. On day t, path p, the LSMC's continuation C_t(y; state) on the inventory levels gives,
as the factor lattice does for one factor (`_lattice_start.py`), the best place to inject up to
and to withdraw down to,

    b_L = argmax_y [C_t(y) - p_in y],   b_U = argmax_{y >= b_L} [C_t(y) - p_out y]

(p_in, p_out: today's discounted cash per unit injected or withdrawn at the path's spot; y over
the levels between tomorrow's floor and ceiling and those ends). These targets reproduce the
LSMC rule wherever its continuation is concave in y. They are data (piecewise constant in the
state: no gradient) computed for every path the policy sees.

Correction. A network of the calendar gives, per day, the coefficients of a polynomial of
degree `degree` in the standardised state for the two target logits (mid-point, band), added to
the start's logits; its last layer starts at zero, so the untrained policy is the start, and the
adjoint trains the correction on the exact model's simulator (ratchets, fuel, costs,
discounting), smooth, as the one-factor basestock head is trained.
"""

import io
import json
import os

import equinox as eqx
import jax
import jax.numpy as jnp

from snapo_ode import Scene

from ._basestock import BAND_INIT, TARGET_OVERSHOOT, follow_targets, inventory_bounds, targets_of_logits
from ._inputs import StorageInputs
from ._lsmc import InventoryGrid, interpolate_levels
from ._model import Schedule, calendar_features, flows_and_cash, spot_prices
from ._paths import PricePaths
from ._state_lsmc import StateBasis, StateLSMCFit, state_basis

STATE_HARMONICS = 4


def _logits_of_targets(low, high, floor, ceiling):
    """(mid, band) logits whose `targets_of_logits` are `low` <= `high` [MMBtu] (the inverse map,
    targets clipped to [floor, ceiling]; the band at least softplus(BAND_INIT))."""
    span = jnp.maximum(ceiling - floor, 1e-9 * jnp.max(ceiling))

    def logit(target):
        position = jnp.clip((target - floor) / span, 0.0, 1.0)
        scaled = (position + TARGET_OVERSHOOT) / (1 + 2 * TARGET_OVERSHOOT)
        return jnp.log(scaled / (1 - scaled))

    low, high = logit(low), logit(high)
    band = jnp.maximum(high - low, jax.nn.softplus(BAND_INIT))
    return jnp.stack([(low + high) / 2, band + jnp.log(-jnp.expm1(-band))], axis=-1)


def lsmc_start_logits(fit: StateLSMCFit, inputs: StorageInputs, scene: Scene, levels: jax.Array, spacing: float,
                      paths: PricePaths) -> jax.Array:
    """The start's target logits (mid-point, band) of every path and day, shape (paths, T, 2)
    (module docstring), without gradient; `levels` (N,) [MMBtu], `spacing` D: the LSMC's grid."""
    fit, inputs, paths, levels = jax.lax.stop_gradient((fit, inputs, paths, levels))
    floor, ceiling = (bound[1:] for bound in inventory_bounds(inputs, scene, None))
    prices = spot_prices(inputs, paths)[0]
    regressors = fit.basis(paths.state())
    step = jnp.asarray(spacing)

    def day_targets(today):
        day, price, basis, coefficients, floor_t, ceiling_t = today
        positions = jnp.clip(levels, floor_t, ceiling_t)
        # Interpolated in the coefficients (B, N), linear in them: a gather of B rows, not of every path's
        # (faster, same values: docs/dev/gas_storage_notes.md, Measurements behind the design).
        value = basis @ interpolate_levels(coefficients, positions, spacing)  # (paths, N)
        cash = flows_and_cash(inputs, scene, jnp.stack([step, -step]), price[:, None], day, None)[2] / step
        low = positions[jnp.argmax(value + cash[:, :1] * positions, axis=-1)]
        above = positions >= low[:, None]
        high = positions[jnp.argmax(jnp.where(above, value - cash[:, 1:] * positions, -jnp.inf), axis=-1)]
        return _logits_of_targets(low, high, floor_t, ceiling_t)

    logits = jax.lax.map(day_targets, (jnp.arange(inputs.n_days), prices.T, jnp.swapaxes(regressors, 0, 1),
                                       fit.coefficients, floor, ceiling))
    return jnp.swapaxes(logits, 0, 1)


class StatePolicy(eqx.Module):
    """**Fields:** `mlp` (calendar -> per-day coefficients, tanh); `basis`: the state polynomial
    of the correction; `fit`, `levels` (N,) and `spacing` (static): the LSMC and its grid, which
    the policy starts on; `harmonics` (static)."""

    mlp: eqx.nn.MLP
    basis: StateBasis
    fit: StateLSMCFit
    levels: jax.Array
    spacing: float = eqx.field(static=True)
    harmonics: int = eqx.field(static=True, default=STATE_HARMONICS)

    def start_logits(self, inputs: StorageInputs, scene: Scene, paths: PricePaths) -> jax.Array:
        """The start's logits on `paths`, shape (paths, T, 2) (`lsmc_start_logits`)."""
        return lsmc_start_logits(self.fit, inputs, scene, self.levels, self.spacing, paths)

    def logits(self, inputs: StorageInputs, scene: Scene, paths: PricePaths, start=None) -> jax.Array:
        """Target logits (mid-point, band), shape (paths, T, 2): the LSMC start (`start`, where the
        caller computed it once for these paths) plus the correction."""
        start = self.start_logits(inputs, scene, paths) if start is None else jax.lax.stop_gradient(start)
        basis = jax.lax.stop_gradient(self.basis)(jax.lax.stop_gradient(paths.state()))  # (paths, T, B)
        calendar = calendar_features(inputs.n_days, self.harmonics).astype(basis.dtype)
        coefficients = jax.vmap(self.mlp)(calendar).reshape(inputs.n_days, 2, -1)  # (T, 2, B)
        return start + jnp.einsum("ptb,tob->pto", basis, coefficients)


def make_state_policy(fit: StateLSMCFit, grid: InventoryGrid, paths: PricePaths, *, key, degree: int = 1,
                      width: int = 32, depth: int = 2) -> StatePolicy:
    """A `StatePolicy` started on the LSMC `fit`; the correction's state basis is standardised on
    `paths` (the training paths)."""
    basis = state_basis(paths, degree)
    calendar = 1 + 2 * STATE_HARMONICS
    mlp = eqx.nn.MLP(calendar, 2 * len(basis.exponents), width, depth, activation=jnp.tanh, key=key)
    last = mlp.layers[-1]
    mlp = eqx.tree_at(lambda m: (m.layers[-1].weight, m.layers[-1].bias), mlp,
                      (jnp.zeros_like(last.weight), jnp.zeros_like(last.bias)))
    return StatePolicy(mlp, basis, fit, jnp.asarray(grid.levels), float(grid.spacing))


def simulate_state_policy(policy: StatePolicy, inputs: StorageInputs, scene: Scene, paths: PricePaths, *,
                          sharpness: float | None, start=None) -> Schedule:
    """The policy on `paths`, smooth (`sharpness`) or hard (None), as `simulate` does; `start`:
    `policy.start_logits` on these paths where already computed (they depend on the paths alone)."""
    floor, ceiling = inventory_bounds(inputs, scene, sharpness)
    low, high = targets_of_logits(policy.logits(inputs, scene, paths, start), floor, ceiling)
    prices = spot_prices(inputs, paths)[0]
    start = jnp.broadcast_to(inputs.initial_inventory, prices.shape[:1])
    return follow_targets(inputs, scene, low.T, high.T, prices, start, floor, sharpness)


def _basis_header(basis: StateBasis) -> dict:
    return {"shape": list(basis.mean.shape), "exponents": [list(e) for e in basis.exponents]}


def _basis_like(header: dict) -> StateBasis:
    return StateBasis(jnp.zeros(header["shape"]), jnp.zeros(header["shape"]), tuple(map(tuple, header["exponents"])))


def state_policy_bytes(policy: StatePolicy) -> bytes:
    """A trained `StatePolicy` as bytes (read back with `load_storage_policy`): a JSON header
    with its shapes, then the equinox-serialised leaves (the LSMC it starts on included)."""
    mlp, fit = policy.mlp, policy.fit
    header = {"head": "state", "in_size": mlp.in_size, "out_size": mlp.out_size, "width": mlp.width_size,
              "depth": mlp.depth, "harmonics": policy.harmonics, "spacing": policy.spacing,
              "levels": int(policy.levels.shape[0]), "basis": _basis_header(policy.basis),
              "fit_basis": _basis_header(fit.basis), "coefficients": list(fit.coefficients.shape),
              "fit_paths": int(fit.values.shape[0])}
    buffer = io.BytesIO()
    eqx.tree_serialise_leaves(buffer, policy)
    return json.dumps(header).encode() + b"\n" + buffer.getvalue()


def load_state_policy(path: str | os.PathLike) -> StatePolicy:
    """Load a policy written by `state_policy_bytes` (`snapo gas --price-model`'s `OUT.policy.eqx`)."""
    with open(path, "rb") as handle:
        header = json.loads(handle.readline())
        mlp = eqx.nn.MLP(header["in_size"], header["out_size"], header["width"], header["depth"],
                         activation=jnp.tanh, key=jax.random.key(0))
        fit = StateLSMCFit(jnp.zeros(header["coefficients"]), _basis_like(header["fit_basis"]),
                           jnp.zeros(header["fit_paths"]))
        like = StatePolicy(mlp, _basis_like(header["basis"]), fit, jnp.zeros(header["levels"]), header["spacing"],
                           header["harmonics"])
        return eqx.tree_deserialise_leaves(handle, like)
