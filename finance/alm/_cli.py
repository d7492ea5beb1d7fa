"""CLI verbs of the pension-fund ALM study: `snapo alm`, `snapo bench alm` and `snapo report alm`.

Heavy imports (JAX, the model) happen inside the handlers, so `snapo --help` stays quick.
"""

import pathlib

from snapo_ode import InputError
from snapo_ode.cli import count, CommandLine, add_device_options, add_training_options

FUND_HELP = ("a fund file (YAML; docs/alm.md, 'A fund in files'): its market, liabilities (CSV), assets and "
             "objective, instead of the built-in fund; its N follows from the files")


def _fund(args):
    """The fund `--fund` names (read and checked before anything compiles), or None; refuses
    `--risk-factors` beside it (a fund's N follows from its files)."""
    if args.fund is None:
        return None
    if args.risk_factors is not None:
        raise InputError(f"--risk-factors {args.risk_factors} and --fund {args.fund}: a fund's number of risk "
                         "factors follows from its files; give one of the two.")
    from ._fund_file import load_fund

    return load_fund(args.fund)


def _risk_factors(args) -> int:
    return 100 if args.risk_factors is None else args.risk_factors


def _alm(args) -> int:
    from snapo_ode import is_writer

    from ._study import run_alm

    fund = _fund(args)
    study = run_alm(_risk_factors(args), fund=fund, n_paths=args.paths, horizon_months=args.horizon_months, bump=args.bump,
                    train_steps=args.train_steps, train_paths=args.train_paths, seed=args.seed,
                    progress=args.progress and is_writer(), checkpoint_path=args.checkpoint, resume=args.resume,
                    mesh=args.mesh)
    if is_writer():
        study.write_json(args.json)
        print(study.summary())
        print(f"written: {args.json}")
    return 0


def _bench(args) -> int:
    from ._bench import DEFAULT_COUNTS, format_table, scaling_rows, write_scaling

    fund = _fund(args)
    rows = scaling_rows(args.risk_factors or DEFAULT_COUNTS, n_paths=args.paths, horizon_months=args.horizon_months,
                        repeats=args.repeats, seed=args.seed, progress=args.progress, mesh=args.mesh, fund=fund)
    print(format_table(rows))
    print(f"written: {', '.join(map(str, write_scaling(rows, args.out)))}")
    return 0


def _report(args) -> int:
    from snapo_ode.cli import publish_report

    from ._report import alm_report, build_alm_report, report_provenance

    settings = dict(n_paths=args.paths, horizon_months=args.horizon_months, train_steps=args.train_steps,
                    train_paths=args.train_paths, bump=not args.no_bump, seed=args.seed)
    from snapo_ode import is_writer

    fund = _fund(args)
    data = build_alm_report(_risk_factors(args), fund=fund, progress=args.progress and is_writer(), checkpoint_path=args.checkpoint,
                            resume=args.resume, mesh=args.mesh, **settings)
    if not is_writer():
        return 0
    return publish_report(args, alm_report(data, report_provenance(data["n_risk_factors"], settings, args.command_line,
                                                                   fund=fund)))


def _smoothing_accuracy(args):
    from ._accuracy import smoothing_study

    return smoothing_study(quick=args.quick, seed=args.seed)


def _monte_carlo_accuracy(args):
    from ._accuracy import monte_carlo_study

    return monte_carlo_study(quick=args.quick, seed=args.seed)


def _device_scaling(args):
    from ._device_scaling import device_scaling

    return device_scaling(mesh=args.mesh, quick=args.quick, seed=args.seed, repeats=args.repeats)


def register_alm(cli: CommandLine) -> None:
    """Add `snapo alm`, `snapo bench alm`, `snapo report alm`, the "alm" workload of
    `snapo bench scaling` and ALM's panels of the "smoothing" and "monte-carlo" studies of
    `snapo bench accuracy`."""
    parser = cli.command("alm", "pension-fund ALM: train the rebalancing policy and report the "
                                "sensitivities to every risk factor (one reverse pass)")
    parser.add_argument("--risk-factors", type=count(), default=None, metavar="N",
                        help="number of reported risk factors of the built-in fund, >= 9 (default 100)")
    parser.add_argument("--fund", type=pathlib.Path, metavar="FILE", help=FUND_HELP)
    parser.add_argument("--paths", type=count(), default=1000, help="Monte Carlo paths (default 1000)")
    parser.add_argument("--horizon-months", type=count(), default=None, metavar="H",
                        help="horizon in months, 1 to 600 (default 120, or the fund file's)")
    parser.add_argument("--bump", action="store_true",
                        help="also run central bump-and-revalue and forward mode, and compare")
    parser.add_argument("--train-steps", type=count(), default=0, metavar="S",
                        help="policy training steps (default 0: an untrained policy)")
    parser.add_argument("--train-paths", type=count(), default=256, help="paths per training step")
    add_training_options(parser)
    add_device_options(parser)
    parser.set_defaults(handler=_alm)

    bench = cli.bench("alm", "sensitivity cost against the number of risk factors: adjoint vs "
                             "batched bump-and-revalue vs forward mode (writes bench_alm.{csv,json}, alm_scaling.png, and the table as alm_scaling.{csv,json})")
    bench.add_argument("--risk-factors", type=count(), nargs="+", default=None, metavar="N",
                       help="the counts N of the built-in fund (default 10 50 100 500 1000 2000)")
    bench.add_argument("--fund", type=pathlib.Path, metavar="FILE", help=FUND_HELP + " (one row)")
    bench.add_argument("--paths", type=count(), default=128, help="paths (default 128)")
    bench.add_argument("--horizon-months", type=count(), default=None, metavar="H",
                       help="horizon in months (default 120, or the fund file's)")
    bench.add_argument("--repeats", type=count(), default=3, help="timed runs per method")
    add_device_options(bench)
    bench.set_defaults(handler=_bench)

    report = cli.report("alm", "the fund's risk report: funding ratio and objective of the trained policy against "
                               "fixed mixes, and the key-rate, inflation, equity and spread sensitivity ladder "
                               "(one reverse pass each)")
    report.add_argument("--risk-factors", type=count(), default=None, metavar="N",
                        help="reported risk factors of the built-in fund, >= 9 (default 100)")
    report.add_argument("--fund", type=pathlib.Path, metavar="FILE", help=FUND_HELP)
    report.add_argument("--paths", type=count(), default=1000, help="Monte Carlo paths of the evaluation (default 1000)")
    report.add_argument("--horizon-months", type=count(), default=None, metavar="H",
                        help="horizon in months (default 120, or the fund file's)")
    report.add_argument("--train-steps", type=count(), default=300, metavar="S", help="policy training steps (default 300)")
    report.add_argument("--train-paths", type=count(), default=256, help="paths per training step")
    report.add_argument("--no-bump", action="store_true", help="skip the check of the adjoint against central bumps")
    add_training_options(report)
    add_device_options(report)
    report.set_defaults(handler=_report)
    cli.scaling("alm", _device_scaling)
    cli.accuracy("smoothing", _smoothing_accuracy)
    cli.accuracy("monte-carlo", _monte_carlo_accuracy)
