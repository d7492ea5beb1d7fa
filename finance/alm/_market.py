"""The capital-market model: key-rate tenors, factor loadings, mean reversions, the driver
correlation, and the assets' fixed maturities.

Rates are zero rates, continuously compounded [1/year]; times are in years unless the name says
months. Everything here is fixed model structure: the risk factors whose sensitivities are
reported live in `_factors.py`.
"""

from typing import NamedTuple

import equinox as eqx
import jax
import numpy as np

from snapo_ode import InputError, check_finite, check_range

MONTH = 1.0 / 12.0
RATE_DRIVERS = ("rate_level", "rate_slope", "rate_curvature")
ASSETS = ("cash", "bond_short", "bond_long", "inflation_linked", "credit", "equity")  # the built-in fund's classes
ASSET_KINDS = ("cash", "nominal", "inflation_linked", "credit", "equity")


class AssetClass(NamedTuple):
    """One asset class the policy weights: its `name`, `kind` (`ASSET_KINDS`: cash earns the
    short rate; `nominal`, `inflation_linked` and `credit` are constant-maturity zero-coupon
    buckets of `maturity` [years] priced off the simulated curve (real yields; plus the spread),
    rolled monthly; `equity` is the equal-weight sleeve over the equity indices, the last class)."""

    name: str
    kind: str
    maturity: float | None = None


def default_asset_classes(bond_maturities=(5.0, 30.0), inflation_linked_maturity=20.0,
                          credit_maturity=7.0) -> tuple[AssetClass, ...]:
    """The built-in fund's six classes, `ASSETS`."""
    short, long = bond_maturities
    return (AssetClass("cash", "cash"), AssetClass("bond_short", "nominal", float(short)),
            AssetClass("bond_long", "nominal", float(long)),
            AssetClass("inflation_linked", "inflation_linked", float(inflation_linked_maturity)),
            AssetClass("credit", "credit", float(credit_maturity)), AssetClass("equity", "equity"))


def check_asset_classes(classes) -> tuple[AssetClass, ...]:
    """The classes as `AssetClass`es, or `InputError` naming the class: distinct names, known
    kinds, maturities in (1 month, 100 years] for the bond kinds (none for cash and equity), and
    exactly one equity class, the last."""
    classes = tuple(AssetClass(*c) for c in classes)
    names = [c.name for c in classes]
    if len(set(names)) != len(names) or len(classes) < 2:
        raise InputError(f"asset classes {names}: at least two, with distinct names.")
    for c in classes:
        if c.kind not in ASSET_KINDS:
            raise InputError(f"asset class {c.name!r}: kind = {c.kind!r}; allowed: {', '.join(ASSET_KINDS)}.")
        bond = c.kind in ("nominal", "inflation_linked", "credit")
        if bond != (c.maturity is not None) or (bond and not MONTH < c.maturity <= 100.0):
            raise InputError(f"asset class {c.name!r}: maturity = {c.maturity!r}; allowed: (1/12, 100] years for a "
                             "bond kind, none for cash and equity.")
    if [c.kind for c in classes].count("equity") != 1 or classes[-1].kind != "equity":
        raise InputError(f"asset classes {names}: exactly one of kind 'equity' (the sleeve over the equity "
                         "indices), the last.")
    return classes


def key_tenors(n_tenors: int) -> np.ndarray:
    """The default key-rate tenors [years], shape (n_tenors,): geometric from 3 months to 60 years,
    dense at the short end as market curves are."""
    if n_tenors == 1:
        return np.array([10.0])
    return np.geomspace(0.25, 60.0, n_tenors)


