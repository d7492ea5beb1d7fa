"""Scenario sets from outside (an economic scenario generator's output) and the built-in
generator's scenarios written in the same format.

A file holds, per scenario and time, these variables (names case-sensitive):
- `zero_rate_<tenor>`: the zero rate [1/year, continuously compounded] at `<tenor>` years (any
  tenors, at least one; interpolated linearly onto the fund's key tenors, flat beyond the ends);
- `equity_<name>`: the total-return index of the fund's equity index `<name>` (any level);
- `cpi`: the price index (any level);
- `inflation` (optional): the expected inflation rate [1/year] that indexed benefits grow at;
  without it, the price index's annualised growth over the step ahead (the last step's at the
  end; at time 0 the set's mean over its first step, so that every scenario starts alike);
- `spread` (optional): the credit spread [1/year]; without it, the fund's own, constant.
Times are in years from the valuation date, from 0, at monthly (1/12) or annual (1) steps,
reaching the study's horizon; annual steps are filled in monthly, linearly for rates and
log-linearly for the indices.

Formats (by the file's extension): `.csv` and `.parquet`, long tables with the columns
`scenario, time, variable, value` (every scenario, time and variable exactly once, in any
order); `.npz`, the arrays `values` (scenarios x times x variables), `times` (years) and
`variables` (names).
"""

import io
import os
import pathlib
import re
import zipfile
from typing import NamedTuple

import numpy as np
import pandas as pd

from snapo_ode import DECIMAL, InputError, check_npz, check_parquet, read_text
from snapo_ode._platform.reading import MAX_NUMBER_CHARS

from ._market import MONTH, Market, interpolation_weights

LONG_COLUMNS = ["scenario", "time", "variable", "value"]
MAX_SCENARIO_BYTES = 2 * 2**30
MAX_SCENARIO_VALUES = 2**27  # values (scenarios x times x variables) a file may declare: 1 GiB of float64
INDEX_FACTOR = dict(cpi=1e3, equity=1e4)  # how far an index may move from its value at time 0, either way
RATE_BOUND = 1.0  # inflation and spread within [-1, 1] per year
_TENOR = re.compile(r"zero_rate_(\d+(\.\d*)?|\.\d+)$")


class ScenarioSet(NamedTuple):
    """A scenario set in the model's layout: `values`, shape (months + 1, scenarios, n_tenors +
    n_equities + 3) (`variable_names`), month 0 the start, monthly to the horizon; and the file
    it came from."""

    values: np.ndarray
    source: str

    @property
    def n_scenarios(self) -> int:
        return self.values.shape[1]

    @property
    def months(self) -> int:
        return self.values.shape[0] - 1


def variable_names(market: Market) -> list[str]:
    """The variables of the model's layout, in order: the fund's key tenors, its equity indices,
    then `cpi`, `inflation`, `spread`."""
    return ([f"zero_rate_{float(t)!r}" for t in market.tenors] + [f"equity_{name}" for name in market.equity_names]
            + ["cpi", "inflation", "spread"])


def _table(path: pathlib.Path) -> tuple[np.ndarray, np.ndarray, list[str], list[str]]:
    """(values (scenarios, times, variables), times, variable names, scenario ids) from any of the
    formats (an NPZ file's scenarios are numbered from 0)."""
    where = f"scenario file {path}"
    suffix = path.suffix.lower()
    if suffix == ".npz":
        check_npz(path, where, MAX_SCENARIO_VALUES, ("values", "times", "variables"))
        try:
            with np.load(path, allow_pickle=False) as data:
                missing = [name for name in ("values", "times", "variables") if name not in data]
                if missing:
                    raise InputError(f"{where}: no array {missing[0]!r}; an NPZ scenario file holds 'values' "
                                     "(scenarios x times x variables), 'times' and 'variables'.")
                arrays = {name: data[name] for name in ("values", "times")}
                for name, array in arrays.items():
                    if array.dtype.kind not in "fiu":
                        raise InputError(f"{where}: the array {name!r} holds {array.dtype} values; allowed: real "
                                         "numbers (float or integer).")
                values, times = np.asarray(arrays["values"], float), np.asarray(arrays["times"], float)
                names = [str(v) for v in np.atleast_1d(data["variables"])]
        except InputError:
            raise
        except (OSError, ValueError, TypeError, EOFError, zipfile.BadZipFile) as error:
            raise InputError(f"{where}: not a readable NPZ scenario file ({type(error).__name__}: {error}).") from None
        if values.ndim != 3 or times.ndim != 1 or values.shape[1:] != (times.size, len(names)):
            raise InputError(f"{where}: values has shape {values.shape}; expected (scenarios, {times.size} times, "
                             f"{len(names)} variables).")
        return values, times, names, [str(s) for s in range(values.shape[0])]
    if suffix not in (".csv", ".parquet"):
        raise InputError(f"{where}: unknown format {suffix!r}; allowed: .csv, .parquet (long tables) or .npz.")
    try:
        if suffix == ".csv":
            # Blank lines kept (so a row's line is its index + 2) and dropped below; every cell as its text
            # (ids: "01" != "1"; a bad number is reported as written), converted in `_pivoted`.
            table = pd.read_csv(io.StringIO(read_text(path, "scenario", MAX_SCENARIO_BYTES)), skipinitialspace=True,
                                dtype=str, keep_default_na=False, skip_blank_lines=False)
            table = table[~(table.fillna("").apply(lambda column: column.str.strip()) == "").all(axis=1)].copy()
        else:
            import pyarrow.parquet

            check_parquet(path, where, MAX_SCENARIO_VALUES, MAX_SCENARIO_BYTES)
            # The columns as stored: pandas' metadata (an index made of columns) is not applied.
            table = pyarrow.parquet.read_table(path).to_pandas(ignore_metadata=True)
    except InputError:
        raise
    except Exception as error:  # pandas and pyarrow raise many types for a malformed file
        raise InputError(f"{where}: not a readable table ({' '.join(str(error).split())[:200]}).") from None
    if list(table.columns) != LONG_COLUMNS:
        raise InputError(f"{where}, line 1: columns {list(table.columns)}; expected {', '.join(LONG_COLUMNS)}.")
    return _pivoted(table, where, line_offset=2 if suffix == ".csv" else None)


