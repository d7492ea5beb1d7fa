"""The named risk factors: their groups, their sizes for a wanted count N, default values and
the name of every entry.

Factors travel as a dict `{group: array}` (a pytree with named leaves), so one reverse pass gives a
sensitivity per entry and `bump_and_revalue` bumps the same entries. Units: rates, spreads and
volatilities per year (0.02 = 2%); cash flows and holdings in millions of the fund's currency
(cash flows per month); equity levels are index points (1.0 at the reference date).
"""

import math
from typing import NamedTuple

import numpy as np

from snapo_ode import InputError, check_finite, check_range

from ._assets import initial_prices
from ._liabilities import LiabilitySchedule, bucket_schedule, default_liability_cash_flows, initial_liability_value
from ._market import ASSETS, Market

GROUPS = (
    "key_rates",
    "rate_vols",
    "equity_levels",
    "equity_vols",
    "inflation",
    "inflation_vol",
    "spread",
    "spread_vol",
    "liability_cash_flows",
    "holdings",
)
# When N leaves fewer than `FULL_MINIMUM_LIABILITIES` liability buckets beside every other group,
# only these groups are reported; the volatilities and holdings stay fixed inputs.
MARKET_GROUPS = ("key_rates", "equity_levels", "inflation", "spread", "liability_cash_flows")
SCALAR_GROUPS = ("inflation", "inflation_vol", "spread", "spread_vol")
# On a given scenario set the volatilities are the set's, not inputs: these groups are reported,
# key rates, inflation and spread as shifts of every scenario (docs/alm.md, Scenarios from outside).
SCENARIO_GROUPS = (*MARKET_GROUPS, "holdings")
FULL_MINIMUM_LIABILITIES = 12
SMALLEST = 9


class FactorLayout(NamedTuple):
    """Sizes of the factor groups and which groups are reported (differentiated).

    `n_tenors` key rates, `n_equities` indices, `n_liability` liability buckets; `reported` in the
    order of `GROUPS`; `n_plain_assets`, the asset classes before the equity sleeve (holdings are
    one per such class and one per index)."""

    n_tenors: int
    n_equities: int
    n_liability: int
    reported: tuple[str, ...]
    n_plain_assets: int = len(ASSETS) - 1

    def size(self, group: str) -> int:
        sizes = dict(key_rates=self.n_tenors, rate_vols=self.n_tenors, equity_levels=self.n_equities,
                     equity_vols=self.n_equities, liability_cash_flows=self.n_liability,
                     holdings=self.n_plain_assets + self.n_equities)
        return sizes.get(group, 1)

    @property
    def n_risk_factors(self) -> int:
        """N: the number of reported factor entries."""
        return sum(self.size(group) for group in self.reported)


