"""Liabilities: monthly benefit cash flows on a schedule of rows (buckets of months, optionally
per cohort), a default from an age profile, and their value on the simulated curve.

Each cash flow is discounted at its own date on the curve interpolated from the key rates
(linear in maturity, flat beyond the ends): the flow paid j months ahead is worth
`exp(-y(j/12) * j/12)` per unit, `y` the interpolated zero rate, and an indexed flow also grows
to its date at the current inflation. The value's derivative with respect to a key rate goes
through the interpolation weights (the bucketed PV01). The cash flows outstanding at each
month-end depend on the flows only, not on the path, and are laid out once per evaluation.

`key_rate_profile` and `liability_value` keep the cash-flow mapping (each flow split onto its two
neighbouring key tenors and discounted there), an approximation the model no longer values by.
"""

from typing import NamedTuple

import jax
import jax.numpy as jnp
import numpy as np

from ._market import MONTH, Market, interpolation_weights

MINIMUM_RUN_OFF_MONTHS = 720
RETIREMENT_AGE = 67.0


def run_off_months(n_buckets: int) -> int:
    """Months covered by a grid of `n_buckets` buckets: monthly buckets once there are at least
    720 of them, else 720 months in equal buckets (each factor is that bucket's monthly benefit)."""
    return max(n_buckets, MINIMUM_RUN_OFF_MONTHS)


def bucket_of_month(n_buckets: int) -> np.ndarray:
    """The bucket paying in each month of the run-off, shape (run_off_months,); month 0 is paid
    at the end of the first month."""
    months = np.arange(run_off_months(n_buckets))
    return months * n_buckets // run_off_months(n_buckets)


def bucket_start_months(n_buckets: int) -> np.ndarray:
    """The first month (0-based) of each bucket, shape (n_buckets,)."""
    return np.searchsorted(bucket_of_month(n_buckets), np.arange(n_buckets))


class LiabilitySchedule(NamedTuple):
    """Which liability row pays in which month: the rows are the liability factors (one cash
    flow each [million/month], paid in every month the row covers) and their sensitivities.

    `payers`: for each layer, the row paying in each month of the run-off (`n_rows` where none
    does), shape (layers, run_off_months) as tuples (static under `jit`); several layers where
    rows overlap in time (cohorts). `names`: each row's name, as factor names end
    ("month_13", "month_13_cohort_active")."""

    payers: tuple[tuple[int, ...], ...]
    names: tuple[str, ...]

    @property
    def n_rows(self) -> int:
        return len(self.names)

    @property
    def run_off_months(self) -> int:
        return len(self.payers[0])

    def monthly(self, cash_flows) -> jnp.ndarray:
        """The benefit paid in each month of the run-off [million/month], shape (run_off_months,),
        from the rows' `cash_flows`, shape (n_rows,)."""
        cash_flows = jnp.asarray(cash_flows)
        padded = jnp.concatenate([cash_flows, jnp.zeros(1, cash_flows.dtype)])
        layers = np.asarray(self.payers)
        total = padded[layers[0]]
        for layer in layers[1:]:
            total = total + padded[layer]
        return total


def bucket_schedule(n_buckets: int) -> LiabilitySchedule:
    """The built-in fund's schedule: `n_buckets` buckets of about equal length over the run-off
    (`bucket_of_month`), one layer."""
    return LiabilitySchedule((tuple(int(b) for b in bucket_of_month(n_buckets)),),
                             tuple(f"month_{m + 1}" for m in bucket_start_months(n_buckets)))


def row_schedule(first_months, last_months, cohorts=None) -> LiabilitySchedule:
    """A schedule of rows paying from month `first_months[i]` to `last_months[i]` (1-based,
    inclusive), each of cohort `cohorts[i]` (None: one cohort); rows of one cohort must not
    overlap (checked by the reader of the file). Layers are filled greedily, so rows that do
    not overlap share one."""
    first, last = np.asarray(first_months, int), np.asarray(last_months, int)
    run_off = int(last.max())
    layers: list[np.ndarray] = []
    for row in np.argsort(first, kind="stable"):
        span = slice(first[row] - 1, last[row])
        layer = next((layer for layer in layers if np.all(layer[span] == len(first))), None)
        if layer is None:
            layer = np.full(run_off, len(first))
            layers.append(layer)
        layer[span] = row
    suffix = [""] * len(first) if cohorts is None else [f"_cohort_{cohort}" for cohort in cohorts]
    return LiabilitySchedule(tuple(tuple(int(r) for r in layer) for layer in layers),
                             tuple(f"month_{f}{s}" for f, s in zip(first, suffix)))


