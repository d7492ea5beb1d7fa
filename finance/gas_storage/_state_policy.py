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
from ._lsmc import InventoryGrid, continuation_targets, interpolate_levels
from ._model import Schedule, calendar_features, spot_prices
from ._model_lattice import ModelLattice, interpolate_grid, lattice_coordinates
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

    def day_targets(today):
        day, price, basis, coefficients, floor_t, ceiling_t = today
        positions = jnp.clip(levels, floor_t, ceiling_t)
        # Interpolated in the coefficients (B, N), linear in them: a gather of B rows, not of every path's
        # (faster, same values: docs/dev/gas_storage_notes.md, Measurements behind the design).
        value = basis @ interpolate_levels(coefficients, positions, spacing)  # (paths, N)
        low, high = continuation_targets(inputs, scene, value, positions, price, day, spacing)
        return _logits_of_targets(low, high, floor_t, ceiling_t)

    logits = jax.lax.map(day_targets, (jnp.arange(inputs.n_days), prices.T, jnp.swapaxes(regressors, 0, 1),
                                       fit.coefficients, floor, ceiling))
    return jnp.swapaxes(logits, 0, 1)


def lattice_start_logits(lattice: ModelLattice, inputs: StorageInputs, scene: Scene, paths: PricePaths) -> jax.Array:
    """The start's target logits on `paths` (with the model's factors) from a `ModelLattice`'s
    targets, interpolated multilinearly at each path's z = U^-1 X: shape (paths, T, 2), no gradient."""
    lattice, inputs, factors = jax.lax.stop_gradient((lattice, inputs, paths.factors))
    floor, ceiling = (bound[1:] for bound in inventory_bounds(inputs, scene, None))
    z = jnp.swapaxes(lattice_coordinates(lattice.unit, factors), 0, 1)  # (T, paths, k)

    def day_logits(low, high, z_t, floor_t, ceiling_t):
        return _logits_of_targets(interpolate_grid(lattice.axes, low, z_t), interpolate_grid(lattice.axes, high, z_t),
                                  floor_t, ceiling_t)

    return jnp.swapaxes(jax.vmap(day_logits)(lattice.low, lattice.high, z, floor, ceiling), 0, 1)


class StatePolicy(eqx.Module):
    """**Fields:** `mlp` (calendar -> per-day coefficients, tanh); `basis`: the state polynomial
    of the correction; `fit`, `levels` (N,) and `spacing` (static): the LSMC and its grid;
    `harmonics` (static); `lattice`: the `ModelLattice` the policy starts on, or None: it starts
    on the LSMC."""

    mlp: eqx.nn.MLP
    basis: StateBasis
    fit: StateLSMCFit
    levels: jax.Array
    spacing: float = eqx.field(static=True)
    harmonics: int = eqx.field(static=True, default=STATE_HARMONICS)
    lattice: ModelLattice | None = None

    def start_logits(self, inputs: StorageInputs, scene: Scene, paths: PricePaths) -> jax.Array:
        """The start's logits on `paths`, shape (paths, T, 2) (`lattice_start_logits` or
        `lsmc_start_logits`)."""
        if self.lattice is not None:
            return lattice_start_logits(self.lattice, inputs, scene, paths)
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
                      width: int = 32, depth: int = 2, lattice: ModelLattice | None = None) -> StatePolicy:
    """A `StatePolicy` started on `lattice`'s targets, or where None on the LSMC `fit`'s; the
    correction's state basis is standardised on `paths` (the training paths)."""
    basis = state_basis(paths, degree)
    calendar = 1 + 2 * STATE_HARMONICS
    mlp = eqx.nn.MLP(calendar, 2 * len(basis.exponents), width, depth, activation=jnp.tanh, key=key)
    last = mlp.layers[-1]
    mlp = eqx.tree_at(lambda m: (m.layers[-1].weight, m.layers[-1].bias), mlp,
                      (jnp.zeros_like(last.weight), jnp.zeros_like(last.bias)))
    return StatePolicy(mlp, basis, fit, jnp.asarray(grid.levels), float(grid.spacing), lattice=lattice)


