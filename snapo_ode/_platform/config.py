"""Process-wide JAX settings, switched on explicitly: float64 and the persistent compilation cache.

Sensitivities and stiff solves need float64, and compile time is part of the user's time: the
persistent cache lets a second process reuse the first one's XLA executables. Both are global
JAX state, so importing `snapo_ode` does not set them (a library that changed them on import
would surprise users of other JAX code in the same process): `configure()` does, and is called
by the `snapo` CLI, the tests and the notebooks. An entry point that needs float64 calls
`require_float64`, which raises before anything is traced.
"""

import os
import pathlib

import jax

from .cache_trust import CacheUnavailable, directory_secret, install

CACHE_ENV = "SNAPO_CACHE_DIR"


class ConfigurationError(RuntimeError):
    """JAX is not configured as an entry point needs (float64 off)."""


def default_cache_dir() -> pathlib.Path:
    """The compilation cache directory: `$SNAPO_CACHE_DIR`, else `$XDG_CACHE_HOME/snapo-ode/jax`
    (`~/.cache/snapo-ode/jax` when XDG_CACHE_HOME is unset)."""
    explicit = os.environ.get(CACHE_ENV)
    if explicit:
        return pathlib.Path(explicit).expanduser()
    base = os.environ.get("XDG_CACHE_HOME") or pathlib.Path.home() / ".cache"
    return pathlib.Path(base) / "snapo-ode" / "jax"


def configure(cache_dir: str | os.PathLike | None = None, *, cache: bool = True) -> pathlib.Path | None:
    """Turn on float64 and (unless `cache=False`) the persistent compilation cache in
    `cache_dir` (default `default_cache_dir()`); returns the cache directory (or None).

    Every compiled executable is cached, however quick its compile, so that a second run of the
    same job compiles nothing. The directory is created private (mode 0700) and trusted only so
    far (`snapo_ode._platform.cache_trust`): one that others can write is refused, and every entry is
    sealed to its key, so a corrupt or swapped entry is rebuilt, never run. Call it before the
    first computation; calling it again is harmless.

    **Raises:** `CacheUnavailable` (an `OSError`) saying why and what to do, when the directory
    cannot be created or written, or others can write it (float64 is on by then)."""
    jax.config.update("jax_enable_x64", True)
    if not cache:
        return None
    path = pathlib.Path(cache_dir) if cache_dir is not None else default_cache_dir()
    try:
        path.mkdir(mode=0o700, parents=True, exist_ok=True)
        directory_secret(path)
    except CacheUnavailable:
        raise
    except OSError as error:
        raise CacheUnavailable(f"the compilation cache {str(path)!r} cannot be used ({error.strerror or error}): "
                               f"set {CACHE_ENV} to a writable directory of your own.") from None
    install()
    jax.config.update("jax_compilation_cache_dir", str(path))
    jax.config.update("jax_persistent_cache_min_compile_time_secs", 0.0)
    jax.config.update("jax_persistent_cache_min_entry_size_bytes", -1)
    return path


def require_float64(what: str) -> None:
    """Raise `ConfigurationError` unless float64 is on: `what` (e.g. "gas storage inputs")
    needs it for its sensitivities and solves."""
    if not jax.config.jax_enable_x64:
        raise ConfigurationError(
            f"{what} need float64, which is off: call snapo_ode.configure() first (or set the "
            "environment variable JAX_ENABLE_X64=1). In float32 a central bump's round-off and a "
            "stiff solve's tolerances are out of reach.")
