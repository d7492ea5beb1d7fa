"""Traced and lowered programs kept on disk, so that a second process neither traces nor compiles.

JAX's persistent compilation cache (`snapo_ode.configure`) stores XLA executables, but a new
process must still trace and lower a program before it can look the executable up: ~24 s of
Python for the pharma chain's Jacobian, every process. `exported(fn, name=...)` serialises the
lowered program (`jax.export`) into `<compilation cache dir>/exported/` and, in the next process,
deserialises it instead of tracing `fn`; its XLA compile then hits the persistent cache.
`ExportedProgram.prefetch` does either ahead of the call, the reading and the compile in a
background thread, so that a command's several programs load in parallel.

An entry's key is everything that shapes the program:

- `name`; the arguments' pytree structure, shapes and dtypes, and every non-array leaf (solver
  settings, modes, flags); `static`: what `fn` closes over (a model), array values included;
- the versions of Python, snapo-ode, JAX, jaxlib, equinox, diffrax, lineax and optimistix, a
  hash of the source of `snapo_ode` and of the package defining `fn` (a code change makes new
  keys), the backend, float64, the default matmul precision and equinox's runtime-check mode.

An argument that cannot be described the same way in every process (a closure, an object
without a structural description) is refused with `Unkeyable` rather than keyed by its address.
A file is written atomically, carries the SHA-256 of its program, and one that is corrupt or does
not deserialise is rebuilt with a warning, never trusted; a program that cannot be exported (a
host callback, an unstable custom call) runs through `jax.jit` as before, with a warning.

Runtime checks: export refuses host callbacks, so an `equinox.error_if` compiled as a callback
cannot be exported. Call exported programs through `snapo_ode.call_checked`, which traces every
check as a NaN mark and raises `SolverFailed` on the host: a failed solve still raises after
deserialisation, and never gives a silent NaN. Export the function that returns the value and
its derivative (not a deserialised function then differentiated): the entry holds the
differentiated program, custom_vjp and checkpointed loops already lowered.
"""

import concurrent.futures
import dataclasses
import enum
import functools
import hashlib
import importlib.metadata
import importlib.util
import json
import os
import pathlib
import site
import sys
import sysconfig
import types
import warnings
from collections.abc import Callable

import equinox as eqx
import equinox._errors as equinox_errors
import jax
import numpy as np

from ._io import atomic_write_bytes

EXPORTED_DIRECTORY = "exported"
"""The entries' directory, inside the compilation cache directory."""
_MAGIC = b"snapo-exported 1\n"
_VERSIONED = ("snapo-ode", "jax", "jaxlib", "equinox", "diffrax", "lineax", "optimistix")
_LOADED: dict[pathlib.Path, Callable] = {}  # entry -> jitted call of the deserialised program
_PREFETCHED: dict[pathlib.Path, concurrent.futures.Future] = {}  # entry -> its reading, under way


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
    if isinstance(tree, types.FunctionType) and tree.__closure__ is None and "<" not in tree.__qualname__:
        return ["function", f"{tree.__module__}.{tree.__qualname__}"]
    if dataclasses.is_dataclass(tree):
        return [_name(type(tree)), [[f.name, describe(getattr(tree, f.name), values=values)]
                                    for f in dataclasses.fields(tree)]]
    raise Unkeyable(f"{type(tree).__qualname__} has no description that is the same in every process")


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


@functools.cache
def _versions() -> dict:
    def version(name: str) -> str | None:
        try:
            return importlib.metadata.version(name)
        except importlib.metadata.PackageNotFoundError:
            return None

    return {"python": sys.version, **{name: version(name) for name in _VERSIONED}}