def layout_for(n_risk_factors: int) -> FactorLayout:
    """The layout with exactly `n_risk_factors` reported entries.

    Key rates grow as N/10 (5 to 50), equity indices as N/100 (1 to 20), and the liability grid
    takes the rest. Below N = 34 the volatilities and holdings are not reported (they stay fixed).

    **Raises:** `InputError` when `n_risk_factors` is below 9.
    """
    if not isinstance(n_risk_factors, (int, np.integer)) or n_risk_factors < SMALLEST:
        raise InputError(f"risk_factors = {n_risk_factors!r}; allowed: an integer >= {SMALLEST}.")
    n = int(n_risk_factors)
    n_equities = int(np.clip(n // 100, 1, 20))
    n_tenors = int(np.clip(n // 10, 5, 50))
    full = FactorLayout(n_tenors, n_equities, 0, GROUPS)
    fixed_part = full.n_risk_factors
    if n - fixed_part >= FULL_MINIMUM_LIABILITIES:
        return full._replace(n_liability=n - fixed_part)
    small = FactorLayout(n_tenors, n_equities, 0, MARKET_GROUPS)
    return small._replace(n_liability=n - small.n_risk_factors)


DEFAULT_MIX = dict(cash=0.05, bond_short=0.15, bond_long=0.30, inflation_linked=0.10, credit=0.10, equity=0.30)


def holdings_at_funding_ratio(factors: dict, market: Market, funding_ratio: float, mix: dict,
                              schedule: LiabilitySchedule | None = None, indexation: float | None = None,
                              credit: bool = True) -> np.ndarray:
    """Units held of each asset (each non-equity class in order, then each equity index), shape
    (classes - 1 + n_equities,), so that the fund starts at `funding_ratio` with the asset classes' values
    in the proportions `mix` (keys `market.asset_names`, summing to 1; the equity share split equally over the
    indices), its liabilities valued as the simulation values them at the start: on the initial
    curve, with the `indexation` share indexed (None: the indexation effect is off), the credit
    bucket at its spread (`credit`: the credit effect is on)."""
    liability = initial_liability_value(factors, market, schedule, indexation)
    values = funding_ratio * liability * np.array([mix[asset] for asset in market.asset_names])
    equity_value = values[-1] / market.n_equities
    return units_held(np.concatenate([values[:-1], np.full(market.n_equities, equity_value)]), factors, market, credit)


def units_held(values, factors: dict, market: Market, credit: bool) -> np.ndarray:
    """The units of each asset (each non-equity class in order, then each equity index) worth
    `values` [million], shape (classes - 1 + n_equities,), at the initial prices (the credit
    bucket at its spread when `credit`)."""
    prices = np.asarray(initial_prices(factors, market, credit=credit))
    plain = len(market.asset_names) - 1
    return np.asarray(values) / np.concatenate([prices[:plain], np.asarray(factors["equity_levels"])])


def default_factors(layout: FactorLayout, market: Market, *, funding_ratio: float = 1.1,
                    indexation: float | None = None, credit: bool = True) -> dict:
    """Plausible values of every factor group (reported or not) as float64 numpy arrays.

    The holdings are set so the fund starts at `funding_ratio` (its liabilities valued with the
    `indexation` share indexed, as the simulation values them; None: without indexation; the
    credit bucket at its spread when `credit`), in
    the mix `DEFAULT_MIX`: 5% cash, 15% short bonds, 30% long bonds, 10% inflation-linked, 10%
    credit, 30% equities.
    """
    tenors = market.tenors
    key_rates = 0.025 + 0.015 * (1.0 - np.exp(-tenors / 7.0))
    equities = np.arange(layout.n_equities)
    factors = dict(
        key_rates=key_rates,
        rate_vols=0.009 - 0.002 * tenors / tenors.max(),
        equity_levels=np.ones(layout.n_equities),
        equity_vols=0.15 + 0.06 * equities / max(layout.n_equities - 1, 1),
        inflation=np.array(0.02),
        inflation_vol=np.array(0.01),
        spread=np.array(0.012),
        spread_vol=np.array(0.004),
        liability_cash_flows=default_liability_cash_flows(layout.n_liability),
    )
    factors["holdings"] = holdings_at_funding_ratio(factors, market, funding_ratio, DEFAULT_MIX, indexation=indexation,
                                                    credit=credit)
    return factors


# The allowed range of each market group: (low, high, low_open).
MARKET_RANGES = dict(key_rates=(-0.1, 0.5, False), inflation=(-0.1, 0.5, False), spread=(0.0, 0.5, False),
                     rate_vols=(0.0, 2.0, False), equity_vols=(0.0, 2.0, False), inflation_vol=(0.0, 2.0, False),
                     spread_vol=(0.0, 2.0, False), equity_levels=(0.0, math.inf, True))


def check_market_ranges(factors: dict) -> None:
    """Check every market group of `factors` against `MARKET_RANGES`.

    **Raises:** `InputError` naming the group, the entry, the value and the allowed range."""
    for group, (low, high, low_open) in MARKET_RANGES.items():
        check_range(group, factors[group], low, high, low_open=low_open)


def check_factors(factors: dict, layout: FactorLayout) -> dict:
    """Validate every group's shape and range before anything is compiled; returns float64
    numpy arrays.

    **Raises:** `InputError` naming the group and entry for NaN, a wrong shape, negative
    volatilities, levels, cash flows or holdings, or rates outside (-10%, 50%).
    """
    checked = {}
    for group in GROUPS:
        if group not in factors:
            raise InputError(f"risk factor group {group!r} is missing; needed: {', '.join(GROUPS)}.")
        value = check_finite(group, factors[group])
        expected = () if group in SCALAR_GROUPS else (layout.size(group),)
        if value.shape != expected:
            raise InputError(f"{group} has shape {value.shape}; expected {expected}.")
        checked[group] = value
    check_market_ranges(checked)
    check_range("liability_cash_flows", checked["liability_cash_flows"], 0.0)
    check_range("holdings", checked["holdings"], 0.0)
    if checked["liability_cash_flows"].sum() <= 0:
        raise InputError("liability_cash_flows are all zero; the funding ratio needs liabilities.")
    return checked


def split_reported(factors: dict, layout: FactorLayout) -> tuple[dict, dict]:
    """`(reported, fixed)`: the groups whose sensitivities are reported, and the rest."""
    reported = {group: factors[group] for group in layout.reported}
    fixed = {group: factors[group] for group in GROUPS if group not in layout.reported}
    return reported, fixed


def tenor_label(tenor: float) -> str:
    """A key tenor [years] as factor names and report axes show it, 3 significant digits
    ("0.46y", "12.4y")."""
    return f"{tenor:.3g}y"


def factor_names(layout: FactorLayout, market: Market, schedule: LiabilitySchedule | None = None) -> dict[str, list[str]]:
    """The name of every entry of every group, in the order of `np.ravel(factors[group])`; the
    liability rows named by `schedule` (default `bucket_schedule(layout.n_liability)`), the
    equity indices by `market.equity_names`."""
    schedule = bucket_schedule(layout.n_liability) if schedule is None else schedule
    tenor_names = [tenor_label(t) for t in market.tenors]
    equities = list(market.equity_names)
    return dict(
        key_rates=[f"key_rate_{t}" for t in tenor_names],
        rate_vols=[f"rate_vol_{t}" for t in tenor_names],
        equity_levels=[f"{e}_level" for e in equities],
        equity_vols=[f"{e}_vol" for e in equities],
        inflation=["inflation"],
        inflation_vol=["inflation_vol"],
        spread=["spread"],
        spread_vol=["spread_vol"],
        liability_cash_flows=[f"liability_cash_flow_{name}" for name in schedule.names],
        holdings=[f"holding_{a}" for a in market.asset_names[:-1]] + [f"holding_{e}" for e in equities],
    )


def named_sensitivities(gradient: dict, layout: FactorLayout, market: Market,
                        schedule: LiabilitySchedule | None = None) -> dict[str, float]:
    """Flatten a gradient over the reported groups into `{factor name: value}` (names as
    `factor_names` gives them)."""
    names = factor_names(layout, market, schedule)
    out = {}
    for group in layout.reported:
        for name, value in zip(names[group], np.ravel(np.asarray(gradient[group])), strict=True):
            out[name] = float(value)
    return out
