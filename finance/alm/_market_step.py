"""The market a month on, on every path: generated (the Vasicek rates, inflation and spread of
`_market.py` driven by the month's correlated shocks) or read from a given scenario set and
shifted by the factors. `simulate` and the scenario writer share these steps."""

import jax.numpy as jnp
import numpy as np

from ._assets import MarketState
from ._market import MONTH, RATE_DRIVERS, Market


def next_market(state: MarketState, shock, factors: dict, market: Market, credit: bool) -> MarketState:
    """The generated market a month after `state`, from the month's correlated `shock` (paths,
    drivers): key rates, inflation and (with `credit`) the spread revert to their initial values
    (`factors`) as Vasicek processes; the price index accrues the month's inflation."""
    n_rate = len(RATE_DRIVERS)
    rate_shocks = shock[:, :n_rate] @ jnp.asarray(market.loadings()).T
    key_rates0 = jnp.asarray(factors["key_rates"])
    key_rates = state.key_rates + (
        market.rate_mean_reversion * (key_rates0 - state.key_rates) * MONTH
        + factors["rate_vols"] * np.sqrt(MONTH) * rate_shocks)
    inflation = state.inflation + (
        market.inflation_mean_reversion * (jnp.asarray(factors["inflation"]) - state.inflation) * MONTH
        + factors["inflation_vol"] * np.sqrt(MONTH) * shock[:, -2])
    spread = state.spread
    if credit:
        spread = spread + (market.spread_mean_reversion * (jnp.asarray(factors["spread"]) - spread) * MONTH
                           + factors["spread_vol"] * np.sqrt(MONTH) * shock[:, -1])
    return MarketState(key_rates, inflation, state.cpi * jnp.exp(state.inflation * MONTH), spread)


def scenario_state(values, origin, factors: dict, credit: bool, years, n_tenors: int) -> MarketState:
    """The market of a given scenario at `years` [years] after the start: `values` and
    `origin`, the scenario's variables then and at the start, shape (paths, n_tenors +
    n_equities + 3) (`_scenario_file.variable_names`). Shifted by the factors: key rates,
    inflation and (with `credit`) the spread by the factor's difference to the scenario's start,
    the price index by exp(inflation shift x years). Equity levels scale an index's whole path,
    so they leave its returns alone."""
    k = n_tenors
    rates, cpi, inflation, spread = values[:, :k], values[:, -3], values[:, -2], values[:, -1]
    inflation_shift = jnp.asarray(factors["inflation"]) - origin[:, -2]
    spread0 = jnp.asarray(factors["spread"])
    return MarketState(rates + (jnp.asarray(factors["key_rates"]) - origin[:, :k]), inflation + inflation_shift,
                       cpi / origin[:, -3] * jnp.exp(inflation_shift * years),
                       spread + (spread0 - origin[:, -1]) if credit else jnp.broadcast_to(spread0, spread.shape))
