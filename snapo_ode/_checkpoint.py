"""Training checkpoints: one file, written atomically, holding a JSON line (`CheckpointInfo`: the
progress, the history and the run's fingerprint, and `checksum`) and the parameters and optimizer
state (equinox-serialised). A checkpoint is read like any user file: its checksum (the SHA-256 of
the header without it and of every byte after it) must match, so a changed or damaged byte is
refused rather than resumed; its header is checked by a schema; and a run resumes from it only
when its fingerprint (`snapo_ode._fingerprint`) is the run's own."""

import hashlib
import io
import json
import os

import equinox as eqx
import pydantic

from ._fingerprint import differences
from ._platform.files import atomic_write_bytes
from ._platform.schema import STRICT_SCHEMA, validate
from ._platform.validation import InputError

MAX_HEADER_BYTES = 64 * 2**20
CHECKSUM = "checksum"


def _checksum(header: bytes, payload: bytes) -> str:
    """`sha256:` and the hex SHA-256 of the header line (without its checksum) and the payload."""
    return "sha256:" + hashlib.sha256(header + b"\n" + payload).hexdigest()


class CheckpointInfo(pydantic.BaseModel):
    """The header of a checkpoint: `next_step` (steps done), `steps` (of the whole run),
    `history` (per step, the loss and each metric), `best_loss`, `since_best` (steps since it),
    `stopped_early`, and `fingerprint` (part -> digest, see `run_fingerprint`)."""

    model_config = STRICT_SCHEMA
    next_step: pydantic.NonNegativeInt
    steps: pydantic.PositiveInt
    history: dict[str, list[float]]
    best_loss: float | None
    since_best: pydantic.NonNegativeInt
    stopped_early: bool
    fingerprint: dict[str, str] = {}

    @pydantic.model_validator(mode="after")
    def _consistent(self):
        if self.next_step > self.steps:
            raise ValueError(f"next_step = {self.next_step} exceeds steps = {self.steps}")
        lengths = {name: len(values) for name, values in self.history.items()}
        if lengths.get("loss") != self.next_step or len(set(lengths.values())) > 1:
            raise ValueError(f"the history's lengths {lengths} must all equal next_step = {self.next_step}")
        return self


def save_checkpoint(path: str | os.PathLike, best_params, info: dict, resume_state=None) -> None:
    """Write a checkpoint atomically, as one file: `info` (a JSON line, `CheckpointInfo`'s
    fields), the `best_params` (equinox-serialised), and the `resume_state` (the current
    parameters and optimizer state, which a resumed run continues from)."""
    buffer = io.BytesIO()
    eqx.tree_serialise_leaves(buffer, best_params)
    if resume_state is not None:
        eqx.tree_serialise_leaves(buffer, resume_state)
    info = {name: value for name, value in info.items() if name != CHECKSUM}
    payload = buffer.getvalue()
    checksum = _checksum(json.dumps(info, allow_nan=False).encode(), payload)
    atomic_write_bytes(path, json.dumps({**info, CHECKSUM: checksum}, allow_nan=False).encode() + b"\n" + payload)


def _verified(handle, where: str) -> tuple[dict, io.BytesIO]:
    """The header (without its checksum) and the payload of the open checkpoint `handle`, once
    the checksum matches."""
    try:
        header = json.loads(handle.readline(MAX_HEADER_BYTES))
    except (ValueError, RecursionError):
        raise InputError(f"{where}: the first line is not a checkpoint's JSON header.") from None
    if not isinstance(header, dict) or not isinstance(header.get(CHECKSUM), str):
        raise InputError(f"{where} has no checksum: it was not written by this version of snapo-ode, or is not "
                         "a checkpoint.")
    saved = header.pop(CHECKSUM)
    payload = handle.read()
    try:
        checksum = _checksum(json.dumps(header, allow_nan=False).encode(), payload)
    except ValueError:
        checksum = None
    if checksum != saved:
        raise InputError(f"{where} is corrupt: its checksum ({saved[:24]!r}) does not match its content (changed or "
                         "damaged since it was written).")
    return header, io.BytesIO(payload)


def load_checkpoint(path: str | os.PathLike, like, resume_like=None):
    """Read a checkpoint written by `save_checkpoint`: `(best_params, info)` shaped like `like`,
    or with `resume_like` `(best_params, info, resume_state)`; `info` a dict of
    `CheckpointInfo`'s fields.

    **Raises:** `InputError` naming the file when it is not such a checkpoint (unreadable, no
    checksum or one that does not match, a header the schema refuses, parameters of another
    shape)."""
    where = f"checkpoint {str(path)!r}"
    try:
        with open(path, "rb") as handle:
            header, payload = _verified(handle, where)
        info = validate(CheckpointInfo, header, where).model_dump()
        best = eqx.tree_deserialise_leaves(payload, like)
        if resume_like is None:
            return best, info
        return best, info, eqx.tree_deserialise_leaves(payload, resume_like)
    except InputError as error:
        raise InputError(f"{error} Delete it or drop --resume.") from None
    except (OSError, ValueError, RuntimeError, KeyError, TypeError, EOFError) as error:
        raise InputError(f"{where} cannot be read ({' '.join(str(error).split()) or type(error).__name__}); "
                         "delete it or drop --resume.") from None


def check_same_run(path: str | os.PathLike, info: dict, fingerprint: dict[str, str]) -> None:
    """Raise `InputError` unless the checkpoint at `path` (header `info`) was written by a run
    with this `fingerprint`, naming the parts that differ."""
    differ = differences(info["fingerprint"], fingerprint)
    if differ:
        raise InputError(f"checkpoint {str(path)!r} is of another run: its {', '.join(differ)} differ from this "
                         "run's; resume with the same inputs and settings, or delete it (or give another "
                         "--checkpoint).")
