"""Traced and lowered programs kept on disk, so that a second process neither traces nor compiles.

JAX's persistent compilation cache (`snapo_ode.configure`) stores XLA executables, but a new
process must still trace and lower a program before it can look the executable up, which for a
large program (the pharma chain's Jacobian) costs many times the reading of its executable (the
measurement: docs/architecture.md, Measurements behind the design). `exported(fn, name=...)`
serialises the lowered program (`jax.export`) into `<compilation cache dir>/exported/` and, in the
next process, deserialises it instead of tracing `fn`; its XLA compile then hits the persistent
cache. `ExportedProgram.prefetch` does either ahead of the call, the reading and the compile in a
background thread, so that a command's several programs load in parallel; with `elsewhere`, a
missing entry is traced by a helper process (`snapo_ode._runtime.export_helper`), so that a first
process's several traces run side by side too.

An entry's key (`snapo_ode._runtime.export_keys`) is everything that shapes the program:

- `name`; the arguments' pytree structure, shapes and dtypes, and every non-array leaf (solver
  settings, modes, flags); `static`: what `fn` closes over (a model), array values included;
- the versions of Python, snapo-ode, JAX, jaxlib, equinox, diffrax, lineax and optimistix, a
  hash of the source of `snapo_ode` and of the package defining `fn` (a code change makes new
  keys), the backend, float64, the default matmul precision and equinox's runtime-check mode.

An argument that cannot be described the same way in every process (a closure, an object
without a structural description) is refused with `Unkeyable` rather than keyed by its address:
the program is then jitted as before, with a warning (none for a call inside another jit).
A file is written atomically and sealed to its key (`snapo_ode._platform.cache_trust`); one that is corrupt,
another key's, or does not deserialise is rebuilt with a warning, never trusted; a program that cannot be exported (a
host callback, an unstable custom call) runs through `jax.jit` as before, with a warning.

Runtime checks: export refuses host callbacks, so an `equinox.error_if` compiled as a callback
cannot be exported. Call exported programs through `snapo_ode.call_checked`, which traces every
check as a NaN mark and raises `SolverFailed` on the host: a failed solve still raises after
deserialisation, and never gives a silent NaN. Export the function that returns the value and
its derivative (not a deserialised function then differentiated): the entry holds the
differentiated program, custom_vjp and checkpointed loops already lowered.
"""

import concurrent.futures
import functools
import os
import pathlib
import threading
import warnings
from collections.abc import Callable

import equinox as eqx
import equinox._errors as equinox_errors
import jax
import numpy as np

from . import export_helper
from .export_keys import _ARRAYS, Unkeyable, _packages, describe, entry_path, environment
from .._platform.cache_trust import directory_secret, unseal, write_sealed

_MAGIC = b"snapo-exported 2\n"
QUICK_COMPILE = {"xla_cpu_use_fusion_emitters": False, "xla_backend_optimization_level": 1}
"""XLA options for a program whose compiles cost more than its runs: on a CPU, XLA's elemental
emitters instead of its fusion emitters, and LLVM's optimisation at level 1 (of 3; XLA's default
2). Both cut the pharma chain's compiles at the same run times and values to round-off, but the
kinetics gradients ran slower with the elemental emitters, so the options are chosen per
program, not made the default (the measurement: docs/architecture.md, Measurements behind the
design)."""
ONCE_COMPILE = {**QUICK_COMPILE, "xla_backend_optimization_level": 0}
"""XLA options for a program a command runs once (a check: a reference, central differences):
`QUICK_COMPILE` with LLVM's optimisation off: a shorter compile for a slower run, which pays only
for a program run once, so a program that is timed or run many times keeps `QUICK_COMPILE` (the
measurement: docs/architecture.md, Measurements behind the design)."""

_LOADED: dict[pathlib.Path, Callable] = {}  # entry -> jitted call of the deserialised program
_PREFETCHED: dict[pathlib.Path, concurrent.futures.Future] = {}  # entry -> its reading, under way


def _secret() -> bytes:
    return directory_secret(jax.config.jax_compilation_cache_dir)


