"""A dynamic program on the factors of a Gaussian price model (`_price_models.py`): the value of
storage V_t(n, X) on a tensor grid of the k factors, and the basestock targets it implies, the
state policy's start where the grid is affordable (`_state_policy.py`).

Coordinates. With L the Cholesky factor of the step covariance Q written L = U D (U unit lower
triangular, D diagonal) and z = U^-1 X,

    z_{t+1} = M z_t + D eps,   M = U^-1 A U (lower triangular),   eps ~ N(0, I_k):

given z_t the coordinates of z_{t+1} are independent normals, the d-th of mean
mu_d = sum_{e <= d} M_de z_e (the first d coordinates only) and standard deviation D_d. On
`points` equally spaced values per coordinate (+- `width` times its largest standard deviation
over the horizon) V~ is the tensor product of piecewise-linear interpolants, flat beyond each
axis' ends, so its expectation is the product of the exact one-dimensional ones
(`_lattice._calls`, `_lattice._kinks`):

    E[V~(z_{t+1}) | z_t] = sum_j V~_j prod_d h_d(mu_d, j_d),

computed one axis at a time (axis d's weights depend on the first d coordinates only):
k G^(k+1) operations per inventory level and day, not G^(2k). Backward over days each node
takes the best candidate inventory (`_lsmc.level_decisions`: exact rates, ratchets, fuel and
costs) against that continuation, and the continuation's basestock targets
(`_lsmc.continuation_targets`) are kept for every node and day. For one factor this is
`_lattice.py`'s lattice on the same model; the cost in G^k makes it a start for two or three
factors (`lattice_points` sizes the grid by its work), LSMC's regression the method beyond.
The lattice's value is an approximation (discretisation), not a bound.
"""

import itertools
from typing import NamedTuple

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np

from snapo_ode import InputError, Scene, check_count, check_range

from ._basestock import inventory_bounds
from ._inputs import StorageInputs
from ._lattice import _calls, _kinks
from ._lsmc import InventoryGrid, continuation_targets, interpolate_levels, level_decisions, start_value
from ._model import inventory_floor
from ._price_models import AbstractPriceModel

# The most work `lattice_points` allows: days x levels x nodes G^k x (the candidates a level decides
# among + k G / 8, the expectation's multiply-adds, about an eighth of a candidate's cost, measured;
# docs/dev/gas_storage_notes.md, "The factor lattice as the start").
MODEL_LATTICE_WORK = 1.2e10
# The fewest and the most points per factor `lattice_points` gives: below 21 the lattice's start lost to
# the LSMC's where measured (docs/dev/gas_storage_notes.md, "The factor lattice as the start").
MODEL_LATTICE_POINTS = (21, 101)
# Each axis spans +- this many of its largest standard deviations over the horizon (chosen on the
# fast facilities of both families: docs/dev/gas_storage_notes.md, "The factor lattice as the start").
MODEL_LATTICE_WIDTH = 3.0


class ModelLattice(NamedTuple):
    """`unit` U (k, k) and `axes` (k, G): z = U^-1 X on the grid; `low`, `high`: the basestock
    targets b_L, b_U for tomorrow's inventory [MMBtu] of every day and node, shape (T, G, ..., G)
    (k axes); `value`: V_0 at the initial inventory and X_0 = 0 [$]; `values`: V_t at every node
    and level, shape (T, G, ..., G, N) [$], where asked for (`keep_values`), else None."""

    unit: jax.Array
    axes: jax.Array
    low: jax.Array
    high: jax.Array
    value: jax.Array
    values: jax.Array | None = None


def _coordinates(model: AbstractPriceModel) -> tuple[jax.Array, jax.Array, jax.Array]:
    """(U, M, D): X = U z, z_{t+1} = M z_t + D eps (module docstring)."""
    chol = jnp.linalg.cholesky(model.step_covariance())
    sd = jnp.diag(chol)
    unit = chol / sd[None, :]
    drift = jax.scipy.linalg.solve_triangular(unit, model.decay()[:, None] * unit, lower=True, unit_diagonal=True)
    return unit, drift, sd


