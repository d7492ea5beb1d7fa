"""The largest value over a window of levels, every window at once, in O(levels log window):
a sparse table (Bentley 1980) built inside the trace, so that the bound's dynamic program
(`_dual.py`) costs levels x log2(moves) per day instead of levels x moves."""

import jax.numpy as jnp
import numpy as np


def range_maxima(values, low: np.ndarray, high: np.ndarray):
    """max(values[..., m] for low[n] <= m <= high[n]) for every n, indices outside [0, N) left
    out (-inf where the whole window is outside): `values` of shape (..., N); `low` and `high`
    static integer arrays of shape (M,), low <= high. Shape (..., M).

    Table j holds the maxima of the 2^j values from each index; a window of length L is the
    larger of the two (overlapping) windows of length 2^floor(log2 L) at its two ends. Where
    the windows' ends move with n (no ratchet), the ends are slices of the table; elsewhere a
    gather."""
    low, high = np.asarray(low, dtype=int), np.asarray(high, dtype=int)
    if low.shape != high.shape or low.ndim != 1 or np.any(low > high):
        raise ValueError("range_maxima needs one-dimensional low <= high, elementwise")
    before, after = max(0, -int(low.min())), max(0, int(high.max()) - values.shape[-1] + 1)
    table = _pad(values, before, after)
    order = np.floor(np.log2(high - low + 1)).astype(int)
    result = None
    for j in range(int(order.max()) + 1):
        if j > 0:
            table = jnp.maximum(table, _pad(table[..., 2 ** (j - 1):], 0, 2 ** (j - 1)))
        if not np.any(order == j):
            continue
        ends = jnp.maximum(_at(table, low + before), _at(table, high + before - 2 ** j + 1))
        result = ends if result is None else jnp.where(order == j, ends, result)
    return result


def _pad(values, before: int, after: int):
    """`values` with -inf added before and after along the last axis."""
    if before == after == 0:
        return values
    return jnp.pad(values, [(0, 0)] * (values.ndim - 1) + [(before, after)], constant_values=-jnp.inf)


def _at(table, index: np.ndarray):
    """table[..., index]: a slice where the index steps by one, else a gather (clipped: the
    caller masks the levels whose index is out of range)."""
    if np.all(np.diff(index) == 1) and index[0] >= 0 and index[-1] < table.shape[-1]:
        return table[..., index[0]:index[-1] + 1]
    return table[..., np.clip(index, 0, table.shape[-1] - 1)]
