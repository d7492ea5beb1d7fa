"""Process-wide JAX settings: float64 and the persistent compilation cache.

Sensitivities and stiff solves need float64, and compile time is part of the user's time: the
persistent cache lets a second process reuse the first one's XLA executables.
"""

import os
import pathlib

import jax

CACHE_ENV = "SNAPO_CACHE_DIR"


def default_cache_dir() -> pathlib.Path:
    """The compilation cache directory: `$SNAPO_CACHE_DIR`, else `$XDG_CACHE_HOME/snapo-ode/jax`
    (`~/.cache/snapo-ode/jax` when XDG_CACHE_HOME is unset)."""
    explicit = os.environ.get(CACHE_ENV)
    if explicit:
        return pathlib.Path(explicit).expanduser()
    base = os.environ.get("XDG_CACHE_HOME") or pathlib.Path.home() / ".cache"
    return pathlib.Path(base) / "snapo-ode" / "jax"


def configure(cache_dir: str | os.PathLike | None = None) -> pathlib.Path:
    """Turn on float64 and the persistent compilation cache; returns the cache directory.

    Called once on `import snapo_ode`. Every compiled executable is cached, however quick its
    compile, so that a second run of the same job compiles nothing.
    """
    jax.config.update("jax_enable_x64", True)
    path = pathlib.Path(cache_dir) if cache_dir is not None else default_cache_dir()
    path.mkdir(parents=True, exist_ok=True)
    jax.config.update("jax_compilation_cache_dir", str(path))
    jax.config.update("jax_persistent_cache_min_compile_time_secs", 0.0)
    jax.config.update("jax_persistent_cache_min_entry_size_bytes", -1)
    return path
