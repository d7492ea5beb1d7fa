"""Size estimates before large allocations: a run that cannot fit in memory is refused with its
estimate and the limit, before anything is allocated or compiled, instead of allocating until the
operating system kills it."""

import os

from .validation import InputError

GIB = 1024**3


def available_memory() -> int:
    """Bytes of memory available to a new allocation (Linux's MemAvailable; else the physical
    memory)."""
    try:
        with open("/proc/meminfo") as handle:
            for line in handle:
                if line.startswith("MemAvailable:"):
                    return int(line.split()[1]) * 1024
    except OSError:
        pass
    return os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES")


def check_memory(what: str, needed: float, advice: str, *, limit: float | None = None) -> None:
    """Raise `InputError` when `needed` bytes (an estimate of the run's peak) exceed `limit`
    (default: 90% of `available_memory()`), naming both and how to shrink the run."""
    limit = 0.9 * available_memory() if limit is None else limit
    if needed > limit:
        raise InputError(f"{what} needs about {needed / GIB:.1f} GiB of memory (estimated), more than the "
                         f"{limit / GIB:.1f} GiB available; {advice}")


MAPPINGS_FRACTION = 0.5
"""Share of the kernel's mapping limit at which `relieve_mappings` drops the compiled programs."""
COMPILE_EVENT = "/jax/core/compile/backend_compile_duration"
"""JAX's monitoring event of one executable made, compiled or read from the persistent cache
(`jax._src.dispatch.BACKEND_COMPILE_EVENT`): what adds mappings."""
_compiled_since_check = True
_listening = False


def memory_mappings() -> tuple[int, int] | None:
    """(this process's memory mappings, the kernel's limit `vm.max_map_count`), or None where
    /proc does not tell (not Linux)."""
    try:
        with open("/proc/self/maps", "rb") as maps, open("/proc/sys/vm/max_map_count") as limit:
            return maps.read().count(b"\n"), int(limit.read())
    except OSError:
        return None


def relieve_mappings(fraction: float = MAPPINGS_FRACTION) -> bool:
    """Drop JAX's compiled programs (`jax.clear_caches()`) once this process holds more than
    `fraction` of the kernel's memory-mapping limit; returns whether it did.

    Why: every program XLA compiles for the CPU stays mapped while JAX's caches hold it, in
    over a thousand mappings for one stiff ignition solve and its gradient (docs/architecture.md
    gives the count), and nothing else frees it. A process that compiles a few dozen such programs
    (a bench across tolerances, a test worker) reaches Linux's default limit of 65,530 mappings,
    and XLA then dies in its compiler ("LLVM ERROR: Unable to allocate section memory", or a
    segmentation fault).
    After the drop, a program used again is compiled again, or read from the persistent cache."""
    counts = memory_mappings()
    if counts is None or counts[0] <= fraction * counts[1]:
        return False
    import jax

    jax.clear_caches()
    return True


def relieve_mappings_after_compiles() -> bool:
    """`relieve_mappings()` when JAX has made an executable (compiled, or read from the
    persistent cache) since the last such call, else nothing: the form for hot paths (`call_checked`, `time_function`). Mappings grow only with
    compiles, and reading /proc/self/maps takes long enough at tens of thousands of mappings
    (docs/architecture.md) that a check on every call would add it to every timed solve."""
    global _compiled_since_check, _listening
    if not _listening:
        import jax

        jax.monitoring.register_event_duration_secs_listener(_note_compile)
        _listening = True
    if not _compiled_since_check:
        return False
    _compiled_since_check = False
    return relieve_mappings()


def _note_compile(event: str, duration: float, **kwargs) -> None:
    global _compiled_since_check
    if event == COMPILE_EVENT:
        _compiled_since_check = True
