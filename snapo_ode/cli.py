"""The `snapo` command line. Domains plug in their verbs through the `snapo_ode.plugins` entry points.

A plugin is a function `register(cli: CommandLine) -> None` that adds its verbs with
`cli.command(name, help)`, `cli.bench(name, help)` and `cli.report(name, help)`; each returns an
`argparse.ArgumentParser` whose `handler` default (`parser.set_defaults(handler=fn)`) is called
with the parsed arguments. `cli.first_result(name, argv)` adds a command line to `snapo bench
first-result` (cold and warm time to its result, each in a new process). `cli.accuracy(name, run)` adds a study to `snapo bench accuracy`, which
runs every registered study (`--only NAME`, `--quick`), each in a `snapo` process of its own
unless `--in-process`, and writes one page of them (`snapo_ode.write_accuracy`). The core itself never imports a domain.

Every verb, bench and report gets the same options from the core:

- `--out DIR`: where everything the command writes goes (default `snapo-out`; a report's
  default is `snapo-out/NAME-report`).
- `--json PATH`: the result's JSON (default `OUT/NAME.json`; a report's `OUT/report.json`);
  a result is always written, so a long run is never lost to a missing flag.
- `--no-progress`: no progress bars (`args.progress` is the opposite).
- `--seed N`: the random seed, in [0, 2^63) (default 0).
- `--debug`: a traceback instead of the one-line error.

A report also gets `--no-pdf` (HTML, CSV and JSON only) and `--require-pdf` (exit 2 before any
computation when headless Chromium, which prints the PDF, is missing). By default a missing
Chromium is a warning: said at once on stderr, and in the report's JSON and HTML, which are
written with the CSV (exit 0), so a long computation is not lost for want of a browser.
`publish_report(args, report)` writes a domain's `snapo_ode.Report` with these options.

Verbs that train also get `--checkpoint` and `--resume` (`add_training_options`); verbs whose
samples split over devices get `--devices N` and the multi-process options (`add_device_options`).

Every input file a flag of type `pathlib.Path` names is part of a training checkpoint's
fingerprint by content (`snapo_ode._fingerprint.reading_files`), so `--resume` refuses a checkpoint
trained on another file. Outputs that exist and are not regular files (/dev/null, a named pipe, a
device, a directory) are refused before any computation. What the command prints is escaped for
the terminal (`snapo_ode._runtime.terminal`): control characters from a user's text, and what the
locale's encoding cannot show.

Exit codes (`snapo_ode._runtime.exits`): 0 success; 2 a user mistake (`InputError`: a one-line `snapo:
error: ...` naming the field, the value and what is allowed); 3 a failed solve or training; 4 the
environment (disk full, unwritable or untrusted cache); 130 / 143 interrupted by SIGINT / SIGTERM
(the training checkpoint saved).
Heavy imports (JAX, the models) happen inside the handlers, so `snapo --help` stays quick.
"""

import argparse
import pathlib
import sys
from collections.abc import Callable, Sequence
from importlib.metadata import entry_points

from ._runtime.exits import EXIT_INPUT_ERROR, EXIT_SIGINT, configure_or_warn, ended
from ._runtime.first_result import add_first_result_bench
from ._runtime.options import OneLineParser, VersionAction, count, counts, number, numbers, positive, seed
from ._runtime.terminal import safe_streams
from ._platform.validation import InputError

__all__ = ["CommandLine", "OneLineParser", "add_common_options", "add_device_options", "add_training_options",
           "build", "count", "counts", "main", "number", "numbers", "parse", "positive", "publish_report", "seed"]
PLUGIN_GROUP = "snapo_ode.plugins"
DEFAULT_OUT = pathlib.Path("snapo-out")


def check_output_paths(args: argparse.Namespace) -> None:
    """Refuse, before any computation, outputs that could not be written (`check_outputs`)."""
    from ._runtime.outputs import check_outputs

    check_outputs(args.out, {"--json": args.json, "--checkpoint": getattr(args, "checkpoint", None)},
                  report=getattr(args, "report_directory", False), pdf=getattr(args, "pdf", "skip"))


def publish_report(args: argparse.Namespace, report) -> int:
    """Write `report` (a `snapo_ode.Report`) into `args.out` with the report options, print the
    files and any warning; returns the exit code (0)."""
    from ._runtime.report import write_report

    written = write_report(args.out, report, json_path=args.json, pdf=args.pdf)
    for path in written.paths:
        print(f"written: {path}")
    for warning in written.warnings:
        print(f"snapo: warning: {warning}", file=sys.stderr)
    return 0


