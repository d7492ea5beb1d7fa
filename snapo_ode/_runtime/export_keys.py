"""The key of an exported program's entry (`snapo_ode.exported`): a description of its
arguments and what it closes over that is the same in every process (`describe`), and of the
environment that shapes the traced program (versions, the project's source, JAX's settings)."""

import dataclasses
import enum
import functools
import hashlib
import importlib.metadata
import importlib.util
import json
import pathlib
import site
import sys
import sysconfig
import types

import equinox._errors as equinox_errors
import jax
import numpy as np

from .._platform.versions import versions

EXPORTED_DIRECTORY = "exported"
"""The entries' directory, inside the compilation cache directory."""
_ARRAYS = (jax.Array, np.ndarray, np.generic)
"""What `describe` keys as an array (by dtype and shape), and `ExportedProgram._path`'s memo alike."""


class Unkeyable(TypeError):
    """An argument of an exported program has no description that is the same in every process."""


def _name(kind: type) -> str:
    return f"{kind.__module__}.{kind.__qualname__}"


def describe(tree, *, values: bool = False):
    """A JSON-able description of `tree` that is the same in every process: arrays by dtype and
    shape (and, with `values`, the SHA-256 of their bytes), scalars and strings by value,
    containers and dataclasses (`equinox.Module`s) field by field, functions and classes by
    qualified name. **Raises:** `Unkeyable` for a closure, a lambda or an unknown object."""
    if isinstance(tree, jax.core.Tracer):
        raise Unkeyable("a traced value (called inside jit): nothing to export")
    if isinstance(tree, _ARRAYS):
        described = ["array", str(tree.dtype), list(np.shape(tree)), bool(getattr(tree, "weak_type", False))]
        return described + [hashlib.sha256(np.asarray(tree).tobytes()).hexdigest()] if values else described
    if tree is None or isinstance(tree, (bool, int, float, complex, str, bytes)):
        return [type(tree).__name__, repr(tree)]
    if isinstance(tree, enum.Enum):
        return [_name(type(tree)), tree.name]
    if isinstance(tree, (tuple, list)):
        return [_name(type(tree)), [describe(leaf, values=values) for leaf in tree]]
    if isinstance(tree, dict):
        return [_name(type(tree)), sorted([repr(k), describe(v, values=values)] for k, v in tree.items())]
    if isinstance(tree, (set, frozenset)):
        return [_name(type(tree)), sorted(json.dumps(describe(leaf, values=values)) for leaf in tree)]
    if isinstance(tree, type):
        return ["class", _name(tree)]
    if isinstance(tree, types.FunctionType) and _named(tree):
        return ["function", f"{tree.__module__}.{tree.__qualname__}"]
    if dataclasses.is_dataclass(tree):
        return [_name(type(tree)), [[f.name, describe(getattr(tree, f.name), values=values)]
                                    for f in dataclasses.fields(tree)]]
    raise Unkeyable(f"{type(tree).__qualname__} has no description that is the same in every process")


def _named(fn: types.FunctionType) -> bool:
    """Whether `fn` is the same in every process that imports its module: a function defined at
    module or class level without a closure, or what its module holds under its qualified name (a
    decorated module-level function, e.g. optimistix's `max_norm`, which Kvaerno5's root finder
    holds, closes over the function it wraps)."""
    if "<" in fn.__qualname__:
        return False
    if fn.__closure__ is None:
        return True
    owner = sys.modules.get(fn.__module__)
    for part in fn.__qualname__.split("."):
        owner = getattr(owner, part, None)
    return owner is fn


def _packages(description) -> set[str]:
    """The top-level packages of the classes and functions named in a `describe` output."""
    if not isinstance(description, list):
        return set()
    if len(description) == 2 and description[0] in ("class", "function"):
        return {description[1].split(".")[0]}
    head = description[0] if description and isinstance(description[0], str) else ""
    found = {head.split(".")[0]} if "." in head and head.split(".")[0].isidentifier() else set()
    return found.union(*(_packages(part) for part in description))


@functools.cache
def _source_digest(packages: tuple[str, ...]) -> str:
    """SHA-256 of every .py file (path and bytes) of those of `packages` that are not installed
    in site-packages or the standard library (those are keyed by their versions): this project's."""
    installed = {*site.getsitepackages(), sysconfig.get_paths()["stdlib"]}
    digest = hashlib.sha256()
    for package in packages:
        try:
            spec = importlib.util.find_spec(package)
        except (ImportError, ValueError):
            spec = None
        for root in (spec and spec.submodule_search_locations) or []:
            if any(pathlib.Path(root).is_relative_to(place) for place in installed):
                continue
            digest.update(package.encode() + b"\0")
            for path in sorted(pathlib.Path(root).rglob("*.py")):
                digest.update(str(path.relative_to(root)).encode() + b"\0" + path.read_bytes())
    return digest.hexdigest()


def environment(packages=()) -> dict:
    """What besides its arguments shapes a program: versions, the source of `snapo_ode` and of
    `packages` (top-level names), the backend and the JAX settings tracing reads."""
    return {"versions": {"python": sys.version, **versions()},
            "source": _source_digest(tuple(sorted({"snapo_ode", *packages}))), "backend": jax.default_backend(),
            "x64": bool(jax.config.jax_enable_x64), "precision": str(jax.config.jax_default_matmul_precision),
            "runtime_checks": str(getattr(equinox_errors, "EQX_ON_ERROR", None))}


def entry_path(name: str, key: dict) -> pathlib.Path | None:
    """The file of the program `name` with `key`, or None without a compilation cache directory."""
    directory = jax.config.jax_compilation_cache_dir
    if not directory:
        return None
    digest = hashlib.sha256(json.dumps(key, sort_keys=True).encode()).hexdigest()[:40]
    return pathlib.Path(directory) / EXPORTED_DIRECTORY / f"{name}-{digest}.jaxexport"
