"""A price model from a file (`snapo gas --price-model FILE.yaml`): the model's name and its
parameters with their units, read through the one reading path for user files
(`snapo_ode.strict_yaml`), every error one line naming the file, the line and the field.

    model: two-factor            # one-factor | two-factor | three-factor
    short_mean_reversion: 9.0 /yr
    short_volatility: 60 %/sqrt(yr)
    long_volatility: 0.15 /sqrt(yr)
    correlation: -0.3

Units: a rate in `/yr` (also `/year`, `1/yr`) or `/day`; a volatility in `/sqrt(yr)` (also
`/sqrt(year)`) or `/sqrt(day)`, optionally in percent (`60 %/sqrt(yr)`); a correlation is a bare
number in [-1, 1]; a day in `days` (or a bare number). A bare number is read in the first unit
named (per year, per square-root year, days). The shipped examples are under finance/data/
(`price_model_one_factor.yaml`, `price_model_two_factor.yaml`, `price_model_three_factor.yaml`).
"""

import math
import os
import pathlib
import re
from importlib.resources import files

import jax.numpy as jnp

from snapo_ode import InputError, line_of, read_text, strict_yaml

from ._inputs import DAYS_PER_YEAR
from ._price_models import PRICE_MODELS, AbstractPriceModel

_RATE = {"/yr": 1.0, "/year": 1.0, "1/yr": 1.0, "1/year": 1.0, "/day": DAYS_PER_YEAR, "1/day": DAYS_PER_YEAR}
_VOLATILITY = {"/sqrt(yr)": 1.0, "/sqrt(year)": 1.0, "/sqrt(day)": math.sqrt(DAYS_PER_YEAR)}
# field -> (kind, low, high): the allowed range in the model's units (per year, per sqrt year, days)
_FIELDS = {
    "one-factor": {"mean_reversion": ("rate", 0.0, 1e4), "volatility": ("volatility", 0.0, 10.0)},
    "two-factor": {"short_mean_reversion": ("rate", 0.0, 1e4), "short_volatility": ("volatility", 0.0, 10.0),
                   "long_volatility": ("volatility", 0.0, 10.0), "correlation": ("correlation", -1.0, 1.0)},
    "three-factor": {"spot_mean_reversion": ("rate", 0.0, 1e4), "spot_volatility": ("volatility", 0.0, 10.0),
                     "long_volatility": ("volatility", 0.0, 10.0), "seasonal_volatility": ("volatility", 0.0, 10.0),
                     "peak_day": ("day", -1e4, 1e4)},
}
_ALLOWED = {"rate": "a number per year, such as '0.9 /yr' or '0.05 /day'",
            "volatility": "a number per square-root year, such as '0.6 /sqrt(yr)', '60 %/sqrt(yr)' or "
                          "'0.0315 /sqrt(day)'",
            "correlation": "a bare number", "day": "a number of days, such as '15 days'"}
_NUMBER = re.compile(r"\s*([-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?)\s*(.*?)\s*", re.ASCII)


def _value(raw, kind: str, where: str) -> float:
    """The number of `raw` (a YAML number or 'NUMBER UNIT') in the model's unit of `kind`."""
    if isinstance(raw, bool) or not isinstance(raw, (int, float, str)):
        raise InputError(f"{where} = {raw!r}; allowed: {_ALLOWED[kind]}.")
    if not isinstance(raw, str):
        number, unit = float(raw), ""
    else:
        match = _NUMBER.fullmatch(raw)
        if match is None:
            raise InputError(f"{where} = {raw!r} is not a number with a unit; allowed: {_ALLOWED[kind]}.")
        number, unit = float(match.group(1)), match.group(2).replace(" ", "")
    percent = unit.startswith("%") and kind == "volatility"
    unit = unit[1:] if percent else unit
    table = {"rate": _RATE, "volatility": _VOLATILITY, "correlation": {}, "day": {"days": 1.0, "day": 1.0}}[kind]
    if unit and unit not in table:
        raise InputError(f"{where} = {raw!r}: unknown unit {unit!r}; allowed: {_ALLOWED[kind]}.")
    return number * table.get(unit, 1.0) / (100.0 if percent else 1.0)


def load_price_model(path: str | os.PathLike) -> AbstractPriceModel:
    """The price model of a YAML file (module docstring).

    **Raises:** `InputError` (one line: file, line, field, the value's text and what is allowed)
    for an unknown model, a missing or unknown field, a unit that does not fit, a value outside
    its range, or anything the YAML reader refuses; before anything is compiled."""
    path = pathlib.Path(path)
    where = f"price-model file {path}"
    text = read_text(path, "price-model", 64 * 2**10)
    data = strict_yaml(text, where)
    if not isinstance(data, dict):
        raise InputError(f"{where}: a mapping of 'model' and its parameters is expected, not {type(data).__name__}.")
    name = data.get("model")
    if name not in PRICE_MODELS:
        raise InputError(f"{where}{line_of(text, ['model'])}: model = {name!r}; allowed: "
                         f"{', '.join(PRICE_MODELS)}.")
    fields = _FIELDS[name]
    for key in data:
        if key != "model" and key not in fields:
            raise InputError(f"{where}{line_of(text, [str(key)])}: {key} is no parameter of the {name} model; "
                             f"allowed: {', '.join(fields)}.")
    values = {}
    for field, (kind, low, high) in fields.items():
        at = f"{where}{line_of(text, [field])}: {field}"
        if field not in data:
            raise InputError(f"{where}: {field} is missing; the {name} model needs {', '.join(fields)}.")
        value = _value(data[field], kind, at)
        if not (math.isfinite(value) and low <= value <= high):
            raise InputError(f"{at} = {data[field]!r} ({value:g} in the model's unit); allowed: [{low:g}, {high:g}].")
        values[field] = jnp.asarray(value)
    return PRICE_MODELS[name](**values)


def sample_price_model(name: str) -> AbstractPriceModel:
    """The shipped example of the model `name` (one-factor, two-factor, three-factor)."""
    if name not in PRICE_MODELS:
        raise InputError(f"price model {name!r}; allowed: {', '.join(PRICE_MODELS)}.")
    return load_price_model(files("finance") / "data" / f"price_model_{name.replace('-', '_')}.yaml")
