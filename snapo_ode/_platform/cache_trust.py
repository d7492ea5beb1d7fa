"""How far the on-disk caches are trusted: a cache entry is native code (an XLA executable) or a
program this process will run, so whoever can write the cache directory controls the results.

- **Private directory.** `check_private` refuses a cache directory that another user owns or
  that its group or others can write (mode `g+w` or `o+w`), with the `chmod` that fixes it;
  `configure` creates the directory with mode 0700.
- **Sealed entries.** Every entry carries an HMAC-SHA256 of its key and its bytes under a secret
  kept in the directory (`SEAL_KEY`, mode 0600, created whole on first use: processes that open
  a new cache at once share one key). An entry that fails the check (truncated, altered, or
  another key's entry copied under this key's name) is a miss: it is rebuilt, and the rebuilt
  entry replaces it, with one warning.
- A sealed store is the JAX compilation cache's (`install`, through JAX's
  `compilation_cache.get_file_cache`, a private hook of the JAX releases we admit); the export cache
  (`snapo_ode._runtime.exported`) seals its entries with `seal` / `unseal` too.
"""

import hashlib
import hmac
import os
import pathlib
import secrets
import stat
import warnings

from .files import atomic_write_bytes, create_whole

SEAL_KEY = ".snapo-seal-key"
TAG_BYTES = 32
_SUFFIX = "-sealed"


class CacheUnavailable(OSError):
    """The compilation cache cannot be used: not a writable directory, writable by others, or its
    seal key not private. The message says why and what to do."""


def check_private(directory: pathlib.Path) -> None:
    """Raise `CacheUnavailable` unless `directory` is owned by this user and writable by no one else."""
    info = directory.stat()
    if hasattr(os, "getuid") and info.st_uid != os.getuid():
        raise CacheUnavailable(f"the cache directory {str(directory)!r} belongs to another user (uid {info.st_uid}); "
                             "its entries would run as your code: set SNAPO_CACHE_DIR to a directory of your own.")
    if info.st_mode & (stat.S_IWGRP | stat.S_IWOTH):
        raise CacheUnavailable(f"the cache directory {str(directory)!r} is writable by others (mode "
                             f"{stat.S_IMODE(info.st_mode):o}); its entries would run as your code: "
                             f"`chmod go-w {directory}` or set SNAPO_CACHE_DIR to a private directory.")


def _secret(directory: pathlib.Path) -> bytes:
    path = directory / SEAL_KEY
    if not path.exists():
        create_whole(path, secrets.token_bytes(TAG_BYTES), 0o600)
    info = path.lstat()
    if not stat.S_ISREG(info.st_mode) or info.st_mode & 0o077 or info.st_size != TAG_BYTES:
        raise CacheUnavailable(f"the cache's seal key {str(path)!r} is not a private {TAG_BYTES}-byte file (mode "
                             f"{stat.S_IMODE(info.st_mode):o}): delete it and the cache is rebuilt.")
    return path.read_bytes()


def seal(secret: bytes, key: str, value: bytes) -> bytes:
    """`value` followed by its tag under `secret`, bound to `key`."""
    return value + hmac.new(secret, key.encode() + b"\0" + value, hashlib.sha256).digest()


def unseal(secret: bytes, key: str, data: bytes) -> bytes | None:
    """The value `seal` sealed under `key`, or None when the tag does not match."""
    value, tag = data[:-TAG_BYTES], data[-TAG_BYTES:]
    expected = hmac.new(secret, key.encode() + b"\0" + value, hashlib.sha256).digest()
    return value if len(data) >= TAG_BYTES and hmac.compare_digest(tag, expected) else None


def directory_secret(directory: str | os.PathLike) -> bytes:
    """The seal key of the private cache `directory` (checked with `check_private`)."""
    directory = pathlib.Path(directory)
    check_private(directory)
    return _secret(directory)


def _refused(path: pathlib.Path) -> None:
    warnings.warn(f"snapo: cache entry {path.name} failed its seal check (truncated, altered or swapped); "
                  "it is rebuilt", stacklevel=3)


def read_sealed(secret: bytes, path: pathlib.Path) -> bytes | None:
    """The sealed file `path`'s value (its name is its key), None if absent or failing the
    check (then with a warning: the caller rebuilds it and `write_sealed` replaces it)."""
    try:
        data = path.read_bytes()
    except FileNotFoundError:
        return None
    value = unseal(secret, path.name, data)
    if value is None:
        _refused(path)
    return value


def write_sealed(secret: bytes, path: pathlib.Path, value: bytes) -> None:
    """Write `value` sealed under `path`'s name, atomically (replacing any entry there)."""
    atomic_write_bytes(path, seal(secret, path.name, value))


def _sealed_cache_class():
    """`SealedCache`, built on JAX's (private) cache interface when first needed."""
    from jax._src.compilation_cache_interface import CacheInterface

    class SealedCache(CacheInterface):
        """JAX's compilation-cache store over a private directory, every entry sealed (see the
        module docstring); entries are written atomically and never evicted (as JAX's default)."""

        def __init__(self, directory: str | os.PathLike):
            self._path = pathlib.Path(directory)
            self._secret = directory_secret(self._path)

        def get(self, key: str) -> bytes | None:
            return read_sealed(self._secret, self._path / f"{key}{_SUFFIX}")

        def put(self, key: str, value: bytes) -> None:
            write_sealed(self._secret, self._path / f"{key}{_SUFFIX}", value)

        def clear(self) -> None:
            for entry in self._path.glob(f"*{_SUFFIX}"):
                entry.unlink(missing_ok=True)

    return SealedCache


def install() -> None:
    """Make JAX's persistent compilation cache a sealed store (before its first use).

    **Raises:** `CacheUnavailable` when this JAX has no such hook (a release other than those
    `pyproject.toml` admits): its cache would run entries unchecked."""
    try:
        from jax._src import compilation_cache

        sealed = _sealed_cache_class()
        if not callable(getattr(compilation_cache, "get_file_cache", None)):
            raise AttributeError("jax._src.compilation_cache.get_file_cache")
    except (ImportError, AttributeError) as error:
        raise CacheUnavailable(f"this JAX release cannot seal its compilation cache ({error}); install a JAX that "
                               "pyproject.toml admits to use the cache.") from None
    compilation_cache.get_file_cache = lambda path: (sealed(path), path)
