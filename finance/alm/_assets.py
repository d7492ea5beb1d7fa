"""Assets: the market's asset classes (`Market.asset_classes`; by default cash, constant-maturity
nominal zero-coupon buckets (short and long), an inflation-linked zero-coupon bond, a credit
bucket and an equity sleeve over the indices), all priced off the simulated curve.

A bond bucket of maturity tau is held for a month and rolled: its gross return is
P_{t+1}(tau - 1/12) / P_t(tau) with P_t(tau) = exp(-y_t(tau) * tau) and y the bucket's yield.
"""

from typing import NamedTuple

import jax
import jax.numpy as jnp
import numpy as np

from ._market import MONTH, Market


class MarketState(NamedTuple):
    """The simulated market on every path at one month-end.

    `key_rates` (paths, n_tenors) [1/year]; `inflation` (paths,) [1/year]; `cpi` (paths,) the price
    index, 1 at the start; `spread` (paths,) [1/year]."""

    key_rates: jax.Array
    inflation: jax.Array
    cpi: jax.Array
    spread: jax.Array


def zero_rate(key_rates, market: Market, maturity: float):
    """The zero rate [1/year] at `maturity` [years] by linear interpolation; shape (paths,)."""
    return key_rates @ jnp.asarray(market.zero_rate_weights(maturity)[0])


def _bucket_yields(state: MarketState, market: Market, shortening: float, credit: bool):
    """Yields of the bond classes (`Market.bond_classes`: nominal; inflation-linked, real;
    credit, plus the spread when `credit`) at their maturities minus `shortening` [years],
    stacked (paths, n_bonds), with those maturities (n_bonds,)."""
    bonds = market.bond_classes
    maturities = np.array([c.maturity for c in bonds]) - shortening
    weights = jnp.asarray(market.zero_rate_weights(maturities))
    yields = state.key_rates @ weights.T
    columns = []
    for k, c in enumerate(bonds):
        if c.kind == "inflation_linked":
            columns.append(yields[:, k] - state.inflation)
        elif c.kind == "credit" and credit:
            columns.append(yields[:, k] + state.spread)
        else:
            columns.append(yields[:, k])
    return jnp.stack(columns, axis=1), maturities


def _in_class_order(market: Market, cash, bonds) -> jax.Array:
    """Per-class columns of the non-equity classes in their order, from the cash column (paths,)
    and the bond classes' (paths, n_bonds)."""
    columns, next_bond = [], 0
    for c in market.asset_classes[:-1]:
        if c.kind == "cash":
            columns.append(cash)
        else:
            columns.append(bonds[:, next_bond])
            next_bond += 1
    return jnp.stack(columns, axis=1)


def initial_prices(factors: dict, market: Market, *, credit: bool) -> jax.Array:
    """Prices per unit held at the start, shape (non-equity classes + n_equities,): each
    non-equity class in order (cash 1, a bond class per unit of face value, real face for
    inflation-linked), then the equity index levels."""
    rates = jnp.asarray(factors["key_rates"])[None, :]
    state = MarketState(rates, jnp.reshape(factors["inflation"], (1,)), jnp.ones(1),
                        jnp.reshape(factors["spread"], (1,)))
    yields, maturities = _bucket_yields(state, market, 0.0, credit)
    bonds = jnp.exp(-yields * maturities)
    return jnp.concatenate([_in_class_order(market, jnp.ones(1), bonds)[0], jnp.asarray(factors["equity_levels"])])


def _cash_and_bond_returns(before: MarketState, after: MarketState, market: Market, *, credit: bool) -> jax.Array:
    """Gross monthly returns of the non-equity classes in their order, shape (paths, classes - 1)."""
    short_rate = zero_rate(before.key_rates, market, MONTH)
    cash = jnp.exp(short_rate * MONTH)
    yields_now, maturities = _bucket_yields(before, market, 0.0, credit)
    yields_next, _ = _bucket_yields(after, market, MONTH, credit)
    log_bonds = yields_now * maturities - yields_next * (maturities - MONTH)
    inflation_accrual = jnp.log(after.cpi / before.cpi)
    for k, c in enumerate(market.bond_classes):
        if c.kind == "inflation_linked":
            log_bonds = log_bonds.at[:, k].add(inflation_accrual)
        if c.kind == "credit" and credit:
            log_bonds = log_bonds.at[:, k].add(-market.credit_loss_fraction * before.spread * MONTH)
    return _in_class_order(market, cash, jnp.exp(log_bonds))


def index_growth(before: MarketState, equity_shocks, equity_vols, market: Market) -> jax.Array:
    """Each equity index's gross monthly total return, shape (paths, n_equities): GBM with drift
    the short rate plus the equity premium."""
    short_rate = zero_rate(before.key_rates, market, MONTH)
    drift = (short_rate[:, None] + market.equity_premium - 0.5 * equity_vols**2) * MONTH
    return jnp.exp(drift + equity_vols * jnp.sqrt(MONTH) * equity_shocks)


def gross_returns(before: MarketState, after: MarketState, equity_shocks, equity_vols,
                  market: Market, *, credit: bool) -> jax.Array:
    """Gross monthly returns of the asset classes on every path, shape (paths, classes).

    **Arguments:** the market at the start and end of the month; `equity_shocks` (paths,
    n_equities) standard normal; `equity_vols` (n_equities,) [1/sqrt(year)]; `credit`: whether
    the credit bucket earns its spread and loses `credit_loss_fraction` of it to defaults (else
    it is a nominal bucket of the credit maturity).
    """
    equity = jnp.mean(index_growth(before, equity_shocks, equity_vols, market), axis=1)
    return jnp.concatenate([_cash_and_bond_returns(before, after, market, credit=credit), equity[:, None]], axis=1)


def scenario_returns(before: MarketState, after: MarketState, index_ratio, market: Market, *,
                     credit: bool) -> jax.Array:
    """As `gross_returns`, on a given scenario: the equity sleeve earns the mean of the indices'
    total-return ratios `index_ratio` (paths, n_equities) over the month."""
    equity = jnp.mean(index_ratio, axis=1)
    return jnp.concatenate([_cash_and_bond_returns(before, after, market, credit=credit), equity[:, None]], axis=1)
