"""CLI verbs of the pension-fund ALM study: `snapo alm`, `snapo bench alm` and `snapo report alm`.

Heavy imports (JAX, the model) happen inside the handlers, so `snapo --help` stays quick.
"""

import pathlib

from snapo_ode import InputError
from snapo_ode.cli import count, CommandLine, add_device_options, add_training_options

FUND_HELP = ("a fund file (YAML; docs/alm.md, 'A fund in files'): its market, liabilities (CSV), assets and "
             "objective, instead of the built-in fund; its N follows from the files")
SCENARIOS_HELP = ("a scenario set (.csv or .parquet long table scenario,time,variable,value, or .npz; docs/alm.md, "
                  "'Scenarios from outside') to run the fund on instead of generated paths; its scenarios are the "
                  "paths (with training, half train and half evaluate); the fund is --fund's or the built-in one's file")


def _add_fund_options(parser) -> None:
    parser.add_argument("--fund", type=pathlib.Path, metavar="FILE", help=FUND_HELP)
    parser.add_argument("--scenarios", type=pathlib.Path, metavar="FILE", help=SCENARIOS_HELP)


def _fund(args):
    """The fund `--fund` names (the built-in fund's file where only `--scenarios` is given), read
    and checked before anything compiles, or None; refuses `--risk-factors` beside either (a
    fund's N follows from its files)."""
    scenario_file = getattr(args, "scenarios", None)
    if args.fund is None and scenario_file is None:
        return None
    if args.risk_factors is not None:
        raise InputError(f"--risk-factors {args.risk_factors} and --{'fund' if args.fund else 'scenarios'}: a fund's "
                         "number of risk factors follows from its files; give one of the two.")
    from ._fund_file import load_fund, sample_fund_path

    return load_fund(sample_fund_path() if args.fund is None else args.fund)


def _scenario_set(args, fund):
    """The scenario set `--scenarios` names, for `fund` over the study's horizon, or None;
    refuses `--paths` beside it (the set's scenarios are the paths)."""
    if getattr(args, "scenarios", None) is None:
        return None
    if args.paths is not None:
        raise InputError(f"--paths {args.paths} and --scenarios {args.scenarios}: the scenario set's scenarios are the "
                         "paths; give one of the two.")
    from ._scenario_file import load_scenarios

    horizon = fund.horizon_months if args.horizon_months is None else args.horizon_months
    return load_scenarios(args.scenarios, fund.market, horizon, spread=float(fund.factors["spread"]))


def _paths(args, default: int) -> int:
    return default if args.paths is None else args.paths


def _risk_factors(args) -> int:
    return 100 if args.risk_factors is None else args.risk_factors


def _alm(args) -> int:
    from snapo_ode import is_writer

    from ._study import run_alm

    fund = _fund(args)
    scenario_set = _scenario_set(args, fund)
    if args.write_scenarios is not None:
        _write_generated(args, fund)
    study = run_alm(_risk_factors(args), fund=fund, scenario_set=scenario_set, n_paths=_paths(args, 1000), horizon_months=args.horizon_months, bump=args.bump,
                    train_steps=args.train_steps, train_paths=args.train_paths, seed=args.seed,
                    progress=args.progress and is_writer(), checkpoint_path=args.checkpoint, resume=args.resume,
                    mesh=args.mesh)
    if is_writer():
        study.write_json(args.json)
        print(study.summary())
        print(f"written: {args.json}")
    return 0


def _write_generated(args, fund) -> None:
    """Write the built-in generator's scenarios of this run's evaluation paths to
    `--write-scenarios` (before the study, so that a long run's set is kept)."""
    import jax

    from ._scenario_file import write_scenarios
    from ._scenarios import generated_scenarios
    from ._study import study_for

    if args.scenarios is not None:
        raise InputError("--write-scenarios and --scenarios: the generator writes its own scenarios; give one of the two.")
    if args.write_scenarios.suffix.lower() not in (".csv", ".parquet", ".npz"):
        raise InputError(f"--write-scenarios {args.write_scenarios}: unknown format {args.write_scenarios.suffix!r}; "
                         "allowed: .csv, .parquet or .npz.")
    study = study_for(_risk_factors(args), fund, args.horizon_months)
    generated = generated_scenarios(study, _paths(args, 1000), jax.random.fold_in(jax.random.key(args.seed), 2))
    print(f"written: {write_scenarios(args.write_scenarios, generated, study.market)}")


def _bench(args) -> int:
    from ._bench import DEFAULT_COUNTS, format_table, scaling_rows, write_scaling

    fund = _fund(args)
    rows = scaling_rows(args.risk_factors or DEFAULT_COUNTS, n_paths=_paths(args, 128), scenario_set=_scenario_set(args, fund), horizon_months=args.horizon_months,
                        repeats=args.repeats, seed=args.seed, progress=args.progress, mesh=args.mesh, fund=fund)
    print(format_table(rows))
    print(f"written: {', '.join(map(str, write_scaling(rows, args.out)))}")
    return 0


def _report(args) -> int:
    from snapo_ode.cli import publish_report

    from ._report import alm_report, build_alm_report, report_provenance

    settings = dict(n_paths=_paths(args, 1000), horizon_months=args.horizon_months, train_steps=args.train_steps,
                    train_paths=args.train_paths, bump=not args.no_bump, seed=args.seed, bump_sample=args.bump_sample)
    from snapo_ode import is_writer

    fund = _fund(args)
    data = build_alm_report(_risk_factors(args), fund=fund, scenario_set=_scenario_set(args, fund), progress=args.progress and is_writer(), checkpoint_path=args.checkpoint,
                            resume=args.resume, mesh=args.mesh, **settings)
    if not is_writer():
        return 0
    return publish_report(args, alm_report(data, report_provenance(data["n_risk_factors"], settings, args.command_line,
                                                                   fund=fund, scenario_file=args.scenarios)))


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
    _add_fund_options(parser)
    parser.add_argument("--write-scenarios", type=pathlib.Path, metavar="FILE",
                        help="also write the generated scenarios of the evaluation paths to FILE (.csv, .parquet or "
                             ".npz), in --scenarios' format")
    parser.add_argument("--paths", type=count(), default=None, help="Monte Carlo paths (default 1000)")
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
    _add_fund_options(bench)
    bench.add_argument("--paths", type=count(), default=None, help="paths (default 128)")
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
    _add_fund_options(report)
    report.add_argument("--paths", type=count(), default=None, help="Monte Carlo paths of the evaluation (default 1000)")
    report.add_argument("--horizon-months", type=count(), default=None, metavar="H",
                        help="horizon in months (default 120, or the fund file's)")
    report.add_argument("--train-steps", type=count(), default=300, metavar="S", help="policy training steps (default 300)")
    report.add_argument("--train-paths", type=count(), default=256, help="paths per training step")
    report.add_argument("--no-bump", action="store_true", help="skip the check of the adjoint against central bumps")
    report.add_argument("--bump-sample", type=count(low=0), default=20, metavar="K",
                        help="check K sensitivities against central bumps: the largest quarter and a seeded draw of "
                             "the rest (default 20; 0: every one, batched, with forward mode too)")
    add_training_options(report)
    add_device_options(report)
    report.set_defaults(handler=_report)
    cli.scaling("alm", _device_scaling)
    cli.accuracy("smoothing", _smoothing_accuracy)
    cli.accuracy("monte-carlo", _monte_carlo_accuracy)
