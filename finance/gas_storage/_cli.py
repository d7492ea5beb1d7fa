"""`snapo gas`, `snapo demo`, `snapo bench gas`, `snapo bench gas-lsmc` and `snapo bench gas-family`.

Heavy imports (JAX, the model) happen inside the handlers, so `snapo --help` stays quick.
"""

import argparse
import pathlib
import sys

from snapo_ode.cli import count, number, positive, add_training_options

ONE_FACTOR_NODES = 101  # `--lsmc-nodes` on the one-factor spot (a price model's default: `value_on_model`)
ONE_FACTOR_DEGREE = 3  # `--lsmc-degree` in the one-factor spot (a price model's default: `value_on_model`)


def add_study_arguments(parser: argparse.ArgumentParser) -> None:
    from ._cases import CASES

    parser.add_argument("--sample", choices=sorted(CASES), default="sample",
                        help="built-in facility and curve (bdj: Boogert & de Jong 2008)")
    parser.add_argument("--curve", type=pathlib.Path, help="forward curve CSV with header day,price "
                        "[$/MMBtu] (default: the --sample's)")
    parser.add_argument("--facility", type=pathlib.Path, help="facility JSON (default: the --sample's)")
    parser.add_argument("--stochastic", action="store_true", help="trade on simulated spot paths")
    parser.add_argument("--volatility", type=number(0, 10), help="OU factor volatility [1/sqrt(year)] (default 0.5; "
                        "bdj: 0.6018, B&dJ's 3.15%% per sqrt(day))")
    parser.add_argument("--mean-reversion", type=number(0, 1e4), help="OU mean reversion [1/year] (default 2; "
                        "bdj: 18.25, B&dJ's 0.05/day)")
    parser.add_argument("--paths", type=count(), default=1000, help="Monte Carlo paths (stochastic mode)")
    parser.add_argument("--head", choices=["basestock", "fraction", "split"], default="basestock",
                        help="policy head (see make_policy): basestock inventory targets (Secomandi 2010; the "
                        "default, measured best), a fraction of the largest flow, or split inject/withdraw scores")
    parser.add_argument("--split-actions", action="store_true", help="same as --head split")
    parser.add_argument("--train-paths", type=count(), help="fresh paths per training step (default per head: "
                        "basestock 512, others 256)")
    parser.add_argument("--train-steps", type=count(), help="default per head: basestock 800, others 1500")
    parser.add_argument("--start", choices=["lattice", "intrinsic"], default="lattice", help="where the basestock "
                        "head starts on a random spot: the targets of the factor lattice's value (default) or the "
                        "intrinsic schedule (docs/gas_storage.md, Where the policy starts)")
    parser.add_argument("--learning-rate", type=positive(), help="peak learning rate (default per head: basestock 0.03, "
                        "others 0.01)")
    parser.add_argument("--sharpness", type=positive(), help="smoothing sharpness of the smooth value (gap about "
                        "log(2)/sharpness of a day's maximum flow; default 200)")
    parser.add_argument("--hard-training", action=argparse.BooleanOptionalAction, help="train and differentiate "
                        "the exact model (the basestock head can: its value is continuous in its targets; default no)")
    parser.add_argument("--train-float32", action=argparse.BooleanOptionalAction, help="training passes in float32; "
                        "evaluation and sensitivities stay float64 (default: basestock yes, others no)")
    parser.add_argument("--deltas-only", action="store_true", help="the reverse pass differentiates the forward "
                        "curve only, not the facility's parameters (a smaller program, compiled faster)")
    parser.add_argument("--bump", action="store_true", help="also run central bump-and-revalue of the deltas")


