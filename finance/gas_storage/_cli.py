"""`snapo gas`, `snapo demo` and `snapo bench gas`."""

import argparse
import pathlib

DEFAULT_OUT = pathlib.Path("snapo-out")


def add_study_arguments(parser: argparse.ArgumentParser) -> None:
    from ._cases import CASES

    parser.add_argument("--sample", choices=sorted(CASES), default="sample",
                        help="built-in facility and curve (bdj: Boogert & de Jong 2008)")
    parser.add_argument("--curve", type=pathlib.Path, help="forward curve CSV with header day,price "
                        "[$/MMBtu] (default: the --sample's)")
    parser.add_argument("--facility", type=pathlib.Path, help="facility JSON (default: the --sample's)")
    parser.add_argument("--stochastic", action="store_true", help="trade on simulated spot paths")
    parser.add_argument("--volatility", type=float, help="OU factor volatility [1/sqrt(year)] (default 0.5; "
                        "bdj: 0.6018, B&dJ's 3.15%% per sqrt(day))")
    parser.add_argument("--mean-reversion", type=float, help="OU mean reversion [1/year] (default 2; "
                        "bdj: 18.25, B&dJ's 0.05/day)")
    parser.add_argument("--paths", type=int, default=1000, help="Monte Carlo paths (stochastic mode)")
    parser.add_argument("--train-paths", type=int, default=256, help="fresh paths per training step")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--train-steps", type=int, default=1500)
    parser.add_argument("--sharpness", type=float, default=200.0,
                        help="smoothing sharpness (gap about log(2)/sharpness of a day's maximum flow)")
    parser.add_argument("--split-actions", action="store_true", help="policy with separate inject and withdraw "
                        "scores, bang-bang in the hard evaluation (see make_policy)")
    parser.add_argument("--bump", action="store_true", help="also run central bump-and-revalue of the deltas")


def study_from_args(args):
    """Build the inputs and settings from parsed arguments (validated before any compile)."""
    from .. import gas_storage as gs
    from ._study import StudySettings

    from ._cases import BDJ_MEAN_REVERSION, BDJ_VOLATILITY, CASES

    sample_facility, sample_curve = CASES[args.sample]()
    facility = gs.load_facility(args.facility) if args.facility else sample_facility
    curve = gs.load_curve(args.curve) if args.curve else sample_curve
    bdj = args.sample == "bdj"
    volatility = (BDJ_VOLATILITY["low"] if bdj else 0.5) if args.volatility is None else args.volatility
    mean_reversion = (BDJ_MEAN_REVERSION if bdj else 2.0) if args.mean_reversion is None else args.mean_reversion
    if not args.stochastic:
        volatility = mean_reversion = 0.0
    inputs = gs.make_inputs(facility, curve, volatility=volatility, mean_reversion=mean_reversion)
    settings = StudySettings(stochastic=args.stochastic, paths=args.paths, train_paths=args.train_paths,
                             seed=args.seed, train_steps=args.train_steps, sharpness=args.sharpness,
                             split_actions=args.split_actions, bump=args.bump)
    return inputs, settings


def summary_table(result: dict) -> str:
    """A short readable summary of a study's result."""
    lines = [
        f"gas storage, {result['mode']} ({len(result['deltas'])} days)",
        f"  intrinsic value (exact {result['intrinsic_method']})   {result['intrinsic_lp']:>16,.0f} $",
        f"  policy value, hard constraints      {result['value_hard']:>16,.0f} $"
        f"   ({100 * result['hard_to_lp_ratio']:.2f}% of intrinsic)",
        f"  policy value, smooth (training)     {result['value_smooth']:>16,.0f} $"
        f"   (smooth - hard: {result['smoothing_gap']:,.0f} $)",
        f"  worst hard-constraint violation     {result['max_constraint_violation']:>16.2e} MMBtu",
        f"  training: {result['train_steps']} steps in {result['train_seconds']:.1f} s after "
        f"{result['compile_seconds']:.1f} s compile",
        f"  {len(result['deltas'])} forward-curve deltas + {len(result['parameter_sensitivities'])} parameter "
        f"sensitivities from one reverse pass: {1e3 * result['gradient_seconds']:.2f} ms "
        f"({result['gradient_forward_ratio']:.2f}x the forward pass)",
    ]
    if "value_hard_se" in result:
        lines.insert(3, f"  standard error (out of sample)      {result['value_hard_se']:>16,.0f} $")
    if "lsmc_out_of_sample" in result:
        lines += [
            f"  on the same {result['paths']:,} fresh paths (out of sample, hard constraints):",
            f"    SNAPO policy                      {result['snapo_out_of_sample']:>16,.0f} $ +- {result['snapo_se']:,.0f}",
            f"    LSMC ({result['lsmc_nodes']} nodes, degree {result['lsmc_degree']})         "
            f"{result['lsmc_out_of_sample']:>16,.0f} $ +- {result['lsmc_se']:,.0f}"
            f"   (in sample {result['lsmc_in_sample']:,.0f})",
            f"    SNAPO - LSMC (paired)             {result['snapo_minus_lsmc']:>16,.0f} $ +- "
            f"{result['snapo_minus_lsmc_se']:,.0f}",
            f"    perfect foresight ({result['perfect_foresight_paths']} paths)     "
            f"{result['perfect_foresight']:>16,.0f} $ +- {result['perfect_foresight_se']:,.0f}",
            f"  wall time: SNAPO training + every delta {result['snapo_seconds']:.1f} s; LSMC valuation "
            f"{result['lsmc_fit_seconds']:.2f} s (+ {result['lsmc_eval_seconds']:.2f} s out of sample); compile apart",
        ]
    if "bump_seconds" in result:
        lines.append(
            f"  central bump-and-revalue: batched {1e3 * result['bump_batched_seconds']:.1f} ms, sequential "
            f"{1e3 * result['bump_sequential_seconds']:.0f} ms; max relative difference {result['max_rel_diff']:.1e}"
        )
    return "\n".join(lines)


