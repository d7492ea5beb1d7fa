"""Size estimates before large allocations: a run that cannot fit in memory is refused with its
estimate and the limit, before anything is allocated or compiled, instead of allocating until the
operating system kills it."""

import os

from ._validation import InputError

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