def add_lsmc_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--lsmc", action="store_true", help="also value by least-squares Monte Carlo, perfect "
                        "foresight and the dual upper bound on the same fresh paths (needs --stochastic)")
    parser.add_argument("--lsmc-nodes", type=count(), help=f"LSMC inventory grid levels (default {ONE_FACTOR_NODES}; with "
                        "--price-model in `snapo gas`, a step of at most a quarter of a day's smaller full flow, "
                        "101 levels at least)")
    parser.add_argument("--lsmc-degree", type=count(1, 12), help=f"LSMC polynomial degree in the spot (default "
                        f"{ONE_FACTOR_DEGREE}); with --price-model in `snapo gas`, the total degree in the model's state "
                        "(default 2, at most 6)")
    parser.add_argument("--foresight-paths", type=count(), default=256, help="paths of the perfect-foresight LPs")
    parser.add_argument("--price-model", type=pathlib.Path, metavar="FILE.yaml", help="value on this price model "
                        "(one-, two- or three-factor; docs/gas_storage.md, Price models): intrinsic, rolling intrinsic, "
                        "LSMC on the model's state, SNAPO reading the state, the dual bound (implies --stochastic)")
    parser.add_argument("--train-paths-file", type=pathlib.Path, metavar="FILE", help="the desk's training paths "
                        "(NPZ or Parquet): SNAPO samples --train-paths of them a step, LSMC regresses on them")
    parser.add_argument("--value-paths-file", type=pathlib.Path, metavar="FILE", help="the desk's valuation paths "
                        "(NPZ or Parquet): every method is valued on them")


def study_from_args(args):
    """Build the inputs and settings from parsed arguments (validated before any compile)."""
    from snapo_ode import InputError

    from ._cases import BDJ_MEAN_REVERSION, BDJ_VOLATILITY, CASES
    from ._files import load_curve, load_facility
    from ._inputs import make_inputs
    from ._study import StudySettings

    if not args.stochastic and (args.volatility is not None or args.mean_reversion is not None):
        raise InputError("--volatility and --mean-reversion set the stochastic spot: add --stochastic (without it "
                         "the study is deterministic and they would be ignored).")

    sample_facility, sample_curve = CASES[args.sample]()
    facility = load_facility(args.facility) if args.facility else sample_facility
    curve = load_curve(args.curve) if args.curve else sample_curve
    bdj = args.sample == "bdj"
    volatility = (BDJ_VOLATILITY["low"] if bdj else 0.5) if args.volatility is None else args.volatility
    mean_reversion = (BDJ_MEAN_REVERSION if bdj else 2.0) if args.mean_reversion is None else args.mean_reversion
    if not args.stochastic:
        volatility = mean_reversion = 0.0
    inputs = make_inputs(facility, curve, volatility=volatility, mean_reversion=mean_reversion)
    settings = StudySettings(stochastic=args.stochastic, paths=args.paths, head=args.head,
                             split_actions=args.split_actions, train_paths=args.train_paths, seed=args.seed,
                             train_steps=args.train_steps, learning_rate=args.learning_rate, sharpness=args.sharpness,
                             hard_training=args.hard_training, train_float32=args.train_float32,
                             deltas_only=args.deltas_only, bump=args.bump, progress=args.progress,
                             checkpoint_path=args.checkpoint, resume=args.resume, start=args.start)
    return inputs, settings


def _write(result, policy, json_path: pathlib.Path) -> int:
    """Publish the JSON and the trained policy beside it (`OUT.policy.eqx`) as one set, then the
    summary."""
    from ._policy import storage_policy_bytes

    written = result.publish(json_path, {".policy.eqx": storage_policy_bytes(policy)})
    print(result.summary())
    print(f"  written: {', '.join(map(str, written))}")
    for warning in getattr(result, "warnings", []):
        print(f"snapo: warning: {warning}", file=sys.stderr)
    return 0