def _degenerate(model: AbstractPriceModel) -> bool:
    """Whether a day's step has a direction of zero variance (a zero volatility, a correlation of
    +-1): the coordinates z would divide by it."""
    sd = np.asarray(_coordinates(model)[2])
    return not bool(np.all(np.isfinite(sd) & (sd > 1e-300)))


def lattice_points(model: AbstractPriceModel, inputs: StorageInputs, scene: Scene, grid: InventoryGrid, *,
                   work: float = MODEL_LATTICE_WORK) -> int | None:
    """The most points per factor, odd, between MODEL_LATTICE_POINTS, whose lattice costs at most
    `work`; None where even the fewest cost more or the model's step is degenerate (`_degenerate`):
    the start is then LSMC's."""
    if _degenerate(model):
        return None
    k = len(model.factor_names)
    window = np.asarray(grid.window).size + 3  # the candidates a level decides among
    low, high = MODEL_LATTICE_POINTS

    def cost(points):
        return inputs.n_days * grid.nodes * points ** k * (window + k * points / 8)

    if cost(low) > work:
        return None
    points = low
    while points + 2 <= high and cost(points + 2) <= work:
        points += 2
    return points


def lattice_coordinates(unit: jax.Array, factors: jax.Array) -> jax.Array:
    """z = U^-1 X of `factors` X (..., k), same shape: the coordinates the lattice's axes are in."""
    k = unit.shape[0]
    z = jax.scipy.linalg.solve_triangular(unit, factors.reshape(-1, k).T, lower=True, unit_diagonal=True)
    return z.T.reshape(factors.shape)


def hat_expectations(axis: jax.Array, mean: jax.Array, sd) -> jax.Array:
    """E h_j(Y), Y ~ N(mean, sd^2), of the hat functions h_j of `axis` (G,) (flat beyond its
    ends): shape mean.shape + (G,), so that E V~(Y) = hat_expectations(...) @ V."""
    return jnp.zeros(axis.shape[0]).at[0].set(1.0) + _calls(axis, mean, sd) @ _kinks(axis)


def _expectation_weights(axes: jax.Array, drift: jax.Array, sd: jax.Array) -> list[jax.Array]:
    """h_d for d = 0..k-1, shape (G,) * (d + 1) + (G,): the expected hat functions of axis d at
    every node of the first d + 1 axes."""
    weights = []
    for d in range(axes.shape[0]):
        nodes = jnp.stack(jnp.meshgrid(*axes[:d + 1], indexing="ij"), -1)  # (G,) * (d + 1) + (d + 1,)
        weights.append(hat_expectations(axes[d], nodes @ drift[d, :d + 1], sd[d]))
    return weights


def expect(weights: list[jax.Array], table: jax.Array) -> jax.Array:
    """E[V~(z_{t+1}) | z_t = node] for V~ tabulated as `table` (G,) * k + (N,): same shape."""
    shape = table.shape
    k, points = len(weights), shape[0]
    out = table.reshape(1, points, -1)
    for d, h in enumerate(weights):
        out = jnp.einsum("bij,bjr->bir", h.reshape(-1, points, points), out)
        if d + 1 < k:
            out = out.reshape(points ** (d + 1), points, -1)
    return out.reshape(shape)


def interpolate_grid(axes: jax.Array, table: jax.Array, z: jax.Array) -> jax.Array:
    """`table` (G,) * k + rest interpolated multilinearly at `z` (paths, k), flat beyond each
    axis' ends: shape (paths,) + rest."""
    k, points = axes.shape
    spacing = axes[:, 1] - axes[:, 0]
    position = jnp.clip((z - axes[:, 0]) / spacing, 0, points - 1)
    low = jnp.clip(jnp.floor(position).astype(int), 0, points - 2)
    weight = position - low
    out = 0.0
    for corner in itertools.product((0, 1), repeat=k):
        index = tuple(low[:, d] + corner[d] for d in range(k))
        share = jnp.prod(jnp.stack([weight[:, d] if corner[d] else 1 - weight[:, d] for d in range(k)]), axis=0)
        out = out + share.reshape((-1,) + (1,) * (table.ndim - k)) * table[index]
    return out


