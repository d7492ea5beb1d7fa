"""Provenance of a result: the package versions, the code's git commit (and whether the tree had
uncommitted changes), a SHA-256 of every input, the command line and the UTC time."""

import datetime
import hashlib
import json
import pathlib
import platform
import subprocess
from collections.abc import Mapping, Sequence
from importlib.metadata import PackageNotFoundError, version
from typing import Any

PACKAGES = ("snapo-ode", "jax", "jaxlib", "diffrax", "equinox", "optax", "numpy", "scipy", "matplotlib")


def input_digest(value: Any) -> str:
    """SHA-256 of bytes, of a file's content (a `pathlib.Path`), or of anything JSON-ready
    (canonical JSON: sorted keys)."""
    from .results import jsonable

    if isinstance(value, pathlib.Path):
        value = value.read_bytes()
    if not isinstance(value, bytes):
        value = json.dumps(jsonable(value), sort_keys=True).encode()
    return hashlib.sha256(value).hexdigest()


def git_state(directory: pathlib.Path | None = None) -> tuple[str | None, bool | None]:
    """(commit, dirty) of the git tree holding `directory` (default: this package's), or
    (None, None) outside one."""
    root = directory or pathlib.Path(__file__).resolve().parents[2]
    try:
        commit = subprocess.run(["git", "rev-parse", "HEAD"], cwd=root, capture_output=True, text=True,
                                check=True, timeout=30).stdout.strip()
        dirty = bool(subprocess.run(["git", "status", "--porcelain", "--untracked-files=no"], cwd=root,
                                    capture_output=True, text=True, check=True, timeout=30).stdout.strip())
    except (OSError, subprocess.SubprocessError):
        return None, None
    return commit or None, dirty


def provenance(inputs: Mapping[str, Any], *, packages: Sequence[str] = (), command: Sequence[str] | None = None
               ) -> dict:
    """`packages` (versions of `PACKAGES` and the extra `packages`; None where not installed),
    `python`, `platform`, `git_commit`, `git_dirty`, `command` (the command line, when given),
    `timestamp_utc`, and `input_sha256` (name -> `input_digest` of each of `inputs`)."""
    versions = {}
    for name in dict.fromkeys([*PACKAGES, *packages]):
        try:
            versions[name] = version(name)
        except PackageNotFoundError:
            versions[name] = None
    commit, dirty = git_state()
    return {
        "packages": versions, "python": platform.python_version(), "platform": platform.platform(),
        "git_commit": commit, "git_dirty": dirty, "command": " ".join(command) if command else None,
        "timestamp_utc": datetime.datetime.now(datetime.timezone.utc).isoformat(timespec="seconds"),
        "input_sha256": {name: input_digest(value) for name, value in inputs.items()},
    }