def _read(path: pathlib.Path):
    """The deserialised program at `path`; None if absent, or corrupt (then with a warning)."""
    try:
        data = path.read_bytes()
    except FileNotFoundError:
        return None
    try:
        program = unseal(_secret(), path.name, data)
        if program is None:
            raise ValueError("seal check failed: truncated, altered, or another entry's")
        if not program.startswith(_MAGIC):
            raise ValueError("not an exported program")
        return jax.export.deserialize(bytearray(program[len(_MAGIC):]))
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
    write_sealed(_secret(), path, _MAGIC + serialised)
    return jax.export.deserialize(bytearray(serialised))


def _load_or_export(path: pathlib.Path, flat: Callable, leaves, name: str, jit: Callable) -> Callable:
    """The program at `path`, else `flat` traced, lowered and written there; `jit`ted. A program
    that cannot be exported is `flat` jitted, with a warning."""
    program = _read(path) or _export(path, flat, leaves, name)
    return jit(flat) if program is None else jit(program.call)


class ExportedProgram:
    """What `exported` returns: call it as the function it wraps; `prefetch` prepares it ahead
    of the call."""

    def __init__(self, fn: Callable, name: str, static, compiler_options: dict | None = None):
        self._fn, self._name = fn, name
        self._compiler_options = compiler_options
        self._static_key = describe(static, values=True)
        self._packages = _packages(self._static_key) | {(getattr(fn, "__module__", None) or "snapo_ode").split(".")[0]}
        self._recent: dict = {}  # (structure, leaf ids, settings) -> (the leaves, kept alive so ids stay theirs; path)

    def _jit(self, fn: Callable) -> Callable:
        """`fn` jitted with the program's compiler options on a CPU; on another backend with
        XLA's defaults (the options are chosen for XLA's CPU compiler: `QUICK_COMPILE`,
        `ONCE_COMPILE`; an LLVM optimisation level would also slow a GPU's kernels)."""
        return jax.jit(fn, compiler_options=self._compiler_options if jax.default_backend() == "cpu" else None)

    def _entry(self, args) -> pathlib.Path | None:
        try:
            arguments = describe(args)
            return entry_path(self._name, {"name": self._name, "static": self._static_key, "args": arguments,
                                           "environment": environment(self._packages | _packages(arguments))})
        except Unkeyable as error:
            # Inside another jit there is nothing to keep; outside, a program that every process
            # traces again is a cost the caller should see, not a silent fallback.
            if not any(isinstance(leaf, jax.core.Tracer) for leaf in jax.tree.leaves(args)):
                warnings.warn(f"snapo: {self._name} cannot be kept on disk ({error}); it is traced in every "
                              "process", stacklevel=5)
            return None

    def _path(self, args, every, structure) -> pathlib.Path | None:
        # Describing a model's every leaf is slow enough to add up over a design space's points
        # (docs/architecture.md, Measurements behind the design): a call with the same structure,
        # arrays of the same dtypes and shapes (all that `describe` reads of an argument's array)
        # and the very same other leaves (immutable) reuses its entry.
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
            _LOADED[path] = program or _load_or_export(path, flat, leaves, self._name, self._jit)
        return _LOADED[path](*leaves)

    def build(self, args, path: str) -> bool | None:
        """What a helper process does (`snapo_ode._runtime.export_helper`): trace the program for `args`,
        write its entry and compile it (into the persistent compilation cache), if its entry's
        path here is `path`, the caller's. **Returns:** True when done, False where the key
        differs (nothing written), None where the program cannot be exported."""
        entry, leaves, flat = self._flat(args)
        if entry is None or str(entry) != path:
            return False
        deserialised = _export(entry, flat, leaves, self._name)
        if deserialised is None:
            return None
        self._compiled(deserialised, leaves)
        return True

    def _compiled(self, deserialised, leaves) -> Callable:
        """The deserialised program jitted and compiled for `leaves` (an executable the
        persistent cache holds is read from it)."""
        jitted = self._jit(deserialised.call)
        jitted.lower(*leaves).compile()
        return jitted

    def prefetch(self, *args, elsewhere: bool = False) -> bool:
        """Prepare the program for `args` ahead of its call, so that the call finds it compiled:
        an entry on disk is read, and its executable from the compilation cache, in a background
        thread (each program takes a while to read; several prefetched
        together read in parallel while the first runs); a missing entry is traced and written
        here, in the caller's thread, and compiled in the background while the caller traces
        the next. With `elsewhere`, a missing entry is traced, written and compiled by a helper
        process instead (`snapo_ode._runtime.export_helper`: tracing holds the interpreter lock, so
        two traces run side by side only in two processes), and read as from disk when it is
        done; where no helper can take it (a program defined inside a function, arguments that
        do not pickle) it is traced here. Prefetch where the call will be made alike (inside
        `snapo_ode.prefetch_checked` for a program called through `call_checked`): the
        runtime-check mode is part of the key, and tracing must see it.

        **Returns:** whether the entry was on disk (False: traced here or elsewhere, or nothing
        to do)."""
        path, leaves, flat = self._flat(args)
        if path is None or path in _LOADED or path in _PREFETCHED:
            return False
        on_disk = path.is_file()
        precision = jax.config.jax_default_matmul_precision
        helper = None
        if not on_disk and elsewhere:
            helper = export_helper.start(self, args, path, cache_dir=jax.config.jax_compilation_cache_dir,
                                          on_error=getattr(equinox_errors, "EQX_ON_ERROR", None),
                                          precision=precision)
        program = None if on_disk or helper is not None else _export(path, flat, leaves, self._name)
        if not on_disk and helper is None and program is None:
            _LOADED[path] = self._jit(flat)
            return False

        def prepare() -> Callable | None:
            # An unreadable entry (None) is rebuilt by the call, which traces where the
            # runtime-check mode is the caller's; so is one whose helper failed. JAX's
            # in-memory caches key the executable by the arguments' placement and the trace
            # context: lowered for the very leaves of the call, with the caller's matmul
            # precision (thread-local).
            if helper is not None:
                code = export_helper.wait(helper)
                if code == export_helper.UNEXPORTABLE:  # the helper warned; the call jits it
                    return self._jit(flat)
                if code != 0:
                    warnings.warn(f"snapo: the helper process that traces {self._name} exited with {code}; "
                                  "it is traced by the call instead", stacklevel=1)
                    return None
            deserialised = program if program is not None else _read(path)
            if deserialised is None:
                return None
            with jax.default_matmul_precision(precision):
                return self._compiled(deserialised, leaves)

        # A helper is waited for in a thread of its own: waits in the pool (one thread per
        # core) would hold back the compiles of the programs traced here.
        _PREFETCHED[path] = _in_daemon_thread(prepare) if helper is not None else _prefetcher().submit(prepare)
        return on_disk