def _row(where, table: pd.DataFrame, position: int, line_offset) -> str:
    """Where the table's row at `position` is: its line in a CSV (its index counts the blank lines
    dropped), its row number otherwise."""
    index = int(table.index[position])
    return f"{where}, line {index + line_offset}" if line_offset is not None else f"{where}, row {index + 1}"


def _cell(value) -> str:
    """A cell as the file has it: a CSV's text, a Parquet number as Python prints it."""
    return value if isinstance(value, str) else str(value.item() if hasattr(value, "item") else value)


def _pivoted(table: pd.DataFrame, where: str, line_offset) -> tuple[np.ndarray, np.ndarray, list[str], list[str]]:
    for column in ("scenario", "variable"):
        empty = np.flatnonzero(table[column].isna().to_numpy() | (table[column].astype(str).str.strip() == ""))
        if empty.size:
            raise InputError(f"{_row(where, table, empty[0], line_offset)}: {column} is empty; every row names its {column}.")
    for column in ("time", "value"):
        cells = table[column]
        if pd.api.types.is_bool_dtype(cells) or not pd.api.types.is_numeric_dtype(cells):
            # Text (every CSV cell): a decimal number as CSV writes one, the rule of every user file.
            text = cells.astype(str).str.strip()
            bad = np.flatnonzero(~(text.str.fullmatch(DECIMAL.pattern).fillna(False).to_numpy(bool)
                                   & (text.str.len() <= MAX_NUMBER_CHARS).to_numpy(bool)))
            if bad.size:
                raise InputError(f"{_row(where, table, bad[0], line_offset)}: {column} = {cells.iloc[bad[0]]!r}; "
                                 "allowed: a finite number, written in decimal (such as 0.25 or 1e-3).")
        numbers = pd.to_numeric(cells, errors="coerce")
        bad = np.flatnonzero(~np.isfinite(numbers.to_numpy(float)))
        if bad.size:
            raise InputError(f"{_row(where, table, bad[0], line_offset)}: {column} = {_cell(table[column].iloc[bad[0]])!r}; "
                             "allowed: a finite number.")
        table[column] = numbers
    scenario_index, scenarios = pd.factorize(table["scenario"].astype(str))  # in the file's order
    times, time_index = np.unique(table["time"].to_numpy(float), return_inverse=True)
    names, name_index = np.unique(table["variable"].astype(str), return_inverse=True)
    cells = (scenario_index * times.size + time_index) * names.size + name_index
    counts = np.bincount(cells, minlength=scenarios.size * times.size * names.size)
    if np.any(counts > 1):
        first = int(np.flatnonzero(counts[cells] > 1)[1])
        raise InputError(f"{_row(where, table, first, line_offset)}: scenario {_cell(table['scenario'].iloc[first])!r}, time "
                         f"{table['time'].iloc[first]:g}, {table['variable'].iloc[first]} is given twice.")
    if np.any(counts == 0):
        cell = int(np.flatnonzero(counts == 0)[0])
        s, rest = divmod(cell, times.size * names.size)
        t, v = divmod(rest, names.size)
        raise InputError(f"{where}: scenario {scenarios[s]!r} has no {names[v]} at time {times[t]:g}; every "
                         "scenario needs every variable at every time.")
    values = np.empty(scenarios.size * times.size * names.size)
    values[cells] = table["value"].to_numpy(float)
    return values.reshape(scenarios.size, times.size, names.size), times, [str(n) for n in names], list(scenarios)


