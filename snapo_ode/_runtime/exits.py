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

Signals at every phase (`_Signals`): the first SIGINT or SIGTERM is raised in the main thread;
one that lands where Python would drop the exception (a `gc` callback, such as JAX's, which frees
XLA buffers after a collection; a `__del__`) is sent again 50 ms later, outside it, and one whose
exception was dropped all the same still ends the command with its code. Later signals, while the
run ends (the checkpoint written, temporary files removed, the line printed), are noted, not
raised, so a second Ctrl-C does not break the cleanup or print a traceback; a third one leaves at
once. A command run as the program (`ended(..., leave=True)`) that was interrupted leaves with
`os._exit` once its outputs are flushed, so the interpreter's teardown does not race XLA threads
that were still computing.

Without `SNAPO_CACHE_DIR`, a default cache directory that cannot be used is a warning and the run
goes on without the persistent cache (`configure_or_warn`); a `SNAPO_CACHE_DIR` that cannot be
used is exit 4.
"""

import errno
import gc
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


_CODES = {signal.SIGINT: EXIT_SIGINT, signal.SIGTERM: EXIT_SIGTERM}
RESEND_SECONDS = 0.05


def _dropping(frame) -> bool:
    """Whether an exception raised in `frame` would be dropped by Python ("Exception ignored"):
    a frame of a `gc` callback or of a `__del__` is on the stack."""
    callbacks = {getattr(callback, "__code__", None) for callback in gc.callbacks}
    while frame is not None:
        if frame.f_code in callbacks or frame.f_code.co_name == "__del__":
            return True
        frame = frame.f_back
    return False


class _Signals:
    """SIGINT and SIGTERM while a command runs (see the module): `received`, the first signal;
    `ending`, set once the run ends, after which signals are noted, not raised."""

    def __init__(self):
        self.received: int | None = None
        self.count = 0
        self.ending = False
        self.previous = {}
        self.resend: threading.Timer | None = None

    def __enter__(self):
        for signum in _CODES:
            if signal.getsignal(signum) != signal.SIG_IGN:  # an ignored signal stays ignored (nohup)
                self.previous[signum] = signal.signal(signum, self.handle)
        return self

    def __exit__(self, *exc):
        if self.resend is not None:
            self.resend.cancel()
        for signum, handler in self.previous.items():  # None: a handler set outside Python
            signal.signal(signum, signal.SIG_DFL if handler is None else handler)

    def handle(self, signum, frame):
        if self.ending or self.count:  # the run is already ending: note it, let the cleanup finish
            self.count += 1
            if self.count >= 3:
                print(f"snapo: interrupted by {signal.Signals(self.received or signum).name} again; leaving at once",
                      file=sys.stderr, flush=True)
                os._exit(_CODES[self.received or signum])
            return
        self.received = self.received or signum
        if _dropping(frame):
            self.resend = threading.Timer(RESEND_SECONDS, os.kill, (os.getpid(), signum))
            self.resend.daemon = True
            self.resend.start()
            return
        self.count = 1
        raise Terminated() if signum == signal.SIGTERM else KeyboardInterrupt()


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


def _interrupted(terminated: bool, checkpoint) -> int:
    name, code = ("SIGTERM", EXIT_SIGTERM) if terminated else ("SIGINT", EXIT_SIGINT)
    saved = (f"; the training so far is in {str(checkpoint)!r}: run the same command with --resume to go on"
             if checkpoint is not None and pathlib.Path(checkpoint).exists() else "; no result was written")
    print(f"snapo: interrupted by {name}{saved}", file=sys.stderr)
    return code


def ended(run: Callable[[], int], *, debug: bool = False, checkpoint=None, leave: bool = False) -> int:
    """Call `run` with SIGINT and SIGTERM handled (`_Signals`: SIGTERM raises `Terminated`), and
    map its failure to the contract's exit code and line (`checkpoint`: the training checkpoint
    an interrupt leaves, if any). With `leave` (the command is the program), an interrupted run
    leaves the process with `os._exit` once stdout and stderr are flushed."""
    if threading.current_thread() is not threading.main_thread():
        return _ended(run, debug, checkpoint, None)
    with _Signals() as signals:
        code = _ended(run, debug, checkpoint, signals)
        if leave and code in (EXIT_SIGINT, EXIT_SIGTERM):
            for stream in (sys.stdout, sys.stderr):
                stream.flush()
            os._exit(code)
    return code


def _ended(run: Callable[[], int], debug: bool, checkpoint, signals: _Signals | None) -> int:
    try:
        code = run()
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
        terminated = isinstance(error, Terminated)
        while True:  # a signal that lands before `ending` is set is raised once more: start again
            try:
                if signals is not None:
                    signals.ending = True
                return _interrupted(terminated, checkpoint)
            except KeyboardInterrupt:
                continue
    if signals is not None and signals.received is not None:  # raised where it was dropped: still ends the run
        signals.ending = True
        return _interrupted(signals.received == signal.SIGTERM, checkpoint)
    return code


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
