"""A fund's liabilities from a CSV file: benefit cash flows per month, per year, per bucket of
months or per payment date, optionally per cohort, in the unit the fund file names.

Columns (a header row, then one row per cash flow; names case-sensitive):
- the period, one of: `month` (1-based: month 1 ends one month after the valuation date), `year`
  (year 1 is months 1-12), `first_month` and `last_month` (a bucket, inclusive), or `date`
  (ISO 8601, paid in the month that contains it; needs the fund's `valuation_date`);
- `cash_flow`: the benefit paid per unit of time of `cash_flow_unit` over the row's period
  (per month: each of its months pays this; per year: each month pays a twelfth);
- optional `cohort`: a name; rows of one cohort may not overlap in time, rows of different
  cohorts may.
Read with pandas, every cell as text and checked here. Each row becomes one liability factor (its sensitivity: the objective's change per unit of the
model's million/month paid over the row's months).
"""

import datetime
import io
import math
import os
import re
import warnings
from typing import NamedTuple

import numpy as np
import pandas as pd

from snapo_ode import InputError, number_text, read_text, whole_text

from ._liabilities import LiabilitySchedule, row_schedule
from ._units import per_month_in_millions

PERIODS = (("month",), ("year",), ("first_month", "last_month"), ("date",))
MAX_RUN_OFF_MONTHS = 1_800  # 150 years


class Liabilities(NamedTuple):
    """The rows of a liability file: `cash_flows` [million/month], shape (rows,), and the
    `schedule` saying which months each row pays in."""

    cash_flows: np.ndarray
    schedule: LiabilitySchedule


def _months_of(period: str, row: dict, where: str, valuation_date: datetime.date | None) -> tuple[int, int]:
    if period == "date":
        if valuation_date is None:
            raise InputError(f"{where}: a 'date' column needs the fund file's liabilities.valuation_date.")
        try:
            day = datetime.date.fromisoformat(row["date"].strip())
        except ValueError:
            raise InputError(f"{where}: date = {row['date']!r} is not an ISO date (such as 2031-06-30).") from None
        month = (day.year - valuation_date.year) * 12 + day.month - valuation_date.month + (
            day.day > valuation_date.day)
        if day <= valuation_date:
            raise InputError(f"{where}: date = {row['date']} is not after the valuation date {valuation_date}.")
        return month, month
    numbers = {}
    for column in PERIODS[[p[0] for p in PERIODS].index(period)]:
        numbers[column] = whole_text(row[column], where, column, low=1)
    if period == "month":
        return numbers["month"], numbers["month"]
    if period == "year":
        return 12 * numbers["year"] - 11, 12 * numbers["year"]
    if numbers["last_month"] < numbers["first_month"]:
        raise InputError(f"{where}: last_month = {numbers['last_month']} is before first_month = "
                         f"{numbers['first_month']}.")
    return numbers["first_month"], numbers["last_month"]


def load_liabilities(path: str | os.PathLike, cash_flow_unit: str = "million / month", *,
                     valuation_date: datetime.date | None = None, currency: str = "EUR") -> Liabilities:
    """Read a liability CSV (see the module docstring); `cash_flow_unit` is the unit of its
    `cash_flow` column (a money amount per time, "million / month", "EUR / year", ...; in the
    fund's `currency`).

    **Raises:** `InputError` naming the file, the line, the column and the value for a wrong
    header, a value that is not a number, a negative cash flow, overlapping rows of one cohort, a
    run-off past 150 years, or no positive cash flow."""
    scale = per_month_in_millions(cash_flow_unit, "liabilities.cash_flow_unit", currency)
    # Every cell as text, checked below; blank lines kept, so a row's line is its index + 2; a row
    # longer than the header is refused (pandas would drop its extra cells with a warning).
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("error", pd.errors.ParserWarning)
            table = pd.read_csv(io.StringIO(read_text(path, "liability")), dtype=str, keep_default_na=False,
                                skip_blank_lines=False, skipinitialspace=True, index_col=False)
    except (pd.errors.ParserError, pd.errors.EmptyDataError, pd.errors.ParserWarning) as error:
        raise InputError(f"liability file {path}: not a CSV table ({' '.join(str(error).split())}).") from None
    header = [str(name).strip() for name in table.columns]
    table.columns = header
    period = next((p for p in PERIODS if all(column in header for column in p)), None)
    allowed = {"cash_flow", "cohort", *(column for p in PERIODS for column in p)}
    unknown = [column for column in header if column not in allowed]
    if period is None or "cash_flow" not in header or unknown or sum(p[0] in header for p in PERIODS) > 1:
        raise InputError(f"liability file {path}, line 1: header {header}; expected 'cash_flow', one period "
                         "('month', 'year', 'first_month,last_month' or 'date') and optionally 'cohort'.")
    flows, first, last, cohorts, lines = [], [], [], [], []
    for index, row in enumerate(table.to_dict("records")):
        if all(not value.strip() for value in row.values()):
            continue
        where = f"liability file {path}, line {index + 2}"
        flow = number_text(row["cash_flow"], where, "cash_flow")
        if not 0 <= flow < math.inf:
            raise InputError(f"{where}: cash_flow = {row['cash_flow']!r}; allowed: a finite decimal number >= 0.")
        start, end = _months_of(period[0], row, where, valuation_date)
        if end > MAX_RUN_OFF_MONTHS:
            raise InputError(f"{where}: the row pays in month {end}; allowed: up to {MAX_RUN_OFF_MONTHS} "
                             "(150 years).")
        cohort = row.get("cohort", "").strip()
        if "cohort" in header and not re.fullmatch(r"[A-Za-z0-9_]{1,40}", cohort):
            raise InputError(f"{where}: cohort = {row['cohort']!r}; allowed: a name of letters, digits and _ (it "
                             "becomes part of the factor names).")
        flows.append(flow * scale)
        first.append(start)
        last.append(end)
        cohorts.append(cohort)
        lines.append(index + 2)
    if not flows or max(flows) <= 0:
        raise InputError(f"liability file {path}: no positive cash_flow; the funding ratio needs liabilities.")
    _refuse_overlaps(path, first, last, cohorts, lines)
    return Liabilities(np.asarray(flows), row_schedule(first, last, cohorts if "cohort" in header else None))


def _refuse_overlaps(path, first, last, cohorts, lines) -> None:
    for cohort in dict.fromkeys(cohorts):
        rows = sorted((f, l, line) for f, l, c, line in zip(first, last, cohorts, lines) if c == cohort)
        for (f0, l0, i0), (f1, _, i1) in zip(rows, rows[1:]):
            if f1 <= l0:
                label = f" of cohort {cohort!r}" if cohort else ""
                raise InputError(f"liability file {path}, line {i1}: the row{label} pays from month {f1}, which the "
                                 f"row on line {i0} already covers (months {f0}-{l0}); add a 'cohort' column for "
                                 "rows that overlap.")
