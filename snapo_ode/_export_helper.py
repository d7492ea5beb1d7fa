"""Trace, export and compile an `ExportedProgram` entry in a helper process.

Tracing is Python and holds the interpreter lock: a first process that must trace several
programs traces them one after another, however many cores it has (the pharma study's adjoint,
bumps and reference: 19.5 s of tracing in a row, of a 35 s cold run on 2 cores). A helper
process traces one of them alongside, writes its entry (`snapo_ode.exported`) and compiles it,
so its executable lands in the persistent compilation cache; the caller then reads both as it
would in a second process. What the helper is sent: where the program is defined (a module
attribute: the helper imports it, so the program and its key are the caller's), the arguments
(pickled), the entry's path, the cache directory and the runtime-check and matmul-precision
modes the caller traces under. The helper recomputes the entry's key from what it received, and
writes nothing if it differs (exit 3): the caller then traces as it would have.
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

NICENESS = 10
"""The helpers' scheduling priority below the caller's (Unix `nice`): the caller's own trace and
compile are the critical path, and a helper takes what they leave of the cores (measured: a cold
`snapo pharma sensitivities` on 2 cores 24.5-24.9 s with it, 26.0-27.0 s without)."""

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
    if module is None:
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
    except (pickle.PicklingError, TypeError, AttributeError):
        return None
    process = subprocess.Popen([sys.executable, "-m", "snapo_ode._export_helper"], stdin=subprocess.PIPE)
    _RUNNING.append(process)
    process.stdin.write(payload)
    process.stdin.close()
    return process


def main() -> int:
    """The helper: read the payload from stdin, export and compile; the exit code says how it went."""
    import equinox._errors as equinox_errors
    import jax

    from ._config import configure

    if hasattr(os, "nice"):
        os.nice(NICENESS)
    payload = pickle.load(sys.stdin.buffer)
    configure(payload["cache_dir"])
    module, attribute = payload["where"]
    program = getattr(importlib.import_module(module), attribute)
    equinox_errors.EQX_ON_ERROR = payload["on_error"]
    with jax.default_matmul_precision(payload["precision"]):
        built = program.build(pickle.loads(payload["args"]), payload["path"])
    return {True: 0, False: MISMATCH, None: UNEXPORTABLE}[built]


if __name__ == "__main__":
    sys.exit(main())
