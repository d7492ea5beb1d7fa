"""`snapo report gas --out DIR`: the storage desk's report. The value with hard and smooth
constraints against the intrinsic LP (and, with `--lsmc`, least-squares Monte Carlo, perfect
foresight and, where the comparison provides it, the information-relaxation dual upper bound),
the monthly delta ladder, the schedule and the facility sensitivities. This module computes the
JSON's data; `_report_content` says what is shown; the core writes the files.

The LSMC comparison's optional fields (`OPTIONAL_LSMC`: the dual bound, the duality gaps, the
control-variate values, LSMC's pathwise deltas) are read only when the result has them.
"""

import calendar
import datetime

import numpy as np

import snapo_ode
from snapo_ode import Report

from ._inputs import FACILITY_FIELDS

OPTIONAL_LSMC = ("dual_upper_bound", "dual_upper_bound_se", "lsmc_pathwise_deltas", "snapo_gap", "snapo_gap_se",
                 "lsmc_gap", "lsmc_gap_se", "snapo_value_control_variate", "snapo_value_control_variate_se",
                 "lsmc_value_control_variate", "lsmc_value_control_variate_se")
UNITS = {"capacity": "MMBtu", "initial_inventory": "MMBtu", "terminal_inventory_min": "MMBtu",
         "max_injection": "MMBtu/day", "max_withdrawal": "MMBtu/day", "fuel_loss": "fraction",
         "injection_cost": "$/MMBtu", "withdrawal_cost": "$/MMBtu", "rate": "per year",
         "injection_ratchet": "fraction", "withdrawal_ratchet": "fraction"}
DEFAULT_CURRENCY, DEFAULT_ENERGY_UNIT = "USD", "MMBtu"  # the built-in samples' (Henry Hub) units
# Each facility input as a desk names it; a ratchet's row k is its point k + 1, [fill level, rate].
INPUT_NAMES = {"capacity": "working gas capacity", "initial_inventory": "inventory at the start",
               "terminal_inventory_min": "minimum inventory at the end", "max_injection": "maximum injection rate",
               "max_withdrawal": "maximum withdrawal rate", "fuel_loss": "fuel loss on injection",
               "injection_cost": "injection cost", "withdrawal_cost": "withdrawal cost", "rate": "discount rate",
               "injection_ratchet": "injection ratchet", "withdrawal_ratchet": "withdrawal ratchet"}
RATCHET_COLUMNS = ("fill level", "rate")


def unit_of(field: str, currency: str, energy_unit: str) -> str:
    """The unit of a facility input in the report's currency and energy unit."""
    return UNITS.get(field, "").replace("$", currency + " ").replace("MMBtu", energy_unit).replace(" /", "/")


def input_name(name: str) -> str:
    """A facility input's name as a desk reads it: "injection_ratchet[1][0]" -> "injection
    ratchet, point 2, fill level"."""
    field, _, index = name.partition("[")
    words = INPUT_NAMES.get(field, field.replace("_", " "))
    if not index:
        return words
    row, *column = (int(i) for i in index.replace("]", " ").replace("[", " ").split())
    return f"{words}, point {row + 1}" + (f", {RATCHET_COLUMNS[column[0]]}" if column else "")


def months(n_days: int, start: datetime.date | None) -> list[dict]:
    """Calendar months of the days 0..n_days-1 from `start` (label "2005-07"); without a start,
    the months of a non-leap year from January, labelled "month 1 (days 0-30)"."""
    out, day = [], 0
    date = start or datetime.date(2025, 1, 1)  # a non-leap year: month lengths only
    while day < n_days:
        length = calendar.monthrange(date.year, date.month)[1] - (date.day - 1)
        last = min(day + length, n_days) - 1
        label = f"{date:%Y-%m}" if start else f"month {len(out) + 1} (days {day}-{last})"
        name = f"{date:%b %Y}" if start else f"month {len(out) + 1}"
        out.append({"month": label, "month_name": name, "first_day": day, "last_day": last})
        day = last + 1
        date = (date.replace(day=1) + datetime.timedelta(days=32)).replace(day=1)
    return out


def ladder(data: dict, start: datetime.date | None) -> list[dict]:
    """The monthly delta ladder: per month, the sum of the daily deltas (d value / d F_t: the
    value's change per $/MMBtu on every day of the month, in MMBtu), of the LP's envelope
    deltas and, when present, LSMC's pathwise deltas; and the month's mean injection,
    withdrawal and end-of-month inventory of the hard schedule."""
    deltas, lp = np.asarray(data["deltas"]), np.asarray(data["lp_envelope_deltas"])
    lsmc = np.asarray(data["lsmc_pathwise_deltas"]) if "lsmc_pathwise_deltas" in data else None
    schedule = {key: np.asarray(value) for key, value in data["schedule"].items()}
    rows = []
    for month in months(deltas.size, start):
        days = slice(month["first_day"], month["last_day"] + 1)
        rows.append({**month, "delta": float(deltas[days].sum()), "lp_delta": float(lp[days].sum()),
                     "lsmc_delta": None if lsmc is None else float(lsmc[days].sum()),
                     "injection": float(schedule["injection"][days].sum()),
                     "withdrawal": float(schedule["withdrawal"][days].sum()),
                     "end_inventory": float(schedule["inventory"][month["last_day"] + 1])})
    return rows


