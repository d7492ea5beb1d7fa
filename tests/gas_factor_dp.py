"""An independent reference for storage on a two-factor price model: a NumPy/SciPy Bellman
recursion on (inventory, short-term factor, long-term factor), written without the production
code, for any facility of `make_inputs` (ratchets, fuel loss, costs, discounting, whole-day steps).

The model is the Gaussian state X_{t+1} = a X_t + L eps (daily steps, X_0 = 0) with the log spot
log S_t = log F_t + X_t[0] + X_t[1] - v_t / 2. The facility follows `_model.py`'s rules: on day t
at inventory V the net flow n into store lies in [lower, upper], with upper = (1 - fuel) min(
max_injection g_in(V / C), (C - V) / (1 - fuel)), lower = min(max(-min(max_withdrawal g_out(V / C),
V), L_{t+1} - V), upper) (L the terminal floor: the least inventory from which the requirement is
reachable), and pays -(S + c_in) n / (1 - fuel) for n > 0, (S - c_out) (-n) for n < 0,
discounted at exp(-r t / 365).

The value is tabulated on `levels` equally spaced inventories from 0 to C, linear between them;
the factors on a `points` x `points` grid spanning 4.5 standard deviations of the last day's
state, cubic (Catmull-Rom, exact for quadratics) between points, clamped at the box's edge, with
`nodes` x `nodes` Gauss-Hermite expectations written as one sparse matrix. With the continuation linear between levels and the
cash linear on either side of n = 0, the best move over the continuous interval is at a level
inside it, at one of its ends or at n = 0: all are tried, so each day's maximum is exact for the
tabulated continuation and the only errors are the grids' (measured by refining them).
"""

import itertools
from typing import NamedTuple

import numpy as np
from scipy import sparse

DAYS_PER_YEAR = 365.0


def _ratchet(table, fill):
    table = np.asarray(table, float)
    return np.interp(fill, table[:, 0], table[:, 1])


def _floor(facility: dict, days: int) -> np.ndarray:
    """L_t, t = 0..T: the least start-of-day inventory from which the terminal requirement is
    reachable at the full injection rate."""
    kept = 1.0 - facility["fuel_loss"]
    floor = np.zeros(days + 1)
    floor[days] = facility["terminal_inventory_min"]
    for t in range(days - 1, -1, -1):
        later = floor[t + 1]
        room = kept * facility["max_injection"] * _ratchet(facility["injection_ratchet"], later / facility["capacity"])
        floor[t] = max(later - room, 0.0)
    return floor


def _cubic_weights(axis, x):
    """Catmull-Rom weights of the four grid points around each x (clamped to the axis): indices
    and weights, shapes (..., 4). Exact for quadratics, so that the tabulated expectation adds no
    variance to the factor (linear interpolation adds about h^2 / 4 a day: over months, a
    numerical diffusion that raises the option's value)."""
    x = np.clip(x, axis[0], axis[-1])
    low = np.clip(np.searchsorted(axis, x, side="right") - 1, 0, len(axis) - 2)
    t = (x - axis[low]) / (axis[1] - axis[0])
    weights = np.stack([(-t**3 + 2 * t**2 - t) / 2, (3 * t**3 - 5 * t**2 + 2) / 2, (-3 * t**3 + 4 * t**2 + t) / 2,
                        (t**3 - t**2) / 2], -1)
    index = np.clip(low[..., None] + np.arange(-1, 3), 0, len(axis) - 1)
    return index, weights


def _expectation_matrix(decay, chol, axes, nodes):
    """The sparse (G, G) matrix E with (E f)(x) = E f(a x + L eps) for f tabulated on the grid
    `axes` (`_cubic_weights` in each factor), G = len(axes[0]) * len(axes[1])."""
    z, w = np.polynomial.hermite_e.hermegauss(nodes)
    w = w / w.sum()
    shocks = np.array(list(itertools.product(z, z))) @ chol.T
    weights = np.array([wi * wj for wi, wj in itertools.product(w, w)])
    grid = np.stack(np.meshgrid(*axes, indexing="ij"), -1).reshape(-1, 2)
    nxt = (grid * decay)[:, None, :] + shocks[None]  # (G, Q, 2)
    (i, wi), (j, wj) = (_cubic_weights(axis, nxt[..., dim]) for dim, axis in enumerate(axes))
    cols = i[..., :, None] * len(axes[1]) + j[..., None, :]  # (G, Q, 4, 4)
    vals = wi[..., :, None] * wj[..., None, :] * weights[None, :, None, None]
    rows = np.broadcast_to(np.arange(grid.shape[0])[:, None, None, None], cols.shape)
    size = grid.shape[0]
    return sparse.csr_matrix((vals.ravel(), (rows.ravel(), cols.ravel())), shape=(size, size))