def gompertz_survival(age, years):
    """Probability of surviving `years` from `age` [years] under the Gompertz hazard
    5e-5 * exp(0.095 * age) per year (about 3% at 67, 26% at 90)."""
    a, b = 5e-5, 0.095
    return np.exp(-(a / b) * (np.exp(b * (age + years)) - np.exp(b * age)))


def default_liability_cash_flows(n_buckets: int, *, first_year_benefit: float = 4.0) -> np.ndarray:
    """Expected monthly benefits [million/month] of a fund with one member per age from 25 to 95,
    retirement at 67, 1.5% accrual per year of service from 25, Gompertz mortality; averaged per
    bucket, scaled so the first year pays `first_year_benefit` a month. Shape (n_buckets,).

    A long grid runs past the last survivor: its late buckets are zero, but their sensitivities
    (the value of one more unit of benefit then) are still defined and reported.
    """
    ages = np.arange(25.0, 96.0)
    pension = 0.015 * (np.minimum(ages, RETIREMENT_AGE) - 25.0)
    months = np.arange(1, run_off_months(n_buckets) + 1)
    years = months * MONTH
    alive = gompertz_survival(ages[:, None], years[None, :])
    retired = ages[:, None] + years[None, :] >= RETIREMENT_AGE
    monthly = np.sum(pension[:, None] * alive * retired, axis=0) / 12.0
    monthly *= first_year_benefit / monthly[:12].mean()
    buckets = bucket_of_month(n_buckets)
    return np.bincount(buckets, weights=monthly) / np.bincount(buckets)


def monthly_cash_flows(liability_cash_flows, schedule: LiabilitySchedule | None = None) -> jnp.ndarray:
    """Expand the rows' cash flows, shape (n_rows,), to one per month of the run-off, by
    `schedule` (default: `bucket_schedule` of as many buckets)."""
    if schedule is None:
        schedule = bucket_schedule(np.shape(liability_cash_flows)[0])
    return schedule.monthly(liability_cash_flows)


def cash_flow_maturities(run_off: int) -> np.ndarray:
    """The maturities [years] of the outstanding flows, one month to `run_off` months, shape
    (run_off,): a row of `outstanding_cash_flows` pays column j at (j + 1) / 12 years."""
    return np.arange(1, run_off + 1) * MONTH


def outstanding_cash_flows(liability_cash_flows, n_months: int,
                           schedule: LiabilitySchedule | None = None) -> jnp.ndarray:
    """The flows still to pay at each month-end t = 0..n_months, by maturity: row t, column j is
    the benefit paid j + 1 months after month-end t [million/month], shape (n_months + 1,
    run_off_months). Linear in the cash flows; `schedule` as in `monthly_cash_flows`."""
    monthly = monthly_cash_flows(liability_cash_flows, schedule)
    run_off = monthly.shape[0]
    padded = jnp.concatenate([monthly, jnp.zeros(n_months + 1, monthly.dtype)])
    return padded[np.arange(n_months + 1)[:, None] + np.arange(run_off)[None, :]]


def liability_value_at_dates(outstanding, key_rates, tenors, *, indexation=None):
    """Liability value [million] on each path: every outstanding flow discounted at its own date on
    the curve interpolated from the key rates.

    **Arguments:**
    - `outstanding`: one row of `outstanding_cash_flows`, shape (run_off,): the flow paid
      j + 1 months ahead in column j.
    - `key_rates`: the key rates, shape (paths, n_tenors) [1/year, continuously compounded].
    - `tenors` [years], shape (n_tenors,).
    - `indexation`: `None`, or `(fraction, cpi, inflation)`: that fraction of the benefits is
      indexed; an indexed flow tau years ahead is worth `cpi * exp(inflation * tau)` nominal per
      unit, with `cpi` (paths,) the price index since the start and `inflation` (paths,) the
      current rate [1/year].

    **Returns:** shape (paths,): sum_j outstanding_j exp(-y(tau_j) tau_j) (1 - f + f cpi
    exp(inflation tau_j)), y(tau) = (1 - a) r_left + a r_right the interpolated zero rate.
    """
    run_off = outstanding.shape[-1]
    maturities = cash_flow_maturities(run_off)
    # The interpolation as a product with the weights: its transpose is another product, where a
    # gather's is a scatter, several times slower in the reverse pass (measured, docs/alm.md).
    zero_rates = key_rates @ jnp.asarray(interpolation_weights(maturities, tenors).T)
    discount = jnp.exp(-zero_rates * maturities)
    if indexation is None:
        return discount @ outstanding
    fraction_indexed, cpi, inflation = indexation
    indexed = cpi[:, None] * _monthly_growth(inflation, run_off)
    return (discount * (1.0 - fraction_indexed + fraction_indexed * indexed)) @ outstanding


