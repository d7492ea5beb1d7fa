"""A desk's own price paths from a file (`snapo gas --train-paths-file FILE --value-paths-file
FILE`), read through the one reading path for user files (`snapo_ode.check_npz`,
`check_parquet`: bounded from their headers before anything is decompressed).

- NPZ: `spot`, shape (paths, days) in the curve's unit [$/MMBtu]; optional `factors`, shape
  (paths, days, k): the price state the policy and the LSMC basis may read (with a price model,
  its factors, in its order).
- Parquet (long): columns `path`, `day`, `spot`, then any factor columns; every path has every
  day 0..T-1 once.

Every refusal (a wrong shape, another day count than the curve's, a NaN, a spot <= 0, a path
missing a day) is one line naming the file, before anything is compiled.
"""

import os
import pathlib
import zipfile

import jax.numpy as jnp
import numpy as np

from snapo_ode import InputError, check_npz, check_parquet

from ._paths import PricePaths

MAX_PATH_VALUES = 200_000_000  # spot and factors of one file: 100,000 paths x 365 days x 5 numbers
MAX_PATH_BYTES = 4 * 2**30


def _arrays(path: pathlib.Path, where: str) -> tuple[np.ndarray, np.ndarray | None]:
    if path.suffix.lower() == ".npz":
        check_npz(path, where, MAX_PATH_VALUES, ("spot", "factors"))
        try:
            with np.load(path, allow_pickle=False) as data:
                if "spot" not in data:
                    raise InputError(f"{where}: no array 'spot'; an NPZ paths file holds 'spot' (paths x days) and "
                                     "optionally 'factors' (paths x days x k).")
                spot = np.asarray(data["spot"], dtype=float)
                factors = np.asarray(data["factors"], dtype=float) if "factors" in data else None
        except InputError:
            raise
        except (OSError, ValueError, TypeError, EOFError, zipfile.BadZipFile) as error:
            raise InputError(f"{where}: not a readable NPZ paths file ({type(error).__name__}: {error}).") from None
        return spot, factors
    if path.suffix.lower() != ".parquet":
        raise InputError(f"{where}: unknown format {path.suffix!r}; allowed: .npz or .parquet.")
    import pandas as pd

    check_parquet(path, where, MAX_PATH_VALUES, MAX_PATH_BYTES)
    try:
        table = pd.read_parquet(path)
    except Exception as error:  # pyarrow raises many types for a malformed file
        raise InputError(f"{where}: not a readable Parquet file ({' '.join(str(error).split())[:200]}).") from None
    columns = list(table.columns)
    if columns[:3] != ["path", "day", "spot"]:
        raise InputError(f"{where}: columns {columns[:3]}; a long paths table starts path, day, spot (then factors).")
    for column in columns:
        if not pd.api.types.is_numeric_dtype(table[column]) or pd.api.types.is_bool_dtype(table[column]):
            raise InputError(f"{where}: column {column!r} is not numeric ({table[column].dtype}).")
    table = table.sort_values(["path", "day"], kind="stable")
    paths, days = table["path"].nunique(), int(table["day"].max()) + 1 if len(table) else 0
    expected = np.tile(np.arange(days), paths)
    if len(table) != paths * days or not np.array_equal(table["day"].to_numpy(), expected):
        raise InputError(f"{where}: {len(table):,} rows for {paths:,} paths and days 0..{days - 1}; every path needs "
                         "every day 0..T-1 exactly once.")
    spot = table["spot"].to_numpy(float).reshape(paths, days)
    factors = table[columns[3:]].to_numpy(float).reshape(paths, days, -1) if len(columns) > 3 else None
    return spot, factors


def load_paths(path: str | os.PathLike, forward_curve, *, factor_count: int | None = None) -> PricePaths:
    """The paths of `path` as `PricePaths` relative to `forward_curve` (T,) [$/MMBtu].
    `factor_count`: the k a price model needs (None: any, or none).

    **Raises:** `InputError` (module docstring)."""
    path = pathlib.Path(path)
    where = f"paths file {path}"
    curve = np.asarray(forward_curve, dtype=float)
    spot, factors = _arrays(path, where)
    if spot.ndim != 2 or spot.shape[0] < 2:
        raise InputError(f"{where}: spot has shape {spot.shape}; expected (paths >= 2, {curve.size} days).")
    if spot.shape[1] != curve.size:
        raise InputError(f"{where}: {spot.shape[1]} days of spot; the forward curve has {curve.size}.")
    bad = np.argwhere(~np.isfinite(spot) | (spot <= 0))
    if bad.size:
        p, d = bad[0]
        raise InputError(f"{where}: spot[{p}, {d}] = {float(spot[p, d])!r}; allowed: a finite price > 0.")
    if factors is not None:
        if factors.ndim != 3 or factors.shape[:2] != spot.shape:
            raise InputError(f"{where}: factors has shape {factors.shape}; expected ({spot.shape[0]} paths, "
                             f"{spot.shape[1]} days, k).")
        bad = np.argwhere(~np.isfinite(factors))
        if bad.size:
            raise InputError(f"{where}: factors[{', '.join(map(str, bad[0]))}] is not finite.")
    if factor_count is not None and factors is not None and factors.shape[2] != factor_count:
        raise InputError(f"{where}: {factors.shape[2]} factors; the price model has {factor_count}.")
    log_ratio = np.log(spot / curve)
    return PricePaths(jnp.asarray(log_ratio), None if factors is None else jnp.asarray(factors))


def save_paths(path: str | os.PathLike, forward_curve, paths: PricePaths) -> pathlib.Path:
    """Write `paths` as an NPZ (`spot` = F exp(log ratio), and `factors` where known) or a long
    Parquet table, by the suffix of `path`."""
    path = pathlib.Path(path)
    spot = np.asarray(forward_curve, dtype=float) * np.exp(np.asarray(paths.log_ratio))
    factors = None if paths.factors is None else np.asarray(paths.factors)
    if path.suffix.lower() == ".npz":
        np.savez(path, spot=spot, **({} if factors is None else {"factors": factors}))
        return path
    import pandas as pd

    count, days = spot.shape
    columns = {"path": np.repeat(np.arange(count), days), "day": np.tile(np.arange(days), count),
               "spot": spot.ravel()}
    for index in range(0 if factors is None else factors.shape[2]):
        columns[f"factor_{index}"] = factors[:, :, index].ravel()
    pd.DataFrame(columns).to_parquet(path, index=False)
    return path


def paths_of_args(args, inputs, factor_count: int | None = None) -> tuple[PricePaths | None, PricePaths | None]:
    """The paths of `--train-paths-file` and `--value-paths-file` (None where not given), read and
    checked before any compile."""
    return tuple(None if file is None else load_paths(file, inputs.forward_curve, factor_count=factor_count)
                 for file in (args.train_paths_file, args.value_paths_file))