def interpolation_segments(maturities, tenors) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Where each maturity sits on the key tenors for linear interpolation in maturity, flat beyond
    both ends: `(left, right, fraction)`, each shape (m,), so that the zero rate at `maturities[i]`
    is `(1 - fraction[i]) * r[left[i]] + fraction[i] * r[right[i]]`.

    **Arguments:** `maturities` [years], shape (m,); `tenors` [years], shape (k,), increasing.
    """
    maturities = np.atleast_1d(np.asarray(maturities, dtype=float))
    tenors = np.asarray(tenors, dtype=float)
    if tenors.size == 1:
        zero = np.zeros(maturities.size, int)
        return zero, zero, np.zeros(maturities.size)
    clipped = np.clip(maturities, tenors[0], tenors[-1])
    right = np.clip(np.searchsorted(tenors, clipped, side="right"), 1, tenors.size - 1)
    left = right - 1
    return left, right, (clipped - tenors[left]) / (tenors[right] - tenors[left])


def interpolation_weights(maturities, tenors) -> np.ndarray:
    """Weights of linear interpolation in maturity on the key tenors, flat beyond both ends.

    **Arguments:** `maturities` [years], shape (m,); `tenors` [years], shape (k,), increasing.

    **Returns:** shape (m, k); row i gives the zero rate at `maturities[i]` as a weighted sum of
    the key rates: the derivative of that zero rate with respect to each key rate.
    """
    left, right, fraction = interpolation_segments(maturities, tenors)
    weights = np.zeros((left.size, np.size(tenors)))
    rows = np.arange(left.size)
    weights[rows, left] = 1.0 - fraction
    weights[rows, right] += fraction
    return weights


def rate_loadings(tenors) -> np.ndarray:
    """Level, slope and curvature loadings of each key rate, shape (k, 3), each row of unit norm so
    that a key rate's normal volatility is its `rate_vols` entry."""
    tenors = np.asarray(tenors, dtype=float)
    decay = np.exp(-tenors / 5.0)
    raw = np.stack([np.ones_like(tenors), decay - 0.5, 4.0 * decay * (1.0 - decay) - 0.4], axis=1)
    raw[:, 1:] *= 0.6
    return raw / np.linalg.norm(raw, axis=1, keepdims=True)


def driver_names(n_equities: int) -> tuple[str, ...]:
    """Names of the correlated shocks, in the order of the correlation matrix's rows."""
    return (*RATE_DRIVERS, *(f"equity_{e}" for e in range(n_equities)), "inflation", "spread")


def default_correlation(n_equities: int) -> np.ndarray:
    """A plausible driver correlation, shape (3 + n_equities + 2,)*2: equities 0.7 among
    themselves, -0.4 with spreads, 0.2 with the rate level; inflation 0.3 with the rate level."""
    names = driver_names(n_equities)
    index = {name: i for i, name in enumerate(names)}
    corr = np.eye(len(names))
    equities = [index[f"equity_{e}"] for e in range(n_equities)]

    def put(a, b, value):
        corr[a, b] = corr[b, a] = value

    for i in equities:
        for j in equities:
            if i != j:
                corr[i, j] = 0.7
        put(i, index["spread"], -0.4)
        put(i, index["rate_level"], 0.2)
    put(index["inflation"], index["rate_level"], 0.3)
    return corr


def check_correlation(field: str, matrix, size: int) -> np.ndarray:
    """Raise unless `matrix` is a (size, size) symmetric positive-semidefinite correlation matrix
    with a unit diagonal; returns it as float64."""
    matrix = check_finite(field, matrix)
    if matrix.shape != (size, size):
        raise InputError(f"{field} has shape {matrix.shape}; expected ({size}, {size}) (one row per "
                         "driver: 3 rate factors, one per equity index, inflation, spread).")
    asymmetry = np.abs(matrix - matrix.T)
    if asymmetry.max() > 1e-12:
        i, j = np.unravel_index(np.argmax(asymmetry), matrix.shape)
        raise InputError(f"{field} is not symmetric: {field}[{i}, {j}] = {matrix[i, j]:g} but "
                         f"{field}[{j}, {i}] = {matrix[j, i]:g}.")
    diagonal = np.abs(np.diag(matrix) - 1.0)
    if diagonal.max() > 1e-12:
        i = int(np.argmax(diagonal))
        raise InputError(f"{field}[{i}, {i}] = {matrix[i, i]:g}; a correlation matrix has 1 on its "
                         "diagonal.")
    check_range(field, matrix, -1.0, 1.0)
    smallest = float(np.linalg.eigvalsh(matrix).min())
    if smallest < -1e-10:
        raise InputError(f"{field} is not positive semidefinite: its smallest eigenvalue is "
                         f"{smallest:.3g}; allowed: >= 0.")
    return matrix


