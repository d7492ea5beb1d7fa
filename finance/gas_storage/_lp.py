"""The exact intrinsic value: the deterministic storage problem as a linear program (a mixed-
integer one when a ratchet table is not concave), solved by HiGHS through SciPy."""

from typing import NamedTuple

import numpy as np
from scipy import sparse
from scipy.optimize import Bounds, LinearConstraint, milp

from snapo_ode import Scene

from ._inputs import DAYS_PER_YEAR, StorageInputs


class IntrinsicSolution(NamedTuple):
    """`value` [$]; `injection`, `withdrawal` shape (T,) and `inventory` shape (T+1,);
    `deltas`: d value / d F_t = DF_t (wd_t - inj_t) by the envelope theorem, shape (T,);
    `method`: "LP" or "MILP"."""

    value: float
    injection: np.ndarray
    withdrawal: np.ndarray
    inventory: np.ndarray
    deltas: np.ndarray
    method: str


def is_concave(table: np.ndarray) -> bool:
    """Whether a piecewise-linear table's slopes never increase."""
    slopes = np.diff(table[:, 1]) / np.diff(table[:, 0])
    return bool(np.all(np.diff(slopes) <= 1e-12))


class _Constraints:
    """Linear constraints lower <= A x <= upper, added a block of one row per day at a time."""

    def __init__(self, n_days: int):
        self.n_days = n_days
        self.rows, self.cols, self.values, self.lower, self.upper = [], [], [], [], []
        self.count = 0

    def add(self, entries, lower, upper):
        """`entries`: (columns, coefficients) pairs, each an array over days or a scalar."""
        days = np.arange(self.n_days)
        for columns, coefficients in entries:
            self.rows.append(self.count + days)
            self.cols.append(np.broadcast_to(columns, days.shape))
            self.values.append(np.broadcast_to(np.asarray(coefficients, dtype=float), days.shape))
        self.lower.append(np.broadcast_to(lower, days.shape))
        self.upper.append(np.broadcast_to(upper, days.shape))
        self.count += self.n_days

    def build(self, n_vars: int) -> LinearConstraint:
        matrix = sparse.csr_matrix(
            (np.concatenate(self.values), (np.concatenate(self.rows), np.concatenate(self.cols))),
            shape=(self.count, n_vars),
        )
        return LinearConstraint(matrix, np.concatenate(self.lower), np.concatenate(self.upper))


def _add_ratchet(constraints: _Constraints, table, flow_col, inv_col, max_rate, capacity, next_binary) -> int:
    """Bound flow_t <= max_rate g(V_t / capacity). Concave g: one row per segment and day.
    Otherwise a binary per segment and day picks the segment holding V_t (big-M). Returns the
    number of binaries used, numbered from `next_binary`."""
    x, y = table[:, 0], table[:, 1]
    slopes = np.diff(y) / np.diff(x)
    n_segments = len(slopes)
    days = np.arange(constraints.n_days)
    flow = (flow_col + days, 1.0)
    fill_per_unit = 1.0 / capacity
    if is_concave(table):
        for s in range(n_segments):
            # flow - max_rate slope_s V / capacity <= max_rate (y_s - slope_s x_s)
            constraints.add([flow, (inv_col + days, -max_rate * slopes[s] * fill_per_unit)],
                            -np.inf, max_rate * (y[s] - slopes[s] * x[s]))
        return 0
    big_m = max_rate * (np.max(np.abs(y)) + np.max(np.abs(slopes)) + 1.0)
    chosen = [(next_binary + s * constraints.n_days + days) for s in range(n_segments)]
    constraints.add([(z, 1.0) for z in chosen], 1.0, 1.0)
    # sum_s x_s z_s <= V / capacity <= sum_s x_{s+1} z_s
    constraints.add([(inv_col + days, fill_per_unit)] + [(z, -x[s]) for s, z in enumerate(chosen)], 0.0, np.inf)
    constraints.add([(inv_col + days, fill_per_unit)] + [(z, -x[s + 1]) for s, z in enumerate(chosen)],
                    -np.inf, 0.0)
    for s, z in enumerate(chosen):
        # flow <= max_rate (y_s + slope_s (V / capacity - x_s)) + M (1 - z_s)
        constraints.add([flow, (inv_col + days, -max_rate * slopes[s] * fill_per_unit), (z, big_m)],
                        -np.inf, max_rate * (y[s] - slopes[s] * x[s]) + big_m)
    return n_segments * constraints.n_days


def solve_intrinsic(inputs: StorageInputs, scene: Scene) -> IntrinsicSolution:
    """The optimal intrinsic schedule and value for the deterministic effects of `scene`.

    Variables: inj_0..inj_{T-1}, wd_0..wd_{T-1}, V_0..V_T (then ratchet binaries for a
    non-concave table).
    """
    f = {name: np.asarray(value, dtype=float) for name, value in vars(inputs).items()}
    n = inputs.n_days
    days = np.arange(n)
    inj, wd, inv = 0, n, 2 * n
    n_continuous = 3 * n + 1
    kept = 1.0 - float(f["fuel_loss"]) if scene.has("fuel_loss") else 1.0
    discount = np.exp(-f["rate"] / DAYS_PER_YEAR * days) if scene.has("discounting") else np.ones(n)
    price = f["forward_curve"]
    cost_in = f["injection_cost"] if scene.has("costs") else 0.0
    cost_out = f["withdrawal_cost"] if scene.has("costs") else 0.0

    constraints = _Constraints(n)
    # V_{t+1} - V_t - kept inj_t + wd_t = 0
    constraints.add([(inv + days + 1, 1.0), (inv + days, -1.0), (inj + days, -kept), (wd + days, 1.0)], 0.0, 0.0)
    n_binaries = 0
    if scene.has("ratchets"):
        for table, col, max_rate in ((f["injection_ratchet"], inj, f["max_injection"]),
                                     (f["withdrawal_ratchet"], wd, f["max_withdrawal"])):
            n_binaries += _add_ratchet(constraints, table, col, inv, float(max_rate), float(f["capacity"]),
                                       n_continuous + n_binaries)
    n_vars = n_continuous + n_binaries

    low = np.zeros(n_vars)
    high = np.full(n_vars, np.inf)
    high[inj:inj + n] = f["max_injection"]
    high[wd:wd + n] = f["max_withdrawal"]
    high[inv:inv + n + 1] = f["capacity"]
    low[inv] = high[inv] = f["initial_inventory"]
    low[inv + n] = f["terminal_inventory_min"]
    high[n_continuous:] = 1.0
    cost = np.zeros(n_vars)
    cost[inj:inj + n] = discount * (price + cost_in)
    cost[wd:wd + n] = -discount * (price - cost_out)
    integrality = np.zeros(n_vars)
    integrality[n_continuous:] = 1
    result = milp(cost, constraints=constraints.build(n_vars),
                  bounds=Bounds(low, high), integrality=integrality,
                  options={"mip_rel_gap": 1e-9, "presolve": True})
    if result.status != 0 or result.x is None:
        raise RuntimeError(f"the intrinsic LP failed: {result.message}")
    x = result.x
    injection, withdrawal = x[inj:inj + n], x[wd:wd + n]
    return IntrinsicSolution(
        value=float(-result.fun),
        injection=injection,
        withdrawal=withdrawal,
        inventory=x[inv:inv + n + 1],
        deltas=discount * (withdrawal - injection),
        method="MILP" if n_binaries else "LP",
    )