def _in_daemon_thread(fn: Callable) -> concurrent.futures.Future:
    """`fn()` in a daemon thread: an exit does not wait for it (the helper it waits for is
    killed at exit, `snapo_ode._runtime.export_helper`)."""
    future: concurrent.futures.Future = concurrent.futures.Future()

    def run():
        try:
            future.set_result(fn())
        except BaseException as error:  # noqa: BLE001 - handed to the caller through the future
            future.set_exception(error)

    threading.Thread(target=run, name="snapo-helper-wait", daemon=True).start()
    return future


@functools.cache
def _prefetcher() -> concurrent.futures.ThreadPoolExecutor:
    return concurrent.futures.ThreadPoolExecutor(max_workers=os.cpu_count() or 1,
                                                 thread_name_prefix="snapo-prefetch")


def exported(fn: Callable, *, name: str, static=None, compiler_options: dict | None = None) -> ExportedProgram:
    """`fn` (a function of pytrees, its array leaves traced, every other leaf static) as a
    program traced once and kept on disk; see the module docstring.

    **Arguments:**
    - `fn`: returns arrays in tuples, lists or dicts (what `jax.export` serialises).
    - `name`: the entry's name (letters, digits, `-`), e.g. "pharma-jacobian".
    - `static`: what `fn` closes over and its program depends on (a model, settings): part of
      the key, array values included. Arguments need not be listed: they are keyed by structure.
    - `compiler_options`: XLA options its executable is compiled with on a CPU (`jax.jit`'s;
      they key the executable in the compilation cache, not the entry), e.g. `QUICK_COMPILE`.
      On another backend, without a cache directory or for `Unkeyable` arguments
      (`equinox.filter_jit`), XLA's defaults.

    **Returns:** an `ExportedProgram`, a function of the same arguments (with `prefetch`).
    Without a compilation cache directory, or with an argument that cannot be keyed
    (`Unkeyable`: a closure, a traced value), it is `fn` jitted (`equinox.filter_jit`); for a
    closure with a warning, since every process then traces it.
    """
    return ExportedProgram(fn, name, static, compiler_options)