def environment(packages=()) -> dict:
    """What besides its arguments shapes a program: versions, the source of `snapo_ode` and of
    `packages` (top-level names), the backend and the JAX settings tracing reads."""
    return {"versions": _versions(),
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


def _read(path: pathlib.Path):
    """The deserialised program at `path`; None if absent, or corrupt (then with a warning)."""
    try:
        data = path.read_bytes()
    except FileNotFoundError:
        return None
    try:
        if not data.startswith(_MAGIC + b"sha256 "):
            raise ValueError("not an exported program")
        checksum, _, program = data[len(_MAGIC + b"sha256 "):].partition(b"\n")
        if hashlib.sha256(program).hexdigest().encode() != checksum:
            raise ValueError("checksum mismatch: truncated or altered")
        return jax.export.deserialize(bytearray(program))
    except Exception as error:  # noqa: BLE001 - any failure means: rebuild, never trust
        warnings.warn(f"snapo: exported program {path} is unreadable ({error}); tracing it again", stacklevel=4)
        return None


def _export(path: pathlib.Path, flat: Callable, leaves, name: str):
    """`flat` traced, lowered and written at `path`; the deserialised program (what every later
    process runs), or None, with a warning, if it cannot be exported (e.g. a host callback)."""
    structs = [jax.ShapeDtypeStruct(np.shape(leaf), leaf.dtype) for leaf in leaves]
    try:
        serialised = jax.export.export(jax.jit(flat))(*structs).serialize()
    except Exception as error:  # noqa: BLE001 - whatever export refuses runs as before
        warnings.warn(f"snapo: {name} cannot be exported ({type(error).__name__}: {error}); it is traced "
                      "in every process", stacklevel=5)
        return None
    path.parent.mkdir(parents=True, exist_ok=True)
    atomic_write_bytes(path, _MAGIC + b"sha256 " + hashlib.sha256(serialised).hexdigest().encode() + b"\n"
                       + serialised)
    return jax.export.deserialize(bytearray(serialised))


def _load_or_export(path: pathlib.Path, flat: Callable, leaves, name: str) -> Callable:
    """The program at `path`, else `flat` traced, lowered and written there; jitted. A program
    that cannot be exported is `flat` jitted, with a warning."""
    program = _read(path) or _export(path, flat, leaves, name)
    return jax.jit(flat) if program is None else jax.jit(program.call)


class ExportedProgram:
    """What `exported` returns: call it as the function it wraps; `prefetch` prepares it ahead
    of the call."""

    def __init__(self, fn: Callable, name: str, static):
        self._fn, self._name = fn, name
        self._static_key = describe(static, values=True)
        self._packages = _packages(self._static_key) | {(getattr(fn, "__module__", None) or "snapo_ode").split(".")[0]}
        self._recent: dict = {}  # (structure, leaf ids, settings) -> (the leaves, kept alive so ids stay theirs; path)

    def _entry(self, args) -> pathlib.Path | None:
        try:
            arguments = describe(args)
            return entry_path(self._name, {"name": self._name, "static": self._static_key, "args": arguments,
                                           "environment": environment(self._packages | _packages(arguments))})
        except Unkeyable:
            return None

    def _path(self, args, every, structure) -> pathlib.Path | None:
        # Describing a model's every leaf costs milliseconds (~4 ms a call of the pharma chain's
        # Jacobian: 3 s of a design space's 801 points): a call with the same structure, arrays
        # of the same dtypes and shapes (all that `describe` reads of an argument's array) and
        # the very same other leaves (immutable) reuses its entry.
        settings = (jax.config.jax_enable_x64, str(jax.config.jax_default_matmul_precision),
                    getattr(equinox_errors, "EQX_ON_ERROR", None), jax.config.jax_compilation_cache_dir)
        leaves = tuple((str(leaf.dtype), np.shape(leaf), bool(getattr(leaf, "weak_type", False)))
                       if isinstance(leaf, _ARRAYS)
                       and not isinstance(leaf, jax.core.Tracer) else id(leaf) for leaf in every)
        try:
            memo = (structure, leaves, settings)
            path = self._recent[memo][1] if memo in self._recent else None
        except TypeError:  # an unhashable static leaf
            memo = path = None
        if path is None:
            path = self._entry(args)
            if memo is not None:
                self._recent[memo] = (every, path)
                if len(self._recent) > 16:
                    self._recent.pop(next(iter(self._recent)))
        return path

    def _flat(self, args):
        """The program's path, its array leaves and `fn` as a function of them alone."""
        every, structure = jax.tree.flatten(args)
        path = self._path(args, every, structure)
        dynamic, static_part = eqx.partition(args, eqx.is_array)
        leaves, treedef = jax.tree.flatten(dynamic)

        def flat(*dynamic):
            return self._fn(*eqx.combine(jax.tree.unflatten(treedef, dynamic), static_part))

        return path, leaves, flat

    def __call__(self, *args):
        path, leaves, flat = self._flat(args)
        if path is None:
            return eqx.filter_jit(self._fn)(*args)
        if path not in _LOADED:
            pending = _PREFETCHED.pop(path, None)
            program = pending.result() if pending is not None and pending.exception() is None else None
            _LOADED[path] = program or _load_or_export(path, flat, leaves, self._name)
        return _LOADED[path](*leaves)

    def prefetch(self, *args) -> bool:
        """Prepare the program for `args` ahead of its call, so that the call finds it compiled:
        an entry on disk is read, and its executable from the compilation cache, in a background
        thread (a warm chain's programs take ~0.2-1.2 s each to read; several prefetched
        together read in parallel while the first runs); a missing entry is traced and written
        here, in the caller's thread, and compiled in the background while the caller traces
        the next. Prefetch where the call will be made alike (inside
        `snapo_ode.prefetch_checked` for a program called through `call_checked`): the
        runtime-check mode is part of the key, and tracing must see it.

        **Returns:** whether the entry was on disk (False: traced here, or nothing to do)."""
        path, leaves, flat = self._flat(args)
        if path is None or path in _LOADED or path in _PREFETCHED:
            return False
        on_disk = path.is_file()
        program = None if on_disk else _export(path, flat, leaves, self._name)
        if not on_disk and program is None:
            _LOADED[path] = jax.jit(flat)
            return False
        precision = jax.config.jax_default_matmul_precision

        def prepare() -> Callable | None:
            # An unreadable entry (None) is rebuilt by the call, which traces where the
            # runtime-check mode is the caller's. JAX's in-memory caches key the executable by
            # the arguments' placement and the trace context: lowered for the very leaves of the
            # call, with the caller's matmul precision (thread-local).
            deserialised = _read(path) if on_disk else program
            if deserialised is None:
                return None
            with jax.default_matmul_precision(precision):
                jitted = jax.jit(deserialised.call)
                jitted.lower(*leaves).compile()
            return jitted

        _PREFETCHED[path] = _prefetcher().submit(prepare)
        return on_disk


@functools.cache
def _prefetcher() -> concurrent.futures.ThreadPoolExecutor:
    return concurrent.futures.ThreadPoolExecutor(max_workers=os.cpu_count() or 1,
                                                 thread_name_prefix="snapo-prefetch")


def exported(fn: Callable, *, name: str, static=None) -> ExportedProgram:
    """`fn` (a function of pytrees, its array leaves traced, every other leaf static) as a
    program traced once and kept on disk; see the module docstring.

    **Arguments:**
    - `fn`: returns arrays in tuples, lists or dicts (what `jax.export` serialises).
    - `name`: the entry's name (letters, digits, `-`), e.g. "pharma-jacobian".
    - `static`: what `fn` closes over and its program depends on (a model, settings): part of
      the key, array values included. Arguments need not be listed: they are keyed by structure.

    **Returns:** an `ExportedProgram`, a function of the same arguments (with `prefetch`).
    Without a compilation cache directory, or with an argument that cannot be keyed
    (`Unkeyable`: a closure, a traced value), it is `fn` jitted (`equinox.filter_jit`).
    """
    return ExportedProgram(fn, name, static)
