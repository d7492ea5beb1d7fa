"""`snapo kinetics check`, `snapo kinetics sweep` and `snapo bench kinetics`.

Heavy imports (JAX, Cantera, the model) happen inside the handlers, so `snapo --help` stays quick.
"""

import importlib.util
import pathlib

from snapo_ode.cli import count, positive, CommandLine

CASE_FIELDS = ("temperature", "pressure", "end_time", "sensitivity_time")


def run_check(args) -> int:
    from ._check import check_against_cantera

    overrides = {field: getattr(args, field) for field in CASE_FIELDS if getattr(args, field) is not None}
    result = check_against_cantera(args.mechanism, phase=args.phase, n_states=args.states, seed=args.seed,
                                   mixture=args.mixture, case_overrides=overrides, ignition=not args.no_ignition,
                                   sensitivities=not args.no_sensitivities, progress=args.progress)
    print(result.summary())
    print(f"  written: {result.write_json(args.json)}")
    return 0


def run_sweep(args) -> int:
    from snapo_ode import atomic_write_json

    from ._sweep import as_json, markdown_table, sweep

    results = sweep(args.files or None, n_states=args.states, seed=args.seed)
    print(markdown_table(results))
    print(f"  written: {atomic_write_json(args.json, as_json(results, n_states=args.states, seed=args.seed))}")
    return 0


def run_bench(args) -> int:
    from snapo_ode import check_count

    from ._bench import run_kinetics_benchmark

    if args.batch is not None:
        check_count("--batch", args.batch, 1)
    for size in args.batch_scaling:
        check_count("--batch-scaling", size, 1)
    run_kinetics_benchmark(args.out, mechanisms=args.mechanisms, repeats=args.repeats, batch=args.batch,
                           scaling=args.batch_scaling)
    return 0


def stiff_accuracy(args):
    from ._solver_accuracy import stiff_study

    return stiff_study(quick=args.quick)


def register_kinetics(cli: CommandLine) -> None:
    """Add `snapo kinetics check`, `snapo kinetics sweep` and `snapo bench kinetics`."""
    kinetics = cli.group("kinetics", "Cantera-YAML kinetics: check a mechanism against Cantera")
    check = cli.command("check", "rates at random states, constant-volume ignition and d ln T / d ln A against "
                        "Cantera", group=kinetics)
    check.add_argument("mechanism", type=pathlib.Path, metavar="MECH.yaml")
    check.add_argument("--phase", help="phase name (default: the file's first)")
    check.add_argument("--states", type=count(), default=120, help="random states of the rate comparison")
    check.add_argument("--mixture", help="ignition mixture in Cantera's mole ratios, e.g. 'H2:2,O2:1,N2:3.76' "
                       "(default: H2/O2 or CH4/air when the mechanism has them)")
    check.add_argument("--temperature", type=positive(), help="ignition start temperature [K] (default: the case's, "
                       "1000 K for H2/O2, 1500 K for CH4/air)")
    check.add_argument("--pressure", type=positive(), help="ignition start pressure [Pa] (default 1 atm)")
    check.add_argument("--end-time", type=positive(), help="ignition end time [s] (default: the case's)")
    check.add_argument("--sensitivity-time", type=positive(), help="time of d ln T / d ln A [s] (default: the case's, "
                       "else 0.9 x the delay)")
    check.add_argument("--no-ignition", action="store_true", help="rates only")
    check.add_argument("--no-sensitivities", action="store_true", help="skip the sensitivity comparison")
    check.set_defaults(handler=run_check)
    sweep = cli.command("sweep", "every ideal-gas phase shipped with Cantera (or of the files given): read and "
                        "compared with Cantera, or refused naming the feature (a Markdown table)", group=kinetics)
    sweep.add_argument("files", nargs="*", type=pathlib.Path, metavar="MECH.yaml",
                       help="YAML files (default: every *.yaml in Cantera's data directory)")
    sweep.add_argument("--states", type=count(), default=4, help="random states per phase (T 500-2500 K, "
                       "P 0.01-100 atm)")
    sweep.set_defaults(handler=run_sweep)
    bench = cli.bench("kinetics", "forward solve and gradient wrt every A-factor vs Cantera with and without "
                      "forward sensitivities, at equal tolerance")
    bench.add_argument("--mechanisms", nargs="+", default=["h2o2", "gri30"], choices=["h2o2", "gri30"],
                       help="built-in ignition cases (gri30: ~3 minutes, most of it compiling and Cantera's "
                            "325 sensitivities)")
    bench.add_argument("--repeats", type=count(), default=5)
    bench.add_argument("--batch", type=count(), metavar="N", help="also N reactors from spread initial states, per "
                       "reactor: our forward solves as one batch, our gradients vmapped over a sample, Cantera "
                       "serially (gri30 with N = 256 and --repeats 1: ~3-5 minutes on 2 cores, compiles included)")
    bench.add_argument("--batch-scaling", type=count(), nargs="+", default=[], metavar="N", help="also, at each N, "
                       "our forward solves as one batch and Cantera serially on the same N reactors, per reactor "
                       "(bench_kinetics_scaling.{csv,json}): how batching amortises as N grows (on a GPU)")
    bench.set_defaults(handler=run_bench)
    cli.accuracy("stiff", stiff_accuracy)
    data = pathlib.Path(importlib.util.find_spec("cantera").origin).parent / "data"  # without importing Cantera
    cli.first_result("kinetics check", ["kinetics", "check", str(data / "h2o2.yaml")])
    cli.first_result("gri30 gradient", ["kinetics", "check", str(data / "gri30.yaml"), "--states", "1"])
