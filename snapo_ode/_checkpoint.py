"""Training checkpoints: one file, written atomically, holding a JSON line (`CheckpointInfo`: the
progress, the history and the run's fingerprint) and the parameters and optimizer state
(equinox-serialised). A checkpoint is read like any user file: its header is checked by a schema,
and a run resumes from it only when its fingerprint (`snapo_ode._fingerprint`) is the run's own."""

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
    atomic_write_bytes(path, json.dumps(info, allow_nan=False).encode() + b"\n" + buffer.getvalue())


def load_checkpoint(path: str | os.PathLike, like, resume_like=None):
    """Read a checkpoint written by `save_checkpoint`: `(best_params, info)` shaped like `like`,
    or with `resume_like` `(best_params, info, resume_state)`; `info` a dict of
    `CheckpointInfo`'s fields.

    **Raises:** `InputError` naming the file when it is not such a checkpoint (unreadable, a
    header the schema refuses, parameters of another shape)."""
    where = f"checkpoint {str(path)!r}"
    try:
        with open(path, "rb") as handle:
            try:
                header = json.loads(handle.readline(MAX_HEADER_BYTES))
            except (ValueError, RecursionError):
                raise InputError(f"{where}: the first line is not a checkpoint's JSON header.") from None
            info = validate(CheckpointInfo, header, where).model_dump()
            best = eqx.tree_deserialise_leaves(handle, like)
            if resume_like is None:
                return best, info
            return best, info, eqx.tree_deserialise_leaves(handle, resume_like)
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