def add_common_options(parser: argparse.ArgumentParser, *, out: pathlib.Path, json_name: str) -> None:
    """Add `--out`, `--json`, `--no-progress`, `--seed` and `--debug` (see the module docstring)."""
    parser.add_argument("--out", type=pathlib.Path, default=out, metavar="DIR",
                        help=f"directory of everything this command writes (default {out})")
    parser.add_argument("--json", type=pathlib.Path, metavar="PATH",
                        help=f"the result's JSON (default OUT/{json_name})")
    parser.add_argument("--no-progress", action="store_true", help="hide progress bars")
    parser.add_argument("--seed", type=seed, default=0, help="random seed in [0, 2^63) (default 0)")
    parser.add_argument("--debug", action="store_true", help="show a traceback on error")
    parser.set_defaults(json_name=json_name)


def add_training_options(parser: argparse.ArgumentParser) -> None:
    """Add `--checkpoint PATH` (default: beside the JSON, `OUT.checkpoint.eqx`) and `--resume`
    to a verb that trains: the whole training state is written there atomically as it goes and
    when the run is interrupted, and `--resume` continues from it, giving the result an
    uninterrupted run would have given."""
    parser.add_argument("--checkpoint", type=pathlib.Path, metavar="PATH",
                        help="training checkpoint (default: beside the JSON, NAME.checkpoint.eqx)")
    parser.add_argument("--resume", action="store_true", help="continue an interrupted training from --checkpoint")
    parser.set_defaults(trains=True)


def add_device_options(parser: argparse.ArgumentParser) -> None:
    """Add `--devices N` and `--coordinator HOST:PORT --num-processes P --process-id I` to a verb
    whose independent samples (paths, design points, conditions) split over devices; its handler
    gets `args.mesh`, the samples mesh (`snapo_ode.sample_mesh`), or None on one device. Only
    process 0 writes (`snapo_ode.is_writer`)."""
    parser.add_argument("--devices", type=count(), metavar="N",
                        help="devices the samples split over (default: all; on CPU, the host split into N)")
    parser.add_argument("--coordinator", metavar="HOST:PORT",
                        help="multi-process run: process 0's address, with --num-processes and --process-id "
                             "(detected on SLURM)")
    parser.add_argument("--num-processes", type=count(), metavar="P", help="multi-process run: the number of processes")
    parser.add_argument("--process-id", type=count(0), metavar="I", help="multi-process run: this process, 0 to P-1")
    parser.set_defaults(distributed=True)


