"""Wall-clock timing of JAX functions: compile time apart from the median steady-state run.

The one timing convention of the project (every benchmark and every JSON): `median_seconds` is
the median of `repeats` calls after a first call, and `compile_seconds` is that first call's
time less the median: tracing plus compiling, or loading from the persistent cache, which is
what a user waits for before the first result."""

import statistics
import time
from collections.abc import Callable
from typing import Any, NamedTuple

import jax

from ._platform.resources import relieve_mappings_after_compiles


class Timing(NamedTuple):
    """`first_call_seconds` includes tracing and compiling (or loading from the persistent
    cache); `compile_seconds` is that minus the median run; `median_seconds` is the median of
    `repeats` runs after the first."""

    median_seconds: float
    compile_seconds: float
    first_call_seconds: float
    runs: tuple[float, ...]


def _call(fn: Callable, args, kwargs) -> tuple[float, Any]:
    start = time.perf_counter()
    out = jax.block_until_ready(fn(*args, **kwargs))
    return time.perf_counter() - start, out


def time_function(fn: Callable, *args, repeats: int = 5, **kwargs) -> tuple[Timing, Any]:
    """Time a jitted `fn(*args, **kwargs)`: one warm-up call, then `repeats` timed calls.

    Returns the `Timing` and the function's output. A bench compiles one program per setting:
    before it compiles, old programs are dropped once the process nears the kernel's limit on
    memory mappings (`snapo_ode.relieve_mappings`, checked after compiles).
    """
    relieve_mappings_after_compiles()
    first, out = _call(fn, args, kwargs)
    runs = tuple(_call(fn, args, kwargs)[0] for _ in range(max(repeats, 1)))
    median = statistics.median(runs)
    return Timing(median, max(first - median, 0.0), first, runs), out


def time_once(fn: Callable, *args, **kwargs) -> tuple[float, Any]:
    """Wall time of one call of `fn(*args, **kwargs)` (compile included, outputs ready) and the
    outputs: for runs too long to repeat, reported as such."""
    return _call(fn, args, kwargs)


def compiled_temp_bytes(fn: Callable, *args) -> int:
    """XLA's temporary memory [bytes] of `fn` (a `jax.jit` or `equinox.filter_jit` function)
    compiled for `args`: the working memory beyond its inputs and outputs, e.g. what a reverse
    pass keeps at its checkpoints. Compiles (or loads from the persistent cache); runs nothing."""
    lowered = fn.lower(*args)
    lowered = getattr(lowered, "lowered", lowered)  # equinox wraps JAX's Lowered
    return int(lowered.compile().memory_analysis().temp_size_in_bytes)
