"""`snapo bench first-result`: how long a user waits for a command's result in a new process,
cold (an empty cache directory: every program traced and compiled) and warm (a new process on the
cache the cold one left: exported programs loaded, `snapo_ode.exported`, and their executables
read from the persistent compilation cache).

A domain registers a workload with `CommandLine.first_result(name, argv)`: `argv` is a `snapo`
command line; the bench adds `--out` and `--no-progress`. "First result" is the whole command:
from the process's start to its exit, its result written, so Python's and JAX's imports, the
model's construction, every program the command runs (a study's checks too) and the writing of
its files all count. Each run is a fresh `snapo` process whose `SNAPO_CACHE_DIR` is a new
temporary directory for the cold run, reused by the warm runs (the median of `--repeats`).
"""

import argparse
import os
import pathlib
import statistics
import subprocess
import sys
import tempfile
import time
from collections.abc import Mapping, Sequence

from .options import count

DEFINITION = ("wall time of a new `snapo` process, start to exit with its result written; cold: an empty "
              "SNAPO_CACHE_DIR, warm: the median of --repeats new processes on the cache the cold one left")


def timed_process(argv: Sequence[str], cache_dir: pathlib.Path, out: pathlib.Path) -> tuple[float, int]:
    """Wall time [s] and exit code of `snapo ARGV --out OUT --no-progress` in a new process whose
    cache directory is `cache_dir` (its stdout dropped, its stderr shown)."""
    env = dict(os.environ, SNAPO_CACHE_DIR=str(cache_dir))
    start = time.perf_counter()
    code = subprocess.run([sys.executable, "-m", "snapo_ode.cli", *argv, "--out", str(out), "--no-progress"],
                          env=env, stdout=subprocess.DEVNULL).returncode
    return time.perf_counter() - start, code


def measure(name: str, argv: Sequence[str], repeats: int) -> dict:
    """One row of the bench: `argv` cold once, then warm `repeats` times."""
    with tempfile.TemporaryDirectory(prefix="snapo-first-result-") as scratch:
        cache = pathlib.Path(scratch) / "cache"
        cold, cold_code = timed_process(argv, cache, pathlib.Path(scratch) / "cold")
        warm = [timed_process(argv, cache, pathlib.Path(scratch) / f"warm{i}") for i in range(repeats)]
        exported = len(list((cache / "exported").glob("*"))) if (cache / "exported").is_dir() else 0
    codes = [cold_code, *(code for _, code in warm)]
    seconds = statistics.median(s for s, _ in warm)
    return {"workload": name, "command": " ".join(["snapo", *argv]), "cold_seconds": cold, "warm_seconds": seconds,
            "warm_seconds_all": [s for s, _ in warm], "cold_over_warm": cold / seconds,
            "exported_programs": exported, "exit_codes": codes, "ok": not any(codes)}


def add_first_result_bench(cli) -> None:
    """Add `snapo bench first-result` to `cli` (a `snapo_ode.cli.CommandLine`), over the
    workloads in `cli.first_results` (name -> argv)."""
    bench = cli.bench("first-result", "time to the first result of the domains' commands in a new process: cold "
                      "(empty cache directory) and warm (a second process)")
    bench.add_argument("--only", action="append", metavar="NAME", help="run only this workload (repeatable)")
    bench.add_argument("--repeats", type=count(), default=3, help="warm processes, their median reported (default 3)")
    bench.set_defaults(handler=lambda args: run_first_result(args, cli.first_results))


def run_first_result(args: argparse.Namespace, workloads: Mapping[str, Sequence[str]]) -> int:
    """Measure the chosen workloads, print the table, write `bench_first_result.{csv,json}`;
    exit 1 if any child process failed. **Raises:** `InputError` for an unknown `--only` or
    `--repeats` below 1, before any process starts."""
    from .tables import Column, format_table, write_table
    from .._platform.validation import InputError, check_count

    check_count("repeats", args.repeats, 1)
    chosen = args.only or list(workloads)
    unknown = [name for name in chosen if name not in workloads]
    if unknown:
        raise InputError(f"--only = {unknown[0]!r} is not a workload; choose from {sorted(workloads)}.")
    rows = [measure(name, workloads[name], args.repeats) for name in chosen]
    print(format_table(rows, (Column("workload", "workload"), Column("cold s", "cold_seconds", ".1f"),
                              Column("warm s", "warm_seconds", ".1f"), Column("cold / warm", "cold_over_warm", ".1f"),
                              Column("exported programs", "exported_programs", "d"), Column("ok", "ok"))))
    written = write_table(args.out, "bench_first_result", rows,
                          {"command": " ".join(args.command_line), "definition": DEFINITION})
    print(f"written: {', '.join(map(str, written))}")
    for row in rows:
        if not row["ok"]:
            print(f"snapo: error: {row['workload']!r} failed (exit codes {row['exit_codes']})", file=sys.stderr)
    return 0 if all(row["ok"] for row in rows) else 1