class CommandLine:
    """The parser tree handed to each plugin."""

    def __init__(self) -> None:
        self.parser = OneLineParser(
            prog="snapo",
            description="Smooth Neural Adjoint Policy Optimization on differentiable simulators.",
        )
        self.parser.add_argument("--version", action=VersionAction)
        self._verbs = self.parser.add_subparsers(dest="verb", metavar="VERB")
        bench = self._verbs.add_parser("bench", help="run a benchmark, print its table, write CSV and JSON")
        self._benches = bench.add_subparsers(dest="bench", metavar="NAME")
        report = self._verbs.add_parser("report", help="write a report (HTML, PDF, CSV, JSON) to a directory")
        self._reports = report.add_subparsers(dest="report", metavar="NAME")
        self._groups: dict[int, str] = {}
        self._accuracy: dict[str, list[Callable]] = {}
        accuracy = self.bench("accuracy", "what accuracy costs in time: error against wall time per solver, "
                              "adjoint, smoothing sharpness and path count; writes OUT/accuracy.md, its plots and CSVs")
        accuracy.add_argument("--quick", action="store_true", help="few settings, small problems (a minute or two)")
        accuracy.add_argument("--only", action="append", metavar="NAME",
                              help="run only this study (repeatable); default all")
        accuracy.add_argument("--in-process", action="store_true",
                              help="run every study in this process (default: each in a snapo process of its own "
                                   "when several run)")
        accuracy.set_defaults(handler=self._run_accuracy)
        self._scaling: dict[str, Callable] = {}
        scaling = self.bench("scaling", "strong and weak scaling of the sample-parallel workloads (ALM sensitivities, "
                             "the pharma Monte Carlo) over device counts: time, speed-up, efficiency, memory per "
                             "device, bytes communicated")
        scaling.add_argument("--device-counts", type=counts(1), default="1,2,4", help="comma-separated device counts (default 1,2,4), "
                             "each run in a snapo process of its own")
        scaling.add_argument("--only", action="append", metavar="NAME", help="run only this workload (repeatable)")
        scaling.add_argument("--quick", action="store_true", help="small sizes (a test's)")
        scaling.add_argument("--repeats", type=count(), default=5, help="timed runs after the compile (default 5)")
        add_device_options(scaling)
        scaling.set_defaults(handler=self._run_scaling)
        self.first_results: dict[str, list[str]] = {}
        add_first_result_bench(self)

    def command(self, name: str, help: str, *, group: "argparse._SubParsersAction | None" = None,
                json_name: str | None = None) -> argparse.ArgumentParser:
        """A verb: `snapo NAME ...`, or with `group` (from `CommandLine.group`) a sub-verb such
        as `snapo pharma NAME`; its result goes to `OUT/NAME.json` (`OUT/GROUP-NAME.json`, or
        `OUT/json_name`) by default."""
        verbs = self._verbs if group is None else group
        parser = verbs.add_parser(name, help=help, description=help)
        prefix = "" if group is None else f"{self._groups[id(group)]}-"
        add_common_options(parser, out=DEFAULT_OUT, json_name=json_name or f"{prefix}{name}.json")
        return parser

    def group(self, name: str, help: str) -> argparse._SubParsersAction:
        """A verb with sub-verbs (`snapo NAME VERB ...`): returns the group to pass to `command`."""
        parser = self._verbs.add_parser(name, help=help, description=help)
        group = parser.add_subparsers(dest=f"{name}_verb", metavar="VERB", required=True)
        self._groups[id(group)] = name
        return group

    def bench(self, name: str, help: str) -> argparse.ArgumentParser:
        """A benchmark: `snapo bench NAME ...`; its table goes to `OUT/bench_NAME.{csv,json}`."""
        parser = self._benches.add_parser(name, help=help, description=help)
        add_common_options(parser, out=DEFAULT_OUT, json_name=f"bench_{name.replace('-', '_')}.json")
        return parser

    def accuracy(self, name: str, run: Callable[[argparse.Namespace], Sequence]) -> None:
        """Add a study to `snapo bench accuracy`: `run(args)` returns its `AccuracyStudy`s
        (`args.quick` asks for the small version, `args.progress` for progress bars). Several
        domains may add to one name ("monte-carlo"): `--only NAME` runs them all, in order."""
        self._accuracy.setdefault(name, []).append(run)

    def _run_accuracy(self, args: argparse.Namespace) -> int:
        from ._runtime.accuracy import write_accuracy

        chosen = args.only or list(self._accuracy)
        unknown = [name for name in chosen if name not in self._accuracy]
        if unknown:
            raise InputError(f"--only = {unknown[0]!r} is not a study; choose from {sorted(self._accuracy)}.")
        if args.in_process or len(chosen) == 1:
            studies, failed = [study for name in chosen for run in self._accuracy[name] for study in run(args)], {}
        else:
            from ._runtime.apart import studies_apart

            studies, failed = studies_apart(chosen, args)
        command = " ".join(args.command_line)
        extra = {"quick": args.quick, **({"failed_studies": failed} if failed else {})}
        for path in write_accuracy(args.out, studies, command, extra, json_path=args.json):
            print(f"written: {path}")
        for name, code in failed.items():
            print(f"snapo: error: study {name!r} failed (exit {code}); the page holds the others", file=sys.stderr)
        return next(iter(failed.values()), 0)

    def scaling(self, name: str, run: Callable[[argparse.Namespace], Sequence[dict]]) -> None:
        """Add a workload to `snapo bench scaling`: `run(args)` measures it on `args.mesh` and
        returns its rows (see `snapo_ode._runtime.scaling`)."""
        self._scaling[name] = run

    def _run_scaling(self, args: argparse.Namespace) -> int:
        from ._runtime.scaling import COLUMNS, scaling_png, with_efficiency
        from ._runtime.tables import format_table, write_table

        chosen = args.only or list(self._scaling)
        unknown = [name for name in chosen if name not in self._scaling]
        if unknown:
            raise InputError(f"--only = {unknown[0]!r} is not a workload; choose from {sorted(self._scaling)}.")
        if args.devices is not None:  # one count, measured here
            rows, failed = [row for name in chosen for row in self._scaling[name](args)], {}
        else:
            from ._runtime.apart import scaling_apart

            rows, failed = scaling_apart(chosen, args)
        rows = with_efficiency(rows)
        print(format_table(rows, COLUMNS))
        extra = {"command": " ".join(args.command_line), **({"failed_device_counts": failed} if failed else {})}
        written = write_table(args.out, "bench_scaling", rows, extra,
                              files={} if args.devices is not None else {"bench_scaling.png": scaling_png(rows)})
        print(f"written: {', '.join(map(str, written))}")
        for devices, code in failed.items():
            print(f"snapo: error: the run on {devices} devices failed (exit {code}); the table holds the others",
                  file=sys.stderr)
        return next(iter(failed.values()), 0)

    def first_result(self, name: str, argv: Sequence[str]) -> None:
        """Add a workload to `snapo bench first-result`: `argv`, a `snapo` command line, timed
        from a new process's start to its exit, cold and warm (see `snapo_ode._runtime.first_result`)."""
        self.first_results[name] = list(argv)

    def report(self, name: str, help: str) -> argparse.ArgumentParser:
        """A report: `snapo report NAME ...`, written into `--out` (default `snapo-out/NAME-report`)."""
        parser = self._reports.add_parser(name, help=help, description=help)
        add_common_options(parser, out=DEFAULT_OUT / f"{name}-report", json_name="report.json")
        pdf = parser.add_mutually_exclusive_group()
        pdf.add_argument("--no-pdf", dest="pdf", action="store_const", const="skip",
                         help="write HTML, CSV and JSON only")
        pdf.add_argument("--require-pdf", dest="pdf", action="store_const", const="require",
                         help="fail at once (exit 2) if headless Chromium, which prints the PDF, is missing")
        parser.set_defaults(report_directory=True, pdf="auto")
        return parser


