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


def _add_ratchet(constraints: _Constraints, table, flow_col, inv_col, max_rate, capacity,
                 next_extra) -> tuple[int, np.ndarray]:
    """Bound flow_t <= max_rate g(V_t / capacity). Concave g: one row per segment and day.
    Otherwise the convex-combination (SOS2) formulation: weights lambda over the knots with one
    binary per segment choosing the two adjacent knots. Returns the number of extra variables
    (weights, then binaries), numbered from `next_extra`, and the binaries' columns."""
    x, y = table[:, 0], table[:, 1]
    n_days, n_knots = constraints.n_days, len(x)
    days = np.arange(n_days)
    flow = (flow_col + days, 1.0)
    if is_concave(table):
        slopes = np.diff(y) / np.diff(x)
        for s in range(n_knots - 1):
            # flow - max_rate slope_s V / capacity <= max_rate (y_s - slope_s x_s)
            constraints.add([flow, (inv_col + days, -max_rate * slopes[s] / capacity)],
                            -np.inf, max_rate * (y[s] - slopes[s] * x[s]))
        return 0, np.zeros(0, dtype=int)
    weight = [next_extra + i * n_days + days for i in range(n_knots)]
    chosen = [next_extra + (n_knots + s) * n_days + days for s in range(n_knots - 1)]
    constraints.add([(w, 1.0) for w in weight], 1.0, 1.0)
    constraints.add([(z, 1.0) for z in chosen], 1.0, 1.0)
    constraints.add([(inv_col + days, 1.0 / capacity)] + [(w, -x[i]) for i, w in enumerate(weight)], 0.0, 0.0)
    constraints.add([flow] + [(w, -max_rate * y[i]) for i, w in enumerate(weight)], -np.inf, 0.0)
    for i, w in enumerate(weight):
        neighbours = [z for s, z in enumerate(chosen) if s in (i - 1, i)]
        constraints.add([(w, 1.0)] + [(z, -1.0) for z in neighbours], -np.inf, 0.0)
    return (2 * n_knots - 1) * n_days, np.concatenate(chosen)


def solve_intrinsic(inputs: StorageInputs, scene: Scene) -> IntrinsicSolution:
    """The optimal intrinsic schedule and value for the deterministic effects of `scene`.

    Variables: inj_0..inj_{T-1}, wd_0..wd_{T-1}, V_0..V_T, then the SOS2 weights and binaries
    of each non-concave ratchet table.
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
    n_vars, binaries = n_continuous, []
    if scene.has("ratchets"):
        for table, col, max_rate in ((f["injection_ratchet"], inj, f["max_injection"]),
                                     (f["withdrawal_ratchet"], wd, f["max_withdrawal"])):
            extra, columns = _add_ratchet(constraints, table, col, inv, float(max_rate), float(f["capacity"]), n_vars)
            n_vars += extra
            binaries.append(columns)
    binaries = np.concatenate(binaries) if binaries else np.zeros(0, dtype=int)

    low = np.zeros(n_vars)
    high = np.full(n_vars, np.inf)
    high[inj:inj + n] = f["max_injection"]
    high[wd:wd + n] = f["max_withdrawal"]
    high[inv:inv + n + 1] = f["capacity"]
    low[inv] = high[inv] = f["initial_inventory"]
    low[inv + n] = f["terminal_inventory_min"]
    high[n_continuous:] = 1.0  # SOS2 weights and segment binaries
    cost = np.zeros(n_vars)
    cost[inj:inj + n] = discount * (price + cost_in)
    cost[wd:wd + n] = -discount * (price - cost_out)
    integrality = np.zeros(n_vars)
    integrality[binaries] = 1
    result = milp(cost, constraints=constraints.build(n_vars),
                  bounds=Bounds(low, high), integrality=integrality,
                  options={"mip_rel_gap": 1e-6, "presolve": True})
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
        method="MILP" if binaries.size else "LP",
    )
