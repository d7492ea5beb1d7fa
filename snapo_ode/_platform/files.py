"""Atomic writes: a result is either fully on disk or not there at all, and the outputs of one
command form a set that a reader sees old or new, never mixed.

- `atomic_write_*`: one file, through a temporary file in the same directory and `os.replace`.
  A new file gets the permissions the umask allows (as `open` would give it); a replaced file
  keeps its mode.
- `publish`: several files: every one is serialised and written to a temporary file first, so a
  failure (a NaN refused by the JSON writer, a full disk) leaves the old set untouched; then they
  replace the old files in the order given, the index (the JSON that names the others, with their
  SHA-256) last.
- `publish_directory`: a whole directory (a report): written as a temporary sibling and swapped
  in, so the old directory or the new one is there, never a mix. Only an empty directory, or one
  this function wrote and nobody changed since, is replaced: its `MANIFEST.json` is this
  package's and it holds exactly the files the manifest lists, with their SHA-256. Anything else
  (a user's file beside the report, an edited report file, a MANIFEST.json of another tool) is
  refused with `InputError`, so a user's file is never deleted.

Symbolic links are written through (`output_target`): the link stays and its target gets the new
content, atomically. A target that exists and is not a regular file (a directory, a device such as
/dev/null, a named pipe, a socket) is refused with `InputError`: a result written into /dev/null
would be lost with exit 0, and a pipe without a reader would hang the run after its work was done.
"""

import hashlib
import json
import os
import pathlib
import shutil
import stat
import tempfile
from collections.abc import Mapping
from typing import Any

from .validation import InputError

MANIFEST = "MANIFEST.json"
WRITER = "snapo-ode publish_directory"  # the manifest's `written_by`


def _umask() -> int:
    mask = os.umask(0)
    os.umask(mask)
    return mask


def output_target(path: str | os.PathLike, what: str = "output") -> pathlib.Path:
    """The file a write to `path` replaces: `path` with every symbolic link followed.

    **Raises:** `InputError` naming `what` (e.g. "--json") when that file exists and is not a
    regular file (a directory, a device such as /dev/null, a named pipe or a socket)."""
    target = pathlib.Path(os.path.realpath(path))
    kind = _kind(target)
    if kind is not None:
        raise InputError(f"{what} = {str(path)!r}{f' (-> {str(target)!r})' if target != pathlib.Path(path) else ''} "
                         f"is {kind}, not a regular file; give the path of a file to write.")
    return target


def _kind(path: pathlib.Path) -> str | None:
    """What `path` is when it exists and is not a regular file ("a directory", "a named pipe", ...),
    else None. Never opens it (opening a pipe without a writer would block)."""
    try:
        mode = path.stat().st_mode
    except OSError:
        return None
    kinds = ((stat.S_ISREG, None), (stat.S_ISDIR, "a directory"), (stat.S_ISFIFO, "a named pipe"),
             (stat.S_ISCHR, "a character device"), (stat.S_ISBLK, "a block device"), (stat.S_ISSOCK, "a socket"))
    return next((kind for test, kind in kinds if test(mode)), "not a regular file")


def _write_temporary(path: pathlib.Path, data: bytes, mode: int | None = None) -> pathlib.Path:
    """`data` in a new temporary file beside `path`, flushed to disk, with `mode` (default: the
    mode `path` has, or the umask allows); returns the temporary path."""
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.", suffix=".tmp")
    try:
        with os.fdopen(fd, "wb") as handle:
            handle.write(data)
            handle.flush()
            os.fsync(handle.fileno())
        if mode is None:
            mode = path.stat().st_mode & 0o7777 if path.exists() else 0o666 & ~_umask()
        os.chmod(tmp, mode)
    except BaseException:
        pathlib.Path(tmp).unlink(missing_ok=True)
        raise
    return pathlib.Path(tmp)


def atomic_write_bytes(path: str | os.PathLike, data: bytes) -> pathlib.Path:
    """Write `data` to `path` through a temporary file in the same directory and `os.replace`."""
    path = output_target(path)
    tmp = _write_temporary(path, data)
    try:
        os.replace(tmp, path)
    except BaseException:
        tmp.unlink(missing_ok=True)
        raise
    return path


def create_whole(path: pathlib.Path, data: bytes, mode: int) -> None:
    """Write `data` to `path` with `mode` unless `path` exists, so that no reader, in this or
    another process, ever sees it part-written: a complete temporary file is hard-linked into
    place, and the link fails where another process got there first (that file is kept)."""
    tmp = _write_temporary(path, data, mode)
    try:
        os.link(tmp, path)
    except FileExistsError:
        pass
    finally:
        tmp.unlink()


def json_bytes(payload: Any) -> bytes:
    """`payload` as indented UTF-8 JSON. NaN and infinities are refused (`ValueError`)."""
    return (json.dumps(payload, indent=2, allow_nan=False) + "\n").encode("utf-8")


def atomic_write_text(path: str | os.PathLike, text: str) -> pathlib.Path:
    """Write UTF-8 `text` atomically."""
    return atomic_write_bytes(path, text.encode("utf-8"))


def atomic_write_json(path: str | os.PathLike, payload: Any) -> pathlib.Path:
    """Write `payload` as indented JSON atomically. NaN and infinities are refused."""
    return atomic_write_bytes(path, json_bytes(payload))