def cholesky_factor(correlation: np.ndarray) -> np.ndarray:
    """A lower-triangular C with C C^T = correlation, also for a singular (PSD) matrix: the
    Cholesky factor of its eigenvalue-clipped form."""
    values, vectors = np.linalg.eigh(correlation)
    root = vectors * np.sqrt(np.clip(values, 0.0, None))
    return np.linalg.cholesky(root @ root.T + 1e-14 * np.eye(len(values)))


class Market(eqx.Module):
    """The fixed structure of the market model.

    **Arguments:**
    - `tenors`: key-rate tenors [years], shape (n_tenors,).
    - `n_equities`: number of equity indices.
    - `correlation`: driver correlation, shape (d, d) with d = 3 + n_equities + 2 (see
      `driver_names`); default `default_correlation`.
    - `rate_mean_reversion`, `inflation_mean_reversion`, `spread_mean_reversion` [1/year]:
      speeds at which key rates, inflation and the credit spread revert to their initial values.
    - `equity_premium` [1/year]: expected equity return over the short rate.
    - `bond_maturities` [years]: the constant-maturity short and long nominal zero-coupon buckets.
    - `inflation_linked_maturity`, `credit_maturity` [years].
    - `asset_classes`: the classes the policy weights (`AssetClass`es; default
      `default_asset_classes` of the three maturities above).
    - `credit_loss_fraction`: share of the credit spread lost to defaults (the rest is earned).
    - `weight_low`, `weight_high`: per-class portfolio weight bounds, one per asset class in
      order; they must admit weights summing to 1 (default: the built-in six's).
    - `equity_names`: the indices' names, as factor names and reports show them (default
      "equity_0", "equity_1", ...).

    **Raises:** `InputError` naming the field for a bad correlation, negative speeds or
    maturities, or bounds that cannot sum to 1.
    """

    key_tenors: tuple[float, ...] = eqx.field(static=True)
    n_equities: int = eqx.field(static=True)
    cholesky_rows: tuple[tuple[float, ...], ...] = eqx.field(static=True)
    rate_mean_reversion: float = eqx.field(static=True)
    inflation_mean_reversion: float = eqx.field(static=True)
    spread_mean_reversion: float = eqx.field(static=True)
    equity_premium: float = eqx.field(static=True)
    asset_classes: tuple[AssetClass, ...] = eqx.field(static=True)
    credit_loss_fraction: float = eqx.field(static=True)
    weight_low: tuple[float, ...] = eqx.field(static=True)
    weight_high: tuple[float, ...] = eqx.field(static=True)
    equity_names: tuple[str, ...] = eqx.field(static=True)

    def __init__(
        self,
        tenors,
        n_equities: int,
        *,
        correlation=None,
        rate_mean_reversion: float = 0.1,
        inflation_mean_reversion: float = 0.5,
        spread_mean_reversion: float = 0.8,
        equity_premium: float = 0.04,
        bond_maturities: tuple[float, float] = (5.0, 30.0),
        inflation_linked_maturity: float = 20.0,
        credit_maturity: float = 7.0,
        credit_loss_fraction: float = 0.4,
        weight_low=None,
        weight_high=None,
        equity_names=None,
        asset_classes=None,
    ):
        tenors = check_range("tenors", tenors, 0.0, low_open=True)
        if tenors.ndim != 1 or np.any(np.diff(tenors) <= 0):
            raise InputError(f"tenors = {tenors} must be a strictly increasing 1-D array [years].")
        if not isinstance(n_equities, int) or n_equities < 1:
            raise InputError(f"n_equities = {n_equities!r} must be a positive integer.")
        if correlation is None:
            correlation = default_correlation(n_equities)
        size = len(driver_names(n_equities))
        correlation = check_correlation("correlation", correlation, size)
        for name, value in (("rate_mean_reversion", rate_mean_reversion),
                            ("inflation_mean_reversion", inflation_mean_reversion),
                            ("spread_mean_reversion", spread_mean_reversion)):
            check_range(name, value, 0.0, 50.0)
        check_range("equity_premium", equity_premium, -0.5, 0.5)
        check_range("bond_maturities", bond_maturities, MONTH, 100.0, low_open=True)
        check_range("inflation_linked_maturity", inflation_linked_maturity, MONTH, 100.0, low_open=True)
        check_range("credit_maturity", credit_maturity, MONTH, 100.0, low_open=True)
        classes = check_asset_classes(default_asset_classes(bond_maturities, inflation_linked_maturity, credit_maturity)
                                      if asset_classes is None else asset_classes)
        names = tuple(c.name for c in classes)
        if names == ASSETS:  # the built-in classes' bounds, where not given
            weight_low = (0.0,) * 6 if weight_low is None else weight_low
            weight_high = (0.3, 0.6, 0.9, 0.5, 0.3, 0.7) if weight_high is None else weight_high
        elif weight_low is None or weight_high is None:
            raise InputError(f"weight_low and weight_high: needed for the asset classes {list(names)}.")
        check_range("credit_loss_fraction", credit_loss_fraction, 0.0, 1.0)
        low = check_range("weight_low", weight_low, 0.0, 1.0)
        high = check_range("weight_high", weight_high, 0.0, 1.0)
        if low.shape != (len(names),) or high.shape != (len(names),):
            raise InputError(f"weight_low and weight_high need one entry per asset class {names}; got "
                             f"shapes {low.shape} and {high.shape}.")
        if np.any(high <= low):
            i = int(np.argmax(high <= low))
            raise InputError(f"weight_high[{i}] = {high[i]:g} must exceed weight_low[{i}] = "
                             f"{low[i]:g} ({names[i]}).")
        if not low.sum() < 1.0 < high.sum():
            raise InputError(f"weight bounds cannot sum to 1: sum(weight_low) = {low.sum():g} and "
                             f"sum(weight_high) = {high.sum():g}; allowed: sum(weight_low) < 1 < "
                             "sum(weight_high).")
        self.key_tenors = tuple(map(float, tenors))
        self.n_equities = n_equities
        self.cholesky_rows = tuple(map(tuple, cholesky_factor(correlation).tolist()))
        self.rate_mean_reversion = float(rate_mean_reversion)
        self.inflation_mean_reversion = float(inflation_mean_reversion)
        self.spread_mean_reversion = float(spread_mean_reversion)
        self.equity_premium = float(equity_premium)
        self.asset_classes = classes
        self.credit_loss_fraction = float(credit_loss_fraction)
        self.weight_low = tuple(map(float, low))
        self.weight_high = tuple(map(float, high))
        names = tuple(f"equity_{e}" for e in range(n_equities)) if equity_names is None else tuple(equity_names)
        if len(names) != n_equities or len(set(names)) != n_equities:
            raise InputError(f"equity_names = {list(names)}: expected {n_equities} distinct names.")
        self.equity_names = names

    @property
    def asset_names(self) -> tuple[str, ...]:
        """The asset classes' names, in the policy's order."""
        return tuple(c.name for c in self.asset_classes)

    @property
    def bond_classes(self) -> tuple[AssetClass, ...]:
        """The classes priced off the curve (kinds nominal, inflation_linked, credit), in order."""
        return tuple(c for c in self.asset_classes if c.maturity is not None)

    @property
    def tenors(self) -> np.ndarray:
        """Key-rate tenors [years], shape (n_tenors,)."""
        return np.array(self.key_tenors)

    @property
    def cholesky(self) -> np.ndarray:
        """Lower Cholesky factor of the driver correlation, shape (n_drivers, n_drivers)."""
        return np.array(self.cholesky_rows)

    @property
    def n_tenors(self) -> int:
        return len(self.key_tenors)

    @property
    def n_drivers(self) -> int:
        return len(self.cholesky_rows)

    def zero_rate_weights(self, maturities) -> np.ndarray:
        """Interpolation weights, shape (m, n_tenors), of the zero rates at `maturities` [years]."""
        return interpolation_weights(maturities, self.tenors)

    def loadings(self) -> np.ndarray:
        """Factor loadings of the key rates, shape (n_tenors, 3)."""
        return rate_loadings(self.tenors)


def correlated_shocks(market: Market, n_paths: int, n_months: int, key) -> jax.Array:
    """Common random numbers: standard normal shocks correlated by the market's driver
    correlation, shape (n_months, n_paths, n_drivers). The same key gives the same shocks, so an
    adjoint and a bump-and-revalue run see identical scenarios."""
    normals = jax.random.normal(key, (n_months, n_paths, market.n_drivers))
    return normals @ market.cholesky.T