def solve_model_lattice(model: AbstractPriceModel, inputs: StorageInputs, scene: Scene, grid: InventoryGrid,
                        points: int, *, width: float = MODEL_LATTICE_WIDTH,
                        keep_values: bool = False) -> ModelLattice:
    """Backward induction on `points` values per factor (module docstring); `keep_values`: return
    every day's value table too (T x G^k x N numbers).

    **Raises:** `InputError` for `points` outside [3, 401], `width` outside [1, 50] or a model
    whose daily step is degenerate (a zero volatility or a correlation of +-1)."""
    check_count("points", points, 3, 401)
    check_range("width", width, 1.0, 50.0)
    if _degenerate(model):
        raise InputError(f"{type(model).__name__}: a factor's daily step has zero variance (a zero volatility or a "
                         "correlation of +-1); the factor lattice needs every factor random. Use the LSMC start.")
    return _solve(model, inputs, scene, grid, int(points), float(width), bool(keep_values))


@eqx.filter_jit
def _solve(model, inputs, scene, grid, points: int, width: float, keep_values: bool) -> ModelLattice:
    unit, drift, sd = _coordinates(model)
    k, n_days = drift.shape[0], inputs.n_days
    spread = jax.scipy.linalg.solve_triangular(unit, model.covariances(n_days), lower=True, unit_diagonal=True)
    spread = jnp.swapaxes(jax.scipy.linalg.solve_triangular(unit, jnp.swapaxes(spread, -1, -2), lower=True,
                                                            unit_diagonal=True), -1, -2)  # Cov(z_t), (T, k, k)
    half = width * jnp.sqrt(jnp.max(jnp.diagonal(spread, axis1=-2, axis2=-1), axis=0))
    axes = jnp.linspace(-half, half, points, axis=-1)  # (k, G)
    weights = _expectation_weights(axes, drift, sd)
    nodes = jnp.stack(jnp.meshgrid(*axes, indexing="ij"), -1).reshape(-1, k)  # (G^k, k)
    log_ratio = nodes @ (model.loadings(n_days) @ unit).T - model.log_variance(n_days) / 2  # (G^k, T)
    prices = inputs.forward_curve * jnp.exp(log_ratio)
    floor_next, ceiling_next = (bound[1:] for bound in inventory_bounds(inputs, scene, None))
    levels = jnp.asarray(grid.levels)
    cube = (points,) * k

    def back(later, today):
        day, price, floor_tomorrow, bound_low, bound_high = today
        continuation = expect(weights, later.reshape(cube + (-1,))).reshape(later.shape)
        _, values = level_decisions(inputs, scene, grid, price, day, floor_tomorrow, continuation)
        positions = jnp.clip(levels, bound_low, bound_high)
        value = interpolate_levels(continuation, positions, grid.spacing)
        low, high = continuation_targets(inputs, scene, value, positions, price, day, grid.spacing)
        return values, (low.reshape(cube), high.reshape(cube), values.reshape(cube + (-1,)) if keep_values else None)

    values, (low, high, tables) = jax.lax.scan(
        back, jnp.zeros((points ** k, grid.nodes)),
        (jnp.arange(n_days), prices.T, inventory_floor(inputs, scene, None)[1:], floor_next, ceiling_next),
        reverse=True)
    origin = interpolate_grid(axes, values.reshape(cube + (-1,)), jnp.zeros((1, k)))
    return ModelLattice(unit, axes, low, high, start_value(inputs, grid, origin)[0], tables)