def run_gas(args) -> int:
    from snapo_ode import InputError

    from ._study import run_study
    from ._versus_lsmc import compare_with_lsmc

    from ._path_files import paths_of_args

    if args.price_model is not None:
        from ._gas_model_cli import run_gas_on_model

        if args.volatility is not None or args.mean_reversion is not None:
            raise InputError("--volatility and --mean-reversion set the built-in one-factor model; with "
                             "--price-model the model file gives the parameters.")
        args.stochastic = True
        return run_gas_on_model(args, *study_from_args(args))
    inputs, settings = study_from_args(args)
    training, evaluation = paths_of_args(args, inputs)
    if (training is not None or evaluation is not None) and not settings.stochastic:
        raise InputError("--train-paths-file and --value-paths-file are spot paths: add --stochastic (or give "
                         "--price-model).")
    if args.lsmc:
        if not settings.stochastic:
            raise InputError("--lsmc needs --stochastic (LSMC values the optionality on simulated spot paths).")
        result = compare_with_lsmc(inputs, settings, nodes=args.lsmc_nodes or ONE_FACTOR_NODES,
                                   degree=args.lsmc_degree or ONE_FACTOR_DEGREE, foresight_paths=args.foresight_paths,
                                   training_paths=training, evaluation_paths=evaluation)
        return _write(result, result.study.policy, args.json)
    result = run_study(inputs, settings, training_paths=training, evaluation_paths=evaluation)
    return _write(result, result.policy, args.json)



def run_demo(args) -> int:
    from ._files import sample_curve, sample_facility
    from ._inputs import make_inputs
    from ._study import StudySettings, run_study

    inputs = make_inputs(sample_facility(), sample_curve())
    result = run_study(inputs, StudySettings(bump=True, seed=args.seed, progress=args.progress))
    return _write(result, result.policy, args.json)


def run_bench(args) -> int:
    from ._bench import run_gas_benchmark

    return run_gas_benchmark(args.out, paths=args.paths, repeats=args.repeats)


def run_bench_lsmc(args) -> int:
    from ._bench_lsmc import run_lsmc_benchmark

    run_lsmc_benchmark(args.out, paths=args.paths, train_paths=args.train_paths, train_steps=args.train_steps,
                       foresight_paths=args.foresight_paths, nodes=args.lsmc_nodes, degree=args.lsmc_degree,
                       seed=args.seed, head=args.head, progress=args.progress)
    return 0


def run_bench_family(args) -> int:
    from snapo_ode import InputError

    from ._bench_family import run_family_benchmark

    if args.price_model not in (None, "one-factor"):
        from ._bench_model_family import run_model_family

        run_model_family(args.out, args.price_model, paths=args.paths, cases=args.cases, seed=args.seed,
                         train_steps=args.train_steps, nodes=args.lsmc_nodes, names=tuple(args.case or ()),
                         progress=args.progress, fit_paths=args.fit_paths, rolling_paths=args.rolling_paths)
        return 0
    for flag, value in (("--fit-paths", args.fit_paths), ("--rolling-paths", args.rolling_paths)):
        if value is not None:
            raise InputError(f"{flag} {value}: it sets the paths of a multi-factor family; allowed only with "
                             "--price-model two-factor or three-factor.")

    run_family_benchmark(args.out, paths=args.paths, cases=args.cases, seed=args.seed, train_steps=args.train_steps,
                         nodes=args.lsmc_nodes or ONE_FACTOR_NODES, volatilities=tuple(args.volatility),
                         progress=args.progress, names=tuple(args.case or ()))
    return 0


def smoothing_accuracy(args):
    from ._accuracy import smoothing_study

    return smoothing_study(quick=args.quick, seed=args.seed)


def monte_carlo_accuracy(args):
    from ._accuracy import monte_carlo_study

    return monte_carlo_study(quick=args.quick, seed=args.seed)


