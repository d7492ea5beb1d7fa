"""Parts of a bench run each in a `snapo` process of its own, their results read back: the
studies of `snapo bench accuracy` (each compiled program stays mapped in its process, and a
long bench should lose one study, not all) and the device counts of `snapo bench scaling` (a
process's device count is fixed when JAX starts)."""

import argparse
import pathlib
import sys
from collections.abc import Sequence

from .._platform.validation import InputError


def _snapo_process(argv: Sequence[str]) -> int:
    """Run `snapo ARGV` in a process of its own (its stdout dropped, its stderr shown); its exit code."""
    import subprocess

    code = subprocess.run([sys.executable, "-m", "snapo_ode.cli", *argv], stdout=subprocess.DEVNULL).returncode
    return code if code >= 0 else 1


def _child_options(args: argparse.Namespace) -> list[str]:
    return ["--seed", str(args.seed), *(["--quick"] if args.quick else []),
            *([] if args.progress else ["--no-progress"]), *(["--debug"] if args.debug else [])]


def studies_apart(chosen: Sequence[str], args: argparse.Namespace) -> tuple[list, dict[str, int]]:
    """Run each study of `snapo bench accuracy` in a `snapo` process of its own (`--only NAME`)
    and read its studies back; returns them and {name: exit code} of the studies that failed.
    Apart, because each compiled program stays mapped in its process, and a long bench should
    lose one study, not all (see `snapo_ode.relieve_mappings`)."""
    import tempfile

    from .accuracy import read_accuracy

    studies, failed = [], {}
    with tempfile.TemporaryDirectory(prefix="snapo-accuracy-") as scratch:
        for name in chosen:
            json_path = pathlib.Path(scratch) / f"{name}.json"
            code = _snapo_process(["bench", "accuracy", "--only", name, "--out", str(pathlib.Path(scratch) / name),
                                   "--json", str(json_path), *_child_options(args)])
            if code == 0:
                studies += read_accuracy(json_path)
            else:
                failed[name] = code
    return studies, failed


def scaling_apart(chosen: Sequence[str], args: argparse.Namespace) -> tuple[list[dict], dict[int, int]]:
    """The rows of `snapo bench scaling` at each of `--device-counts`, each count measured in a
    `snapo` process of its own (a process's device count is fixed when JAX starts); returns them
    and {count: exit code} of the counts whose process failed.

    **Raises:** `InputError` for a bad count, before any process starts."""
    import json
    import tempfile

    counts = args.device_counts  # parsed by the option's type (`options.counts`)
    if not counts or min(counts) < 1:
        raise InputError(f"--device-counts = {args.device_counts!r}; give positive integers separated by commas, "
                         "e.g. 1,2,4.")
    rows, failed = [], {}
    with tempfile.TemporaryDirectory(prefix="snapo-scaling-") as scratch:
        for count in counts:
            out = pathlib.Path(scratch) / str(count)
            code = _snapo_process(["bench", "scaling", "--devices", str(count), "--repeats", str(args.repeats),
                                   *[flag for name in chosen for flag in ("--only", name)], "--out", str(out),
                                   *_child_options(args)])
            if code:
                failed[count] = code
            else:
                rows += json.loads((out / "bench_scaling.json").read_text())["rows"]
    return rows, failed