def _monthly_growth(inflation, run_off: int):
    """exp(inflation x m / 12) for m = 1..run_off on each path, shape (paths, run_off), from the
    growth over whole years times the growth within the year (m = 12 y + q): run_off / 12 + 12
    exponentials a path instead of run_off, equal to round-off."""
    years = jnp.exp(inflation[:, None] * np.arange(run_off // 12 + 1))
    within = jnp.exp(inflation[:, None] * np.arange(12) * MONTH)
    return (years[:, :, None] * within[:, None, :]).reshape(inflation.shape[0], -1)[:, 1:run_off + 1]


def key_rate_profile(liability_cash_flows, market: Market, n_months: int,
                     schedule: LiabilitySchedule | None = None) -> jnp.ndarray:
    """The outstanding cash flows mapped onto the key tenors at each month-end (cash-flow
    mapping), shape (n_months + 1, n_tenors): row t maps the flows paid after month t, at
    maturities (m - t) / 12 years, each split onto its two neighbouring key tenors by linear
    interpolation in maturity. Linear in the cash flows; `schedule` as in `monthly_cash_flows`.
    An approximation: the model values each flow at its own date (`liability_value_at_dates`)."""
    outstanding = outstanding_cash_flows(liability_cash_flows, n_months, schedule)
    mapping = interpolation_weights(cash_flow_maturities(outstanding.shape[1]), market.tenors)
    return outstanding @ mapping


def liability_value(profile_row, key_rates, tenors, *, indexation=None):
    """The value [million] on each path of cash flows mapped onto the key tenors
    (`key_rate_profile`), each tenor's amount discounted at its key rate: the cash-flow-mapping
    approximation, kept for comparison; the model values by `liability_value_at_dates`.

    **Arguments:**
    - `profile_row`: one row of `key_rate_profile`, shape (n_tenors,).
    - `key_rates`: the simulated key rates, shape (paths, n_tenors).
    - `tenors` [years], shape (n_tenors,).
    - `indexation`: `None`, or `(fraction, cpi, inflation)`: that fraction of the benefits is
      indexed; it is worth `cpi * exp(inflation * tenor)` per unit, with `cpi` (paths,) the price
      index since the start and `inflation` (paths,) the current rate [1/year].
    """
    discount = jnp.exp(-key_rates * tenors)
    if indexation is None:
        return discount @ profile_row
    fraction, cpi, inflation = indexation
    indexed = cpi[:, None] * jnp.exp(inflation[:, None] * tenors)
    return (discount * (1.0 - fraction + fraction * indexed)) @ profile_row


def starting_liability_value(factors: dict, market: Market, schedule: LiabilitySchedule | None = None,
                             indexation: float | None = None):
    """The liability value [million] on the initial curve, as the simulation values it at the
    start (`liability_value_at_dates`): with `indexation` (the indexed share of the benefits,
    growing at the initial inflation), or without (None); a traceable scalar."""
    outstanding = outstanding_cash_flows(factors["liability_cash_flows"], 0, schedule)[0]
    rates = jnp.asarray(factors["key_rates"])[None, :]
    indexed = None if indexation is None else (indexation, jnp.ones(1), jnp.reshape(factors["inflation"], (1,)))
    return liability_value_at_dates(outstanding, rates, market.tenors, indexation=indexed)[0]


def initial_liability_value(factors: dict, market: Market, schedule: LiabilitySchedule | None = None,
                            indexation: float | None = None) -> float:
    """`starting_liability_value` as a host float [million]."""
    return float(starting_liability_value(factors, market, schedule, indexation))


def liability_duration_as_valued(factors: dict, market: Market, schedule: LiabilitySchedule | None = None,
                                 indexation: float | None = None) -> float:
    """The liabilities' duration [years] as the simulation values them at the start: -dL/ds / L
    for a parallel shift s of every key rate (forward-mode AD through `starting_liability_value`,
    the indexed share included). With continuous compounding it is the present-value-weighted
    mean date of the valued flows (their Macaulay duration)."""
    rates = jnp.asarray(factors["key_rates"])

    def value(shift):
        return starting_liability_value({**factors, "key_rates": rates + shift}, market, schedule, indexation)

    level, slope = jax.jvp(value, (jnp.zeros(()),), (jnp.ones(()),))
    return float(-slope / level)