def register_gas(cli) -> None:
    """Add `snapo gas`, `snapo demo`, `snapo bench gas`, `snapo bench gas-lsmc` and `snapo bench gas-family`."""
    gas = cli.command("gas", "train a storage policy, value it hard and smooth against the intrinsic LP, "
                      "and take every forward-curve delta from one reverse pass (the policy is saved beside "
                      "the JSON)")
    add_study_arguments(gas)
    add_training_options(gas)
    add_lsmc_arguments(gas)
    gas.set_defaults(handler=run_gas)
    demo = cli.command("demo", "the gas-storage study on the built-in sample facility and curve, with bumps "
                       "(writes OUT/gas.json and OUT/gas.policy.eqx)", json_name="gas.json")
    demo.set_defaults(handler=run_demo)
    bench = cli.bench("gas", "training time, gradient/forward ratio, adjoint vs bump-and-revalue, scan vs Diffrax")
    bench.add_argument("--paths", type=count(), default=1000, help="Monte Carlo paths of the stochastic case")
    bench.add_argument("--repeats", type=count(), default=5)
    bench.set_defaults(handler=run_bench)
    versus = cli.bench("gas-lsmc", "SNAPO against least-squares Monte Carlo on the Boogert & de Jong (2008) "
                       "contract, both volatilities, the same fresh paths")
    versus.add_argument("--paths", type=count(), default=10_000, help="LSMC fitting paths and evaluation paths")
    versus.add_argument("--head", choices=["basestock", "fraction", "split"], default="basestock")
    versus.add_argument("--train-paths", type=count(), help="SNAPO: fresh paths per training step (default: the head's)")
    versus.add_argument("--train-steps", type=count(), help="default: the head's")
    versus.add_argument("--foresight-paths", type=count(), default=1000, help="paths of the perfect-foresight LPs")
    versus.add_argument("--lsmc-nodes", type=count(), default=101)
    versus.add_argument("--lsmc-degree", type=count(1, 12), default=3)
    versus.set_defaults(handler=run_bench_lsmc)
    family = cli.bench("gas-family", "SNAPO, LSMC, the dual bound and the intrinsic LP on a generated family of "
                       "curves (weekly shapes, holidays, spikes, seasonal, flat, contango, backwardation) and "
                       "facilities (fast, slow, ratchets, fuel and costs, everything), the same fresh paths")
    family.add_argument("--paths", type=count(), default=10_000, help="LSMC fitting paths and evaluation paths")
    family.add_argument("--cases", type=count(), help="the first CASES of the family (default: all 14)")
    family.add_argument("--case", nargs="+", metavar="NAME", help="only these cases, named as in the table "
                        "(e.g. flat-fast-90 spikes-ratchets-90); a row to rerun")
    family.add_argument("--volatility", nargs="+", choices=["low", "high"], default=["low", "high"],
                        help="B&dJ's volatilities to run (mean reversion 0.05/day)")
    family.add_argument("--train-steps", type=count(), help="SNAPO training steps (default: the head's)")
    family.add_argument("--lsmc-nodes", type=count(), help=f"LSMC levels at least, more where a flow needs (default "
                        f"{ONE_FACTOR_NODES}; with --price-model two-factor or three-factor, a step of at most a "
                        "quarter of a day's smaller full flow, 101 levels at least)")
    family.add_argument("--price-model", choices=["one-factor", "two-factor", "three-factor"], help="value under "
                        "this price model's shipped example (finance/data/price_model_*.yaml): intrinsic, rolling "
                        "intrinsic, LSMC on the model's state, SNAPO, the bound; LSMC, the bound's penalty and SNAPO fit on "
                        "--fit-paths training paths (default: the one-factor family)")
    family.add_argument("--fit-paths", type=count(), help="with --price-model: the training paths LSMC and the "
                        "bound's penalty regress on and SNAPO samples (default 4 x PATHS)")
    family.add_argument("--rolling-paths", type=count(), help="with --price-model: daily rolling intrinsic on the "
                        "first this many evaluation paths, paired with SNAPO on them (default 500; its work grows as "
                        "days^2)")
    family.set_defaults(handler=run_bench_family)
    cli.accuracy("smoothing", smoothing_accuracy)
    cli.accuracy("monte-carlo", monte_carlo_accuracy)