def build(plugins: Sequence[Callable[[CommandLine], None]] | None = None) -> CommandLine:
    """The command line with every installed plugin (or the given ones) registered."""
    cli = CommandLine()
    if plugins is None:
        plugins = [entry.load() for entry in entry_points(group=PLUGIN_GROUP)]
    for register in plugins:
        register(cli)
    return cli


def parse(cli: CommandLine, argv: Sequence[str] | None = None) -> argparse.Namespace:
    """Parse `argv`; fills in `args.json` (default `OUT/NAME.json`) and `args.progress`."""
    args = cli.parser.parse_args(argv)
    args.command_line = ["snapo", *(sys.argv[1:] if argv is None else argv)]
    if hasattr(args, "json_name"):
        args.json = args.json if args.json is not None else args.out / args.json_name
        args.progress = not args.no_progress
    if getattr(args, "trains", False) and args.checkpoint is None:
        # A report's directory holds only what the report publishes: its checkpoint goes beside it.
        args.checkpoint = (args.out.with_name(f"{args.out.name}.checkpoint.eqx") if getattr(args, "report_directory", False)
                           else args.json.with_suffix(".checkpoint.eqx"))
    return args


def main(argv: Sequence[str] | None = None, plugins: Sequence[Callable[[CommandLine], None]] | None = None) -> int:
    """Entry point of the `snapo` console script. Without `argv`, the command is the program: an
    interrupted run leaves the process at once when its line is printed (`ended`'s `leave`)."""
    with safe_streams():
        return _main(argv, plugins)


def _main(argv: Sequence[str] | None, plugins: Sequence[Callable[[CommandLine], None]] | None) -> int:
    try:
        cli = build(plugins)
        args = parse(cli, argv)
    except SystemExit as exited:  # --help, --version, or a one-line usage error (exit 2)
        return exited.code if isinstance(exited.code, int) else EXIT_INPUT_ERROR
    except KeyboardInterrupt:  # Ctrl-C while the plugins load
        print("snapo: interrupted by SIGINT; no result was written", file=sys.stderr)
        return EXIT_SIGINT
    handler = getattr(args, "handler", None)
    if handler is None:
        cli.parser.print_help()
        return EXIT_INPUT_ERROR

    def run() -> int:
        check_output_paths(args)
        if getattr(args, "distributed", False):
            from ._platform.devices import start

            start(args.devices, args.coordinator, args.num_processes, args.process_id)
        configure_or_warn()
        if getattr(args, "distributed", False):
            from ._platform.devices import sample_mesh

            mesh = sample_mesh(args.devices)
            args.mesh = mesh if mesh.size > 1 else None
        from ._fingerprint import reading_files
        from ._runtime.outputs import input_files

        with reading_files(input_files(vars(args))):
            return int(handler(args) or 0)

    return ended(run, debug=args.debug, checkpoint=getattr(args, "checkpoint", None), leave=argv is None)


if __name__ == "__main__":
    sys.exit(main())
