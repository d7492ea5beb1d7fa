"""Fingerprints of what defines a run, so that a checkpoint is resumed only by the run that wrote it.

A fingerprint is a mapping from a part's name (`inputs`, `settings`, `seed`, ...) to a digest of
its value: the SHA-256 of its pytree structure and of every leaf (array leaves by dtype, shape and
bytes; other leaves, and static data, by `repr` with sets sorted and memory addresses removed,
so that the digest is the same in every process). `versions` (this package and the numerical stack it runs on) is always added, in
words, so that a mismatch can be shown. Within `reading_files(files)` (the command line sets it
around a command), each input file's content is a part as well (`file --scenarios`: the SHA-256 of
its bytes), so a checkpoint trained on one file is not resumed on another, whatever was made of
the file on the way. `differences(saved, current)` names the parts that differ.
"""

import contextlib
import contextvars
import hashlib
import os
import re
from collections.abc import Iterator, Mapping

import jax
import numpy as np

from ._platform.versions import in_words

_ADDRESS = re.compile(r" at 0x[0-9a-fA-F]+")
_INPUT_FILES: contextvars.ContextVar[Mapping[str, str]] = contextvars.ContextVar("input_files", default={})


def package_versions() -> str:
    """`"snapo-ode 0.1.0, jax 0.10.2, ..."`: the packages whose change may change a result."""
    return in_words()


def _stable(value) -> str:
    """`repr` that is the same in every process: sets sorted, addresses removed."""
    if isinstance(value, (set, frozenset)):
        return "{" + ", ".join(sorted(map(_stable, value))) + "}"
    if isinstance(value, (tuple, list)):
        return f"{type(value).__name__}(" + ", ".join(map(_stable, value)) + ")"
    if isinstance(value, dict):
        return "{" + ", ".join(sorted(f"{_stable(k)}: {_stable(v)}" for k, v in value.items())) + "}"
    return _ADDRESS.sub("", repr(value))


def _structure(structure) -> str:
    """The pytree structure in words, each node's static data by `_stable`."""
    data = structure.node_data()
    if data is None:
        return "*"
    kind, static = data
    return f"{kind.__qualname__}[{_stable(static)}](" + ", ".join(map(_structure, structure.children())) + ")"


def _feed(digest, value) -> None:
    leaves, structure = jax.tree.flatten(value)
    digest.update(_structure(structure).encode())
    for leaf in leaves:
        if isinstance(leaf, jax.Array) and jax.dtypes.issubdtype(leaf.dtype, jax.dtypes.prng_key):
            leaf = jax.random.key_data(leaf)
        if isinstance(leaf, (np.ndarray, np.generic, jax.Array)):
            array = np.ascontiguousarray(np.asarray(leaf))
            digest.update(f"{array.dtype.str}{array.shape}".encode())
            digest.update(array.tobytes())
        else:
            digest.update(_stable(leaf).encode())


def digest_of(value) -> str:
    """A 16-hex-digit digest of `value` (any pytree; non-array leaves by `repr`)."""
    digest = hashlib.sha256()
    _feed(digest, value)
    return digest.hexdigest()[:16]


def file_digest(path: str | os.PathLike) -> str:
    """A 16-hex-digit digest of the bytes of the file at `path`."""
    digest = hashlib.sha256()
    with open(path, "rb") as handle:
        for block in iter(lambda: handle.read(2**20), b""):
            digest.update(block)
    return digest.hexdigest()[:16]


@contextlib.contextmanager
def reading_files(files: Mapping[str, str | os.PathLike]) -> Iterator[None]:
    """Within it, every `run_fingerprint` holds `file NAME`, the `file_digest` of each input file
    (name, e.g. a flag, -> path), as read on entering."""
    token = _INPUT_FILES.set({f"file {name}": file_digest(path) for name, path in files.items()})
    try:
        yield
    finally:
        _INPUT_FILES.reset(token)


def run_fingerprint(parts: Mapping[str, object]) -> dict[str, str]:
    """The fingerprint of a run defined by `parts` (name -> value): each part's `digest_of`, the
    input files' digests (see `reading_files`), and `versions`, the `package_versions` in words."""
    return {**{name: digest_of(value) for name, value in parts.items()}, **_INPUT_FILES.get(),
            "versions": package_versions()}


def differences(saved: Mapping[str, str], current: Mapping[str, str]) -> list[str]:
    """The names of the parts whose digests differ (or that only one side has), sorted; for
    `versions`, the versions as well (`versions (jax 0.10.1 -> 0.10.2)`)."""
    names = sorted(set(saved) | set(current))
    out = []
    for name in names:
        if saved.get(name) == current.get(name):
            continue
        if name == "versions" and name in saved and name in current:
            changed = [f"{old} -> {new.split(' ', 1)[1]}" for old, new in zip(saved[name].split(", "),
                                                                                current[name].split(", "))
                       if old != new]
            out.append(f"versions ({'; '.join(changed) or saved[name]})")
        else:
            out.append(name)
    return out