class _Solution(NamedTuple):
    value: float  # at the initial inventory and X_0 = 0 [$]
    axes: list  # the factor grid's two axes
    inventory: np.ndarray  # (levels,) [MMBtu]
    continuations: list  # per day t, E_t V_{t+1} on (levels, G)
    variances: list  # v_t = Var(log S_t)
    values: list | None  # per day t, V_t on (levels, G), where kept (`_solve(keep_values=True)`)


def _solve(facility: dict, curve, decay, step_covariance, levels: int, points: int, nodes: int,
           keep_values: bool = False) -> _Solution:
    if points % 2 == 0:
        raise ValueError(f"points = {points}: odd, so that the origin X_0 = 0 is a grid point")
    curve = np.asarray(curve, float)
    days = curve.size
    decay, q = np.asarray(decay, float), np.asarray(step_covariance, float)
    capacity, kept = facility["capacity"], 1.0 - facility["fuel_loss"]
    sigma, variances = np.zeros((2, 2)), []
    for _ in range(days):
        variances.append(sigma.sum())
        sigma = decay[:, None] * sigma * decay[None, :] + q
    spread = 4.5 * np.sqrt(np.diag(sigma))
    axes = [np.linspace(-s, s, points) for s in spread]
    expectation = _expectation_matrix(decay, np.linalg.cholesky(q), axes, nodes)
    factor_sum = np.add.outer(axes[0], axes[1]).ravel()  # (G,)

    inventory = np.linspace(0.0, capacity, levels)
    step = inventory[1]
    fill = inventory / capacity
    upper = kept * np.minimum(facility["max_injection"] * _ratchet(facility["injection_ratchet"], fill),
                              (capacity - inventory) / kept)
    max_out = np.minimum(facility["max_withdrawal"] * _ratchet(facility["withdrawal_ratchet"], fill), inventory)
    floor = _floor(facility, days)
    k_in = int(np.ceil(upper.max() / step)) + 1
    k_out = int(np.ceil(max_out.max() / step)) + 1
    index = np.arange(levels)

    def at(table, target):
        """The tabulated `table` (levels, G) at inventories `target` (levels,), linear."""
        x = np.clip(target / step, 0, levels - 1)
        low = np.minimum(np.floor(x).astype(int), levels - 2)
        frac = (x - low)[:, None]
        return table[low] * (1 - frac) + table[low + 1] * frac

    def cash(net, spot, day):  # net (levels,), spot (G,) -> (levels, G)
        injection = np.maximum(net, 0.0)[:, None] / kept
        withdrawal = np.maximum(-net, 0.0)[:, None]
        flow = -(spot + facility["injection_cost"]) * injection + (spot - facility["withdrawal_cost"]) * withdrawal
        return flow * np.exp(-facility["rate"] / DAYS_PER_YEAR * day)

    def bellman(day, continuation, spot):
        lower = np.minimum(np.maximum(-max_out, floor[day + 1] - inventory), upper)
        best = np.maximum(cash(lower, spot, day) + at(continuation, inventory + lower),
                          cash(upper, spot, day) + at(continuation, inventory + upper))
        for k in range(-k_out, k_in + 1):
            target = index + k
            net = step * k
            inside = (target >= 0) & (target < levels) & (net >= lower - 1e-9 * step) & (net <= upper + 1e-9 * step)
            if not inside.any():
                continue
            rows = index[inside]
            best[rows] = np.maximum(best[rows], cash(np.full(rows.size, net), spot, day) + continuation[target[inside]])
        return best

    value = np.zeros((levels, factor_sum.size))
    continuations, values = [None] * days, [None] * days
    for day in range(days - 1, -1, -1):
        continuations[day] = (expectation @ value.T).T if day < days - 1 else value
        spot = curve[day] * np.exp(factor_sum - variances[day] / 2)
        value = bellman(day, continuations[day], spot)
        if keep_values:
            values[day] = value
    origin = (points // 2) * points + points // 2  # X_0 = 0: day 0's spot is the forward
    start = float(at(value[:, origin:origin + 1], np.array([facility["initial_inventory"]]))[0, 0])
    return _Solution(start, axes, inventory, continuations, variances, values if keep_values else None)


def two_factor_value(facility: dict, curve, decay, step_covariance, *, levels: int = 201, points: int = 41,
                     nodes: int = 9) -> float:
    """The optimal expected discounted cash [$] of storage `facility` (the `make_inputs` fields)
    over the daily forward `curve` (T,) under the two-factor model with daily `decay` a (2,) and
    step covariance Q (2, 2), both factors loaded 1 on the log spot (module docstring)."""
    return _solve(facility, curve, decay, step_covariance, levels, points, nodes).value


def two_factor_policy_cash(facility: dict, curve, decay, step_covariance, factors, *, levels: int = 201,
                           points: int = 41, nodes: int = 9) -> tuple[np.ndarray, np.ndarray]:
    """Each path's discounted cash [$] of the dynamic program's own rule (each day the feasible
    net flow that maximises cash plus the tabulated continuation at the path's factors) on the
    factor paths `factors` (P, T, 2): a non-anticipative policy of the exact facility, so its
    mean is a lower bound on the value whatever the grids' errors, shape (P,); and its
    start-of-day inventories [MMBtu], shape (P, T + 1)."""
    solution = _solve(facility, curve, decay, step_covariance, levels, points, nodes)
    curve, factors = np.asarray(curve, float), np.asarray(factors, float)
    capacity, kept = facility["capacity"], 1.0 - facility["fuel_loss"]
    floor = _floor(facility, curve.size)
    grid = solution.inventory
    held = np.full(factors.shape[0], float(facility["initial_inventory"]))
    total = np.zeros(factors.shape[0])
    path = [held]
    for day in range(curve.size):
        x = factors[:, day]
        spot = curve[day] * np.exp(x.sum(-1) - solution.variances[day] / 2)
        table = _bilinear(solution.continuations[day], solution.axes, x)  # (P, levels)
        fill = held / capacity
        upper = kept * np.minimum(facility["max_injection"] * _ratchet(facility["injection_ratchet"], fill),
                                  (capacity - held) / kept)
        max_out = np.minimum(facility["max_withdrawal"] * _ratchet(facility["withdrawal_ratchet"], fill), held)
        lower = np.minimum(np.maximum(-max_out, floor[day + 1] - held), upper)
        nets = np.concatenate([grid[None] - held[:, None], np.stack([lower, upper, np.zeros_like(held)], -1)], 1)
        nets = np.clip(nets, lower[:, None], upper[:, None])
        after = np.clip(held[:, None] + nets, 0.0, capacity)
        later = np.stack([np.interp(a, grid, t) for a, t in zip(after, table)])
        flow = (-(spot[:, None] + facility["injection_cost"]) * np.maximum(nets, 0) / kept
                + (spot[:, None] - facility["withdrawal_cost"]) * np.maximum(-nets, 0))
        flow = flow * np.exp(-facility["rate"] / DAYS_PER_YEAR * day)
        choice = np.argmax(flow + later, axis=1)
        rows = np.arange(held.size)
        total += flow[rows, choice]
        held = held + nets[rows, choice]
        path.append(held)
    return total, np.stack(path, 1)


def _bilinear(table, axes, x):
    """`table` (levels, G) on the factor grid `axes`, at the points x (P, 2) (clamped): (P, levels)."""
    corner = []
    for dim, axis in enumerate(axes):
        xi = np.clip(x[:, dim], axis[0], axis[-1])
        low = np.clip(np.searchsorted(axis, xi, side="right") - 1, 0, len(axis) - 2)
        corner.append((low, (xi - axis[low]) / (axis[low + 1] - axis[low])))
    (i0, fi), (j0, fj) = corner
    size = len(axes[1])
    out = 0.0
    for di, dj in itertools.product((0, 1), (0, 1)):
        share = (fi if di else 1 - fi) * (fj if dj else 1 - fj)
        out = out + share[:, None] * table[:, (i0 + di) * size + (j0 + dj)].T
    return out