def _monthly(values: np.ndarray, times: np.ndarray, horizon: int, where: str, logarithmic: np.ndarray) -> np.ndarray:
    """Values at months 0..horizon, shape (horizon + 1, scenarios, variables), from `times`
    [years] at monthly or annual steps; `logarithmic` marks variables interpolated in log."""
    steps = np.diff(times)
    step = steps[0] if steps.size else 0.0
    if times[0] != 0.0 or steps.size == 0 or not (np.allclose(steps, MONTH, atol=1e-9) or np.allclose(steps, 1.0, atol=1e-9)):
        raise InputError(f"{where}: times {times[:4].tolist()}...; allowed: from 0 in steps of one month (1/12) or "
                         "one year, the same throughout.")
    if times[-1] < horizon * MONTH - 1e-9:
        raise InputError(f"{where}: the scenarios end at {times[-1]:g} years; the study's horizon is {horizon} months "
                         f"({horizon * MONTH:g} years).")
    months = np.arange(horizon + 1) * MONTH
    if abs(step - MONTH) < 1e-9:
        return np.transpose(values[:, :horizon + 1], (1, 0, 2))
    data = np.where(logarithmic, np.log(np.where(logarithmic, values, 1.0)), values)
    right = np.clip(np.searchsorted(times, months, side="right"), 1, times.size - 1)
    share = ((months - times[right - 1]) / (times[right] - times[right - 1]))[None, :, None]
    filled = data[:, right - 1] * (1 - share) + data[:, right] * share
    return np.transpose(np.where(logarithmic, np.exp(filled), filled), (1, 0, 2))


def _refuse(where: str, name: str, values: np.ndarray, times: np.ndarray, bad: np.ndarray, allowed: str):
    """Raise `InputError` naming the first cell of `values` (scenarios, times) that is `bad`."""
    scenario, time = np.argwhere(bad)[0]
    raise InputError(f"{where}: {name} = {values[scenario, time]:g}; allowed: {allowed} (scenario {scenario + 1} in "
                     f"the file's order, time {times[time]:g}).")


def _check_ranges(values: np.ndarray, times: np.ndarray, column: dict, equities: list[str], where: str) -> None:
    """Refuse values that are finite but outside what the model can value: indices that are not
    > 0 or that move more than `INDEX_FACTOR` from their value at time 0 (their ratios drive the
    model), and inflation or spread outside [-RATE_BOUND, RATE_BOUND] per year."""
    for name in [*equities, "cpi"]:
        index = values[..., column[name]]
        if np.any(index <= 0):
            _refuse(where, name, index, times, index <= 0, "an index > 0")
        factor = INDEX_FACTOR["cpi" if name == "cpi" else "equity"]
        with np.errstate(over="ignore"):  # an infinite ratio is refused below like any far one
            ratio = index / index[:, :1]
        far = (ratio > factor) | (ratio < 1 / factor)
        if np.any(far):
            _refuse(where, name, index, times, far, f"within a factor of {factor:g} of the scenario's value at time 0 "
                    f"({ratio[far][0]:.3g} times it here)")
    for name in ("inflation", "spread"):
        rate = values[..., column[name]] if name in column else np.zeros(1)
        if np.any(np.abs(rate) > RATE_BOUND):
            _refuse(where, name, rate, times, np.abs(rate) > RATE_BOUND, f"[-{RATE_BOUND:g}, {RATE_BOUND:g}] per year")


