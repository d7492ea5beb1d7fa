"""How a `snapo` command ends: one exit-code contract for every failure, each one line on stderr
(`snapo: error: ...`; `--debug` shows the traceback instead).

- 0 success;
- 2 a user mistake: `InputError` (naming the field, the value and what is allowed), an input
  nested too deeply to read (`RecursionError`);
- 3 a failed solve or training: `SolverFailed`, `TrainingDiverged`, with advice, and any
  non-finite result found after a computation (`FloatingPointError`);
- 4 the environment: a full disk, an unwritable or untrusted cache or output (`OSError`,
  `CacheUnavailable`), memory exhausted (`MemoryError`), with advice;
- 130 interrupted by SIGINT (Ctrl-C), 143 by SIGTERM (what `timeout`, SLURM and `docker stop`
  send). SIGTERM is raised in the run as `Terminated`, a `KeyboardInterrupt`, so both save the
  training checkpoint and remove temporary files; the line says how to resume.

Without `SNAPO_CACHE_DIR`, a default cache directory that cannot be used is a warning and the run
goes on without the persistent cache (`configure_or_warn`); a `SNAPO_CACHE_DIR` that cannot be
used is exit 4.
"""

import errno
import os
import pathlib
import signal
import sys
import threading
from collections.abc import Callable

from .._platform.validation import InputError

EXIT_INPUT_ERROR = 2
EXIT_SOLVER_FAILED = 3
EXIT_ENVIRONMENT = 4
EXIT_SIGINT, EXIT_SIGTERM = 130, 143
_ADVICE = {errno.ENOSPC: "free some space or write elsewhere (--out, --json)",
           errno.EDQUOT: "free some of your quota or write elsewhere (--out, --json)",
           errno.EROFS: "the file system is read-only: write elsewhere (--out, --json, SNAPO_CACHE_DIR)",
           errno.EACCES: "permission denied: write elsewhere (--out, --json, SNAPO_CACHE_DIR)",
           errno.EPERM: "not permitted: write elsewhere (--out, --json, SNAPO_CACHE_DIR)"}


class Terminated(KeyboardInterrupt):
    """SIGTERM, raised in the main thread like Ctrl-C's `KeyboardInterrupt`."""


def _terminate(signum, frame):
    raise Terminated()


def _environment_message(error: OSError) -> str:
    from .._platform.cache_trust import CacheUnavailable

    if isinstance(error, CacheUnavailable):
        return str(error)
    where = f"{error.filename}: " if error.filename else ""
    advice = _ADVICE.get(error.errno, "check the path and the machine's resources")
    return f"{where}{error.strerror or error}; {advice}."


_FAILED_RUNS = ("snapo_ode._ode.SolverFailed", "snapo_ode._training.TrainingDiverged")


def _message(error: Exception) -> tuple[str, int] | None:
    """The line and exit code of `error`, or None for an error outside the contract (a bug)."""
    if isinstance(error, InputError):
        return str(error), EXIT_INPUT_ERROR
    if isinstance(error, RecursionError):
        return "an input is nested too deeply to read; give a flat table or file.", EXIT_INPUT_ERROR
    if isinstance(error, OSError):
        return _environment_message(error), EXIT_ENVIRONMENT
    if isinstance(error, MemoryError):
        return "out of memory; use fewer paths or points, or a larger machine.", EXIT_ENVIRONMENT
    if isinstance(error, FloatingPointError):
        return str(error), EXIT_SOLVER_FAILED
    # By name: importing the solver or the trainer here would import JAX before the outputs are checked.
    if any(f"{kind.__module__}.{kind.__qualname__}" in _FAILED_RUNS for kind in type(error).__mro__):
        return str(error), EXIT_SOLVER_FAILED
    return None


def _interrupted(error: KeyboardInterrupt, checkpoint) -> int:
    name, code = ("SIGTERM", EXIT_SIGTERM) if isinstance(error, Terminated) else ("SIGINT", EXIT_SIGINT)
    saved = (f"; the training so far is in {str(checkpoint)!r}: run the same command with --resume to go on"
             if checkpoint is not None and pathlib.Path(checkpoint).exists() else "; no result was written")
    print(f"snapo: interrupted by {name}{saved}", file=sys.stderr)
    return code


def ended(run: Callable[[], int], *, debug: bool = False, checkpoint=None) -> int:
    """Call `run` with SIGTERM raising `Terminated`, and map its failure to the contract's exit
    code and line (`checkpoint`: the training checkpoint an interrupt leaves, if any)."""
    main_thread = threading.current_thread() is threading.main_thread()
    previous = signal.signal(signal.SIGTERM, _terminate) if main_thread else None
    try:
        return run()
    except Exception as error:
        ending = _message(error)
        if debug or ending is None:
            raise
        message, code = ending
        print(f"snapo: error: {' '.join(message.split())}", file=sys.stderr)  # one line
        return code
    except KeyboardInterrupt as error:
        if debug:
            raise
        return _interrupted(error, checkpoint)
    finally:
        if main_thread:
            signal.signal(signal.SIGTERM, previous)


def configure_or_warn() -> None:
    """`configure()`; without `SNAPO_CACHE_DIR`, a default cache directory that cannot be used
    is a warning on stderr and the run goes on without the persistent cache."""
    from .._platform.cache_trust import CacheUnavailable
    from .._platform.config import CACHE_ENV, configure

    try:
        configure()
    except CacheUnavailable as error:
        if os.environ.get(CACHE_ENV):
            raise
        print(f"snapo: warning: {' '.join(str(error).split())} Running without the compilation cache.",
              file=sys.stderr)
        configure(cache=False)