def sha256(data: bytes) -> str:
    return hashlib.sha256(data).hexdigest()


def publish(files: Mapping[str | os.PathLike, bytes]) -> list[pathlib.Path]:
    """Write several files as one set: all to temporary files first, then each replaces its
    target in the order given (put the index, the file naming the others, last). Returns the
    paths. Nothing is replaced if any temporary write fails."""
    temporaries: list[tuple[pathlib.Path, pathlib.Path]] = []
    try:
        for path, data in files.items():
            path = output_target(path)
            temporaries.append((_write_temporary(path, data), path))
        for tmp, path in temporaries:
            os.replace(tmp, path)
    finally:
        for tmp, _ in temporaries:
            tmp.unlink(missing_ok=True)
    return [path for _, path in temporaries]


def check_replaceable_directory(out: str | os.PathLike, what: str = "--out") -> pathlib.Path:
    """Raise `InputError` unless `out` is absent, an empty directory, or one `publish_directory`
    wrote and nobody changed since (`_not_ours`): anything else would be deleted by the swap.
    Also refuses an existing file and a parent that cannot be written. Call it before computing."""
    out = pathlib.Path(out)
    if out.exists() and not out.is_dir():
        kind = "is an existing file" if out.is_file() else "exists and is not a directory"
        raise InputError(f"{what} = {str(out)!r} {kind}; give a directory.")
    if out.is_dir() and any(out.iterdir()):
        reason = _not_ours(out)
        if reason is not None:
            raise InputError(f"{what} = {str(out)!r} {reason}; it would be replaced whole, so nothing is written: "
                             "give a new or empty directory, or move that file away.")
    check_writable_under(out.resolve().parent, what)
    return out


def _not_ours(out: pathlib.Path) -> str | None:
    """Why the directory `out` is not one `publish_directory` wrote as it stands, or None: its
    manifest must be this package's, and the directory must hold exactly the files it lists,
    each with its SHA-256."""
    try:
        manifest = json.loads((out / MANIFEST).read_bytes())
    except FileNotFoundError:
        return f"holds files that no earlier run wrote (no {MANIFEST})"
    except (OSError, ValueError, RecursionError):
        return f"holds a {MANIFEST} that this package did not write"
    listed = manifest.get("files") if isinstance(manifest, dict) else None
    if (manifest.get("written_by") if isinstance(manifest, dict) else None) not in (WRITER, None) or not (
            isinstance(listed, dict) and all(isinstance(v, str) for v in listed.values())):
        return f"holds a {MANIFEST} that this package did not write"
    for entry in sorted(out.iterdir()):
        if entry.name != MANIFEST and entry.name not in listed:
            return f"holds {entry.name!r}, which its {MANIFEST} does not list (a file no earlier report wrote)"
    for name, digest in listed.items():
        path = out / name
        if pathlib.Path(name).name != name or path.is_symlink() or not path.is_file():
            return f"lacks {name!r}, which its {MANIFEST} lists"
        if sha256(path.read_bytes()) != digest:
            return f"holds {name!r}, changed since the report was written (its SHA-256 is not its {MANIFEST}'s)"
    return None


def check_writable_under(directory: str | os.PathLike, what: str) -> None:
    """Raise `InputError` (naming the flag `what`) unless files can be created in `directory`:
    its nearest existing ancestor must be a writable directory, not a file."""
    path = pathlib.Path(directory)
    while not path.exists():
        path = path.parent
    if not path.is_dir():
        raise InputError(f"{what}: {str(path)!r} is a file, so nothing can be written under it.")
    if not os.access(path, os.W_OK | os.X_OK):
        raise InputError(f"{what}: the directory {str(path)!r} is not writable.")


def publish_directory(out: str | os.PathLike, files: Mapping[str, bytes]) -> list[pathlib.Path]:
    """Write `files` (name -> bytes) as the directory `out`, with a MANIFEST.json (the SHA-256 of
    each file): built as a temporary sibling, then swapped in for the old directory, so a reader
    sees the old set or the new one. `out` must pass `check_replaceable_directory`."""
    out = pathlib.Path(os.path.realpath(check_replaceable_directory(out)))  # a link to it stays a link
    out.parent.mkdir(parents=True, exist_ok=True)
    staging = pathlib.Path(tempfile.mkdtemp(dir=out.parent, prefix=f".{out.name}.", suffix=".tmp"))
    try:
        os.chmod(staging, 0o777 & ~_umask())
        manifest = {"written_by": WRITER, "files": {name: sha256(data) for name, data in files.items()}}
        for name, data in {**files, MANIFEST: json_bytes(manifest)}.items():
            atomic_write_bytes(staging / name, data)
        if out.exists():
            retired = pathlib.Path(tempfile.mkdtemp(dir=out.parent, prefix=f".{out.name}.", suffix=".old"))
            retired.rmdir()
            os.replace(out, retired)
            os.replace(staging, out)
            shutil.rmtree(retired, ignore_errors=True)
        else:
            os.replace(staging, out)
    except BaseException:
        shutil.rmtree(staging, ignore_errors=True)
        raise
    return [out / name for name in files]