def run_gas(args) -> int:
    from snapo_ode import InputError, atomic_write_json, save_policy

    from ._study import run_study

    from ._versus_lsmc import compare_with_lsmc

    inputs, settings = study_from_args(args)
    if args.lsmc:
        if not settings.stochastic:
            raise InputError("--lsmc needs --stochastic (LSMC values the optionality on simulated spot paths).")
        result, policy = compare_with_lsmc(inputs, settings, nodes=args.lsmc_nodes, degree=args.lsmc_degree,
                                           foresight_paths=args.foresight_paths)
    else:
        result, policy = run_study(inputs, settings)
    policy_path = args.json.with_suffix(".policy.eqx")
    save_policy(policy_path, policy)
    atomic_write_json(args.json, result)
    print(summary_table(result))
    print(f"  written: {args.json}, {policy_path}")
    return 0


def run_demo(args) -> int:
    from snapo_ode import atomic_write_json, save_policy

    from .. import gas_storage as gs
    from ._study import StudySettings, run_study

    inputs = gs.make_inputs(gs.sample_facility(), gs.sample_curve())
    result, policy = run_study(inputs, StudySettings(bump=True))
    path = args.out / "gas.json"
    save_policy(args.out / "gas.policy.eqx", policy)
    atomic_write_json(path, result)
    print(summary_table(result))
    print(f"  written: {path}, {args.out / 'gas.policy.eqx'}")
    return 0


def run_bench(args) -> int:
    from ._bench import run_gas_benchmark

    return run_gas_benchmark(args.out, paths=args.paths, repeats=args.repeats)


def run_bench_lsmc(args) -> int:
    from ._bench_lsmc import run_lsmc_benchmark

    run_lsmc_benchmark(args.out, paths=args.paths, train_paths=args.train_paths, train_steps=args.train_steps,
                       foresight_paths=args.foresight_paths, nodes=args.lsmc_nodes, degree=args.lsmc_degree)
    return 0


def register_gas(cli) -> None:
    """Add `snapo gas`, `snapo demo` and `snapo bench gas`."""
    gas = cli.command("gas", "train a storage policy, value it hard and smooth against the intrinsic LP, "
                      "and take every forward-curve delta from one reverse pass")
    add_study_arguments(gas)
    gas.add_argument("--lsmc", action="store_true", help="also value by least-squares Monte Carlo and perfect "
                     "foresight on the same fresh paths (needs --stochastic)")
    gas.add_argument("--lsmc-nodes", type=int, default=101, help="LSMC inventory grid levels")
    gas.add_argument("--lsmc-degree", type=int, default=3, help="LSMC polynomial degree in spot")
    gas.add_argument("--foresight-paths", type=int, default=256, help="paths of the perfect-foresight LPs")
    gas.add_argument("--json", type=pathlib.Path, default=DEFAULT_OUT / "gas.json", help="output JSON path")
    gas.set_defaults(handler=run_gas)
    demo = cli.command("demo", "the gas-storage study on the built-in sample facility and curve")
    demo.add_argument("--out", type=pathlib.Path, default=DEFAULT_OUT)
    demo.set_defaults(handler=run_demo)
    bench = cli.bench("gas", "training time, gradient/forward ratio, adjoint vs bump-and-revalue, scan vs Diffrax")
    bench.add_argument("--out", type=pathlib.Path, default=DEFAULT_OUT)
    bench.add_argument("--paths", type=int, default=1000, help="Monte Carlo paths of the stochastic case")
    bench.add_argument("--repeats", type=int, default=5)
    bench.set_defaults(handler=run_bench)
    versus = cli.bench("gas-lsmc", "SNAPO against least-squares Monte Carlo on the Boogert & de Jong (2008) "
                       "contract, both volatilities, the same fresh paths")
    versus.add_argument("--out", type=pathlib.Path, default=DEFAULT_OUT)
    versus.add_argument("--paths", type=int, default=10_000, help="LSMC fitting paths and evaluation paths")
    versus.add_argument("--train-paths", type=int, default=256, help="SNAPO: fresh paths per training step")
    versus.add_argument("--train-steps", type=int, default=400)
    versus.add_argument("--foresight-paths", type=int, default=1000, help="paths of the perfect-foresight LPs")
    versus.add_argument("--lsmc-nodes", type=int, default=101)
    versus.add_argument("--lsmc-degree", type=int, default=3)
    versus.set_defaults(handler=run_bench_lsmc)