def load_scenarios(path: str | os.PathLike, market: Market, horizon_months: int, *, spread: float) -> ScenarioSet:
    """Read a scenario file (see the module docstring) for a fund with `market`'s key tenors and
    equity indices, over `horizon_months`; `spread`: the fund's own, where the file has none.

    **Raises:** `InputError` naming the file (the line, for a CSV) and the variable, value or
    time for a missing or unknown variable, a non-finite or out-of-range value, times that are
    not monthly or annual from 0, or scenarios shorter than the horizon."""
    path = pathlib.Path(path)
    where = f"scenario file {path}"
    if not path.is_file():
        raise InputError(f"scenario file {str(path)!r} does not exist.")
    values, times, names, ids = _table(path)
    tenors = {name: float(_TENOR.match(name).group(1)) for name in names if _TENOR.match(name)}
    equities = [f"equity_{name}" for name in market.equity_names]
    allowed = {*tenors, *equities, "cpi", "inflation", "spread"}
    unknown = [name for name in names if name not in allowed]
    missing = [name for name in [*equities, "cpi"] if name not in names] + ([] if tenors else ["zero_rate_<tenor>"])
    if unknown or missing:
        raise InputError(f"{where}: {'unknown variable ' + repr(unknown[0]) if unknown else 'no ' + repr(missing[0])}; "
                         f"the variables are zero_rate_<tenor in years> (one or more), "
                         f"{', '.join(equities)} (the fund's equity indices), cpi, and optionally inflation and spread.")
    if not np.all(np.isfinite(values)):
        s, t, v = np.argwhere(~np.isfinite(values))[0]
        raise InputError(f"{where}: scenario {ids[s]!r}, time {times[t]:g}: {names[v]} = {_cell(values[s, t, v])}; allowed: a "
                         "finite number.")
    column = {name: i for i, name in enumerate(names)}
    _check_ranges(values, times, column, equities, where)
    order = sorted(tenors, key=tenors.get)
    for first, second in zip(order, order[1:]):
        if tenors[first] == tenors[second]:
            raise InputError(f"{where}: {first} and {second} are the same tenor ({tenors[first]:g} years); give it once.")
    rates = values[..., [column[name] for name in order]]
    if np.any(np.abs(rates) >= 0.5):
        s, t, k = np.argwhere(np.abs(rates) >= 0.5)[0]
        raise InputError(f"{where}: scenario {ids[s]!r}, time {times[t]:g}: {order[k]} = {rates[s, t, k]:g}; allowed: "
                         "(-0.5, 0.5).")
    _refuse_starts_apart(values, names, ids, [*equities, "cpi"], where)
    keyed = rates @ interpolation_weights(market.tenors, np.array([tenors[n] for n in order])).T
    cpi = values[..., column["cpi"]]
    if "inflation" in column:
        inflation = values[..., column["inflation"]]
    else:  # the price index's growth over the step ahead (the last step's at the end), as the generator
        # accrues it; at time 0 the set's mean first step, so that every scenario starts alike
        growth = np.diff(np.log(cpi), axis=1) / np.diff(times)
        inflation = np.concatenate([growth, growth[:, -1:]], axis=1)
        inflation[:, 0] = growth[:, 0].mean()
    credit = values[..., column["spread"]] if "spread" in column else np.full(cpi.shape, spread)
    stacked = np.concatenate([keyed, values[..., [column[name] for name in equities]],
                              np.stack([cpi, inflation, credit], axis=-1)], axis=-1)
    logarithmic = np.zeros(stacked.shape[-1], bool)
    logarithmic[market.n_tenors:market.n_tenors + market.n_equities + 1] = True
    return ScenarioSet(_monthly(stacked, times, horizon_months, where, logarithmic), str(path))


def _refuse_starts_apart(values: np.ndarray, names: list[str], ids: list[str], indices: list[str], where: str) -> None:
    """Refuse a set whose scenarios start from different markets, naming the file's variable and
    two scenarios that differ at the first time (the `indices`' levels may differ: only their
    returns are used)."""
    origin = values[:, 0, :]
    apart = np.abs(origin - origin[0]).max(axis=0)
    for v in np.flatnonzero(apart > 1e-9):
        if names[v] not in indices:
            s = int(np.argmax(np.abs(origin[:, v] - origin[0, v])))
            raise InputError(f"{where}: {names[v]} differs between scenarios at the first time: {origin[0, v]:g} in "
                             f"scenario {ids[0]!r}, {origin[s, v]:g} in scenario {ids[s]!r}; every scenario starts "
                             "from the same market.")


def write_scenarios(path: str | os.PathLike, scenarios: ScenarioSet, market: Market) -> pathlib.Path:
    """Write `scenarios` in the format of `path`'s extension (.csv, .parquet or .npz), monthly,
    with the variables `variable_names(market)`; atomically."""
    from snapo_ode import atomic_write_bytes

    path = pathlib.Path(path)
    names = variable_names(market)
    months, count, _ = scenarios.values.shape
    times = np.arange(months) * MONTH
    by_scenario = np.transpose(scenarios.values, (1, 0, 2))
    suffix = path.suffix.lower()
    if suffix == ".npz":
        buffer = io.BytesIO()
        np.savez(buffer, values=by_scenario, times=times, variables=np.array(names))
        return atomic_write_bytes(path, buffer.getvalue())
    if suffix not in (".csv", ".parquet"):
        raise InputError(f"--write-scenarios {path}: unknown format {suffix!r}; allowed: .csv, .parquet or .npz.")
    table = pd.DataFrame({
        "scenario": np.repeat(np.arange(count), months * len(names)),
        "time": np.tile(np.repeat(times, len(names)), count),
        "variable": np.tile(np.array(names), count * months),
        "value": by_scenario.reshape(-1)})
    if suffix == ".csv":
        return atomic_write_bytes(path, table.to_csv(index=False, float_format="%.17g").encode())
    buffer = io.BytesIO()
    table.to_parquet(buffer, index=False)
    return atomic_write_bytes(path, buffer.getvalue())
