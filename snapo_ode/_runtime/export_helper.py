"""Trace, export and compile an `ExportedProgram` entry in a helper process.

Tracing is Python and holds the interpreter lock: a first process that must trace several programs
traces them one after another, however many cores it has (the pharma study's adjoint, bumps and
reference: most of a cold run's time; docs/architecture.md, Measurements behind the design). A
helper process traces one of them alongside, writes its entry (`snapo_ode.exported`) and compiles
it, so its executable lands in the persistent compilation cache; the caller then reads both as it
would in a second process. What the helper is sent: where the program is defined (a module
attribute: the helper imports it, so the program and its key are the caller's), the arguments
(pickled), the entry's path, the cache directory and the runtime-check and matmul-precision modes
the caller traces under. The helper recomputes the entry's key from what it received, and writes
nothing if it differs (exit 3): the caller then traces as it would have.
"""

import atexit
import importlib
import os
import pickle
import subprocess
import sys

MISMATCH = 3
"""The helper's exit code when its key for the arguments differs from the caller's."""
UNEXPORTABLE = 4
"""The helper's exit code when the program cannot be exported (the caller then jits it)."""
TIMEOUT = 900.0
"""Seconds a caller waits for a helper before it kills it and traces the program itself: far
above the longest trace and compile a helper does (a gri30 gradient's), so that only a helper
that hangs is killed."""

NICENESS = 10
"""The helpers' scheduling priority below the caller's (Unix `nice`): the caller's own trace and
compile are the critical path, and a helper takes what they leave of the cores (a cold `snapo
pharma sensitivities` is the shorter for it: docs/architecture.md, Measurements behind the
design)."""

_RUNNING: list[subprocess.Popen] = []


def _stop_running() -> None:
    # A caller that ends early (an error, an interrupt) leaves no helper behind.
    for process in _RUNNING:
        if process.poll() is None:
            process.kill()


atexit.register(_stop_running)


def locate(program) -> tuple[str, str] | None:
    """(module, attribute) where `program` (an `ExportedProgram`) is defined at module level, or
    None: a program made inside a function cannot be imported by a helper."""
    module = sys.modules.get(getattr(program._fn, "__module__", None) or "")
    if module is None or module.__name__ == "__main__":  # a helper's __main__ is not the caller's
        return None
    names = [name for name, value in vars(module).items() if value is program]
    return (module.__name__, names[0]) if names else None


def start(program, args, path, *, cache_dir: str, on_error, precision) -> subprocess.Popen | None:
    """Start a helper process that traces `program` for `args`, writes the entry at `path` and
    compiles it into the compilation cache at `cache_dir`; None where it cannot (the program is
    not a module attribute, or the arguments do not pickle)."""
    where = locate(program)
    if where is None:
        return None
    try:
        # The arguments are pickled on their own and read after `configure`: a float64 array
        # read before float64 is on becomes float32 (and the key differs).
        payload = pickle.dumps({"where": where, "args": pickle.dumps(args), "path": str(path), "cache_dir": cache_dir,
                                "on_error": on_error, "precision": precision})
    except Exception:  # noqa: BLE001 - whatever does not pickle is traced by the caller
        return None
    # Its stdout is dropped (a command's may be machine-read); its stderr shows why it failed.
    # On a GPU it must not take the memory that JAX preallocates for the caller.
    environment = dict(os.environ, XLA_PYTHON_CLIENT_PREALLOCATE="false")
    try:
        process = subprocess.Popen([sys.executable, "-m", "snapo_ode._runtime.export_helper"], stdin=subprocess.PIPE,
                                   stdout=subprocess.DEVNULL, env=environment)
    except OSError:
        return None
    _RUNNING.append(process)
    try:
        process.stdin.write(payload)
        process.stdin.close()
    except OSError:  # it died before reading: the caller traces
        process.kill()
        return None
    return process


def wait(process: subprocess.Popen, timeout: float | None = None) -> int:
    """The helper's exit code once it is done; a helper still running after `timeout` [s]
    (default `TIMEOUT`) is killed (a negative code)."""
    try:
        return process.wait(TIMEOUT if timeout is None else timeout)
    except subprocess.TimeoutExpired:
        process.kill()
        return process.wait()


def main() -> int:
    """The helper: read the payload from stdin, export and compile; the exit code says how it went."""
    if hasattr(os, "nice"):  # first: its imports too take what the caller leaves
        os.nice(NICENESS)
    import equinox._errors as equinox_errors
    import jax

    from .._platform.config import configure

    payload = pickle.load(sys.stdin.buffer)
    configure(payload["cache_dir"])
    module, attribute = payload["where"]
    program = getattr(importlib.import_module(module), attribute)
    equinox_errors.EQX_ON_ERROR = payload["on_error"]
    with jax.default_matmul_precision(payload["precision"]):
        built = program.build(pickle.loads(payload["args"]), payload["path"])
    return {True: 0, False: MISMATCH, None: UNEXPORTABLE}[built]


if __name__ == "__main__":
    code = main()
    # Its outputs are on disk (the entry written atomically, the executable in the compilation
    # cache): it exits without the interpreter's and JAX's teardown, which the caller would wait
    # for, between a helper's last compile and its caller reading the program.
    sys.stdout.flush()
    sys.stderr.flush()
    os._exit(code)