def facility_sensitivities(data: dict, inputs, currency: str = DEFAULT_CURRENCY,
                           energy_unit: str = DEFAULT_ENERGY_UNIT) -> list[dict]:
    """Each facility input's value, d value / d input, and the value's change for +1% of it;
    `name` as a desk reads it and `unit` in the report's currency and energy unit."""
    rows = []
    for name, sensitivity in data["parameter_sensitivities"].items():
        field, _, index = name.partition("[")
        array = np.asarray(getattr(inputs, field))
        value = float(array[tuple(int(i) for i in index.replace("]", " ").replace("[", " ").split())]) if index \
            else float(array)
        rows.append({"input": name, "name": input_name(name), "unit": unit_of(field, currency, energy_unit),
                     "value": value, "sensitivity": sensitivity,
                     "per_percent": sensitivity * value * 0.01 + 0.0})  # + 0.0: no "-0" in the table
    return rows


def build_gas_report(inputs, settings, *, lsmc: bool = False, nodes: int = 101, degree: int = 3,
                     foresight_paths: int = 256, start: datetime.date | None = None,
                     start_source: str | None = None, currency: str = DEFAULT_CURRENCY,
                     energy_unit: str = DEFAULT_ENERGY_UNIT) -> dict:
    """Every number of the gas report, as the JSON document's data (see docs/gas_storage.md):
    the contract starts on `start` (where it came from: `start_source`, words), money in
    `currency`, energy in `energy_unit` (labels only: the model uses the curve's units as given)."""
    import time

    from ._study import run_study
    from ._versus_lsmc import compare_with_lsmc

    began = time.perf_counter()
    if lsmc:
        result = compare_with_lsmc(inputs, settings, nodes=nodes, degree=degree, foresight_paths=foresight_paths)
        study = result.study
    else:
        result = study = run_study(inputs, settings)
    data = result.to_json()
    data.update(
        lsmc_run=bool(lsmc), has_dual_bound="dual_upper_bound" in data,
        start_date=None if start is None else start.isoformat(), start_date_source=start_source,
        currency=currency, energy_unit=energy_unit, price_unit=f"{currency}/{energy_unit}",
        forward_curve=np.asarray(inputs.forward_curve).tolist(),
        lp_schedule={"injection": np.asarray(study.intrinsic.injection).tolist(),
                     "withdrawal": np.asarray(study.intrinsic.withdrawal).tolist(),
                     "inventory": np.asarray(study.intrinsic.inventory).tolist()},
        facility={field: np.asarray(getattr(inputs, field)).tolist() for field in FACILITY_FIELDS},
    )
    for key in ("value_hard_se", "value_smooth_se"):  # left out of a deterministic study's JSON
        data.setdefault(key, None)
    data["scene_text"] = ", ".join(data["scene"])
    data["monthly_ladder"] = ladder(data, start)
    largest = max(data["monthly_ladder"], key=lambda row: abs(row["delta"]))
    data["largest_month"] = {"month": largest["month"], "month_name": largest["month_name"], "delta": largest["delta"]}
    data["ladder_totals"] = {key: float(sum(r[key] for r in data["monthly_ladder"])) for key in ("delta", "lp_delta")}
    data["facility_sensitivities"] = facility_sensitivities(data, inputs, currency, energy_unit)
    if data.get("max_rel_diff") is not None:
        data["max_rel_diff_ppm"] = data["max_rel_diff"] * 1e6  # for a reader, in parts per million
    data["report_seconds"] = time.perf_counter() - began
    return data


def gas_report(data: dict, provenance: dict) -> Report:
    from ._report_content import sections

    return Report(name="gas", title="Natural-gas storage: value, delta ladder and sensitivity report", data=data,
                  provenance=provenance, sections=sections(data),
                  subtitle=("Mode ", snapo_ode.Value(("mode",)), ", computed at ",
                            snapo_ode.Value(("provenance", "timestamp_utc")), "."),
                  csv={"deltas.csv": [["day", "forward_price", "delta", "lp_envelope_delta"]]
                       + [[day, price, delta, lp] for day, (price, delta, lp) in
                          enumerate(zip(data["forward_curve"], data["deltas"], data["lp_envelope_deltas"], strict=True))]})


def report_provenance(inputs, settings, command=None) -> dict:
    curve = np.asarray(inputs.forward_curve)
    facility = {field: np.asarray(getattr(inputs, field)).tolist() for field in FACILITY_FIELDS}
    market = {"volatility": float(inputs.volatility), "mean_reversion": float(inputs.mean_reversion)}
    fields = {k: v for k, v in vars(settings).items() if k not in ("checkpoint_path", "progress")}
    return snapo_ode.provenance({"forward_curve": curve.tobytes(), "facility": facility, "market": market,
                                 "settings": fields}, command=command)