def simulate_state_policy(policy: StatePolicy, inputs: StorageInputs, scene: Scene, paths: PricePaths, *,
                          sharpness: float | None, start=None) -> Schedule:
    """The policy on `paths`, smooth (`sharpness`) or hard (None), as `simulate` does; `start`:
    `policy.start_logits` on these paths where already computed (they depend on the paths alone)."""
    floor, ceiling = inventory_bounds(inputs, scene, sharpness)
    low, high = targets_of_logits(policy.logits(inputs, scene, paths, start), floor, ceiling)
    prices = spot_prices(inputs, paths)[0]
    start = jnp.broadcast_to(inputs.initial_inventory, prices.shape[:1])
    return follow_targets(inputs, scene, low.T, high.T, prices, start, floor, sharpness)


def chosen_start(lattice: ModelLattice | None, fit: StateLSMCFit, inputs: StorageInputs, scene: Scene,
                 grid: InventoryGrid, training: PricePaths, seed: int):
    """The untrained `StatePolicy` on the LSMC `fit`'s targets or, where the factor `lattice` is
    given (None where unaffordable: `lattice_points`), on the lattice's: whichever values more,
    hard, on the `training` paths (the evaluation paths are not seen; without a lattice neither
    start is valued). Returns the policy, its start's logits on the training paths and the JSON
    fields of the choice."""
    key = jax.random.key(seed)
    # The paths are arguments of the compiled programs, not constants baked into them (`snapo_ode.train`'s `data`).
    start_logits = eqx.filter_jit(lambda policy, paths: policy.start_logits(inputs, scene, paths))
    in_sample = eqx.filter_jit(lambda policy, paths, start: jnp.mean(
        simulate_state_policy(policy, inputs, scene, paths, sharpness=None, start=start).value))
    policy = make_state_policy(fit, grid, training, key=key)
    logits = start_logits(policy, training)
    fields = {"snapo_start": "lsmc", "lsmc_start_in_sample": None, "lattice_start_in_sample": None,
              "lattice_value": None}
    if lattice is None:  # no choice to make: nothing valued
        return policy, logits, fields
    fields["lsmc_start_in_sample"] = float(in_sample(policy, training, logits))
    on_lattice = make_state_policy(fit, grid, training, key=key, lattice=lattice)
    lattice_logits = start_logits(on_lattice, training)
    fields.update(lattice_start_in_sample=float(in_sample(on_lattice, training, lattice_logits)),
                  lattice_value=float(lattice.value))
    if fields["lattice_start_in_sample"] > fields["lsmc_start_in_sample"]:
        return on_lattice, lattice_logits, dict(fields, snapo_start="lattice")
    return policy, logits, fields


def _basis_header(basis: StateBasis) -> dict:
    return {"shape": list(basis.mean.shape), "exponents": [list(e) for e in basis.exponents]}


def _basis_like(header: dict) -> StateBasis:
    return StateBasis(jnp.zeros(header["shape"]), jnp.zeros(header["shape"]), tuple(map(tuple, header["exponents"])))


def _lattice_like(shape: list[int] | None) -> ModelLattice | None:
    """A `ModelLattice` of zeros whose targets have `shape` (T, G, ..., G), or None."""
    if shape is None:
        return None
    k, points = len(shape) - 1, shape[-1]
    return ModelLattice(jnp.zeros((k, k)), jnp.zeros((k, points)), jnp.zeros(shape), jnp.zeros(shape), jnp.zeros(()))


def state_policy_bytes(policy: StatePolicy) -> bytes:
    """A trained `StatePolicy` as bytes (read back with `load_storage_policy`): a JSON header
    with its shapes, then the equinox-serialised leaves (the LSMC and the lattice it starts on included)."""
    mlp, fit = policy.mlp, policy.fit
    header = {"head": "state", "in_size": mlp.in_size, "out_size": mlp.out_size, "width": mlp.width_size,
              "depth": mlp.depth, "harmonics": policy.harmonics, "spacing": policy.spacing,
              "levels": int(policy.levels.shape[0]), "basis": _basis_header(policy.basis),
              "fit_basis": _basis_header(fit.basis), "coefficients": list(fit.coefficients.shape),
              "fit_paths": int(fit.values.shape[0]),
              "lattice": None if policy.lattice is None else list(policy.lattice.low.shape)}
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
                           header["harmonics"], _lattice_like(header.get("lattice")))
        return eqx.tree_deserialise_leaves(handle, like)
