"""Typed study results: every study returns a frozen dataclass deriving from `Result`, which
writes itself as JSON (`to_json`) and as a few lines for the terminal (`summary`).

What later steps need but a JSON file should not hold (the trained policy, the evaluation
shocks, per-path schedules) is a field declared with `field(json=False)`: it travels with the
result and never reaches the file.
"""

import dataclasses
import os
import pathlib
from collections.abc import Mapping
from typing import Any, ClassVar

import numpy as np

from .._platform.files import atomic_write_json, json_bytes, publish, sha256


def field(*, json: bool = True, **kwargs) -> Any:
    """A dataclass field of a `Result`; `json=False` keeps it out of `to_json`."""
    return dataclasses.field(metadata={"json": json}, **kwargs)


def jsonable(value) -> Any:
    """`value` as JSON-ready Python: results and dataclasses as dicts of their JSON fields,
    named tuples as dicts, arrays as (nested) lists, NumPy scalars as Python numbers.

    **Raises:** `TypeError` naming the type of anything else (a policy left in a JSON field)."""
    if isinstance(value, Result):
        return value.to_json()
    if dataclasses.is_dataclass(value) and not isinstance(value, type):
        return {f.name: jsonable(getattr(value, f.name)) for f in dataclasses.fields(value)
                if f.metadata.get("json", True)}
    if isinstance(value, tuple) and hasattr(value, "_asdict"):
        return {key: jsonable(item) for key, item in value._asdict().items()}
    if isinstance(value, Mapping):
        return {str(key): jsonable(item) for key, item in value.items()}
    if isinstance(value, (list, tuple)):
        return [jsonable(item) for item in value]
    if isinstance(value, (str, bool, int, float)) or value is None:
        return value
    if isinstance(value, os.PathLike):
        return os.fspath(value)
    if isinstance(value, np.generic) or hasattr(value, "__array__"):
        return np.asarray(value).tolist()
    raise TypeError(f"{type(value).__name__} is not JSON-ready; declare its field with json=False.")


class Result:
    """Base of the typed results (use with `@dataclasses.dataclass(frozen=True, kw_only=True)`).

    Subclasses give `summary()`; `to_json()` returns every field not declared `json=False`, in
    declaration order (without the None ones when the class sets `omit_none`: fields that only
    some runs fill), and may be extended where a documented JSON layout needs it."""

    omit_none: ClassVar[bool] = False

    def to_json(self) -> dict:
        payload = jsonable(_fields(self))
        return {key: value for key, value in payload.items() if value is not None} if self.omit_none else payload

    def summary(self) -> str:
        """A few lines for the terminal."""
        raise NotImplementedError

    def write_json(self, path: str | os.PathLike) -> pathlib.Path:
        """Write `to_json()` to `path` atomically; a NaN or an infinity anywhere in it raises
        `SolverFailed` naming the field, and nothing is written."""
        payload = self.to_json()
        _refuse_non_finite(payload)
        return atomic_write_json(path, payload)

    def publish(self, path: str | os.PathLike, attachments: Mapping[str, bytes] | None = None
                ) -> list[pathlib.Path]:
        """Write the JSON to `path` and each attachment (suffix -> bytes, e.g. ".policy.eqx" ->
        a trained policy) beside it as one set (`snapo_ode.publish`): everything is serialised
        first, so a failure replaces nothing, and the JSON comes last, naming each attachment
        and its SHA-256 under "attachments"."""
        path = pathlib.Path(path)
        files = {path.with_suffix(suffix): data for suffix, data in (attachments or {}).items()}
        payload = self.to_json()
        _refuse_non_finite(payload)
        if files:
            payload["attachments"] = {name.name: sha256(data) for name, data in files.items()}
        return publish({**files, path: json_bytes(payload)})


def _non_finite(payload, path: str = "") -> str | None:
    """The path ("a.b[3]") of the first NaN or infinity in a JSON payload, or None."""
    if isinstance(payload, float):
        return None if np.isfinite(payload) else path
    items = payload.items() if isinstance(payload, dict) else enumerate(payload) if isinstance(payload, list) else ()
    for key, value in items:
        found = _non_finite(value, f"{path}[{key}]" if isinstance(key, int) else f"{path}.{key}" if path else key)
        if found is not None:
            return found
    return None


def _refuse_non_finite(payload: dict) -> None:
    """Never a silent NaN: a result with a non-finite number is a failed computation."""
    from .._ode import SolverFailed

    path = _non_finite(payload)
    if path is not None:
        raise SolverFailed(f"the result's {path} is not finite: a numerical failure upstream, so nothing was "
                           "written. Run again with --debug to see where, or loosen the case (a shorter time, "
                           "a tighter tolerance, fewer paths).")


def _fields(result: Result) -> dict:
    return {f.name: getattr(result, f.name) for f in dataclasses.fields(result) if f.metadata.get("json", True)}
