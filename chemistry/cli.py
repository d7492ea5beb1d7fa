"""CLI verbs of the `chemistry` domain, registered through the `snapo_ode.plugins` entry point."""

import argparse
import pathlib

from snapo_ode.cli import CommandLine

from .pharma._cli import register_pharma


def run_check(args) -> int:
    from snapo_ode import atomic_write_json

    from ._check import check_mechanism, summary
    from ._ignition import IgnitionCase
    from ._units import ONE_ATM

    case = None
    if args.mixture:
        case = IgnitionCase(args.mixture, args.temperature, args.pressure or ONE_ATM, args.end_time,
                            args.sensitivity_time or float("nan"))
    result = check_mechanism(args.mechanism, phase=args.phase, n_states=args.states, seed=args.seed, case=case,
                             ignition=not args.no_ignition, sensitivities=not args.no_sensitivities)
    print(summary(result))
    if args.json:
        atomic_write_json(args.json, result)
        print(f"  written: {args.json}")
    return 0


def run_bench(args) -> int:
    from ._bench import run_kinetics_benchmark

    run_kinetics_benchmark(args.out, mechanisms=args.mechanisms, repeats=args.repeats)
    return 0


def register(cli: CommandLine) -> None:
    """Add this domain's verbs, benchmarks and reports to the `snapo` command line."""
    kinetics = cli.command("kinetics", "Cantera-YAML kinetics: check a mechanism against Cantera")
    verbs = kinetics.add_subparsers(dest="kinetics_verb", metavar="VERB", required=True)
    check = verbs.add_parser("check", help="rates at random states, constant-volume ignition and d ln T / d ln A "
                             "against Cantera", description="Compare MECH.yaml with Cantera.")
    check.add_argument("mechanism", type=pathlib.Path, metavar="MECH.yaml")
    check.add_argument("--phase", help="phase name (default: the file's first)")
    check.add_argument("--json", type=pathlib.Path, help="write the results here (atomically)")
    check.add_argument("--states", type=int, default=120, help="random states of the rate comparison")
    check.add_argument("--seed", type=int, default=0)
    check.add_argument("--mixture", help="ignition mixture in Cantera's mole ratios, e.g. 'H2:2,O2:1,N2:3.76' "
                       "(default: H2/O2 or CH4/air when the mechanism has them)")
    check.add_argument("--temperature", type=float, default=1000.0, help="ignition start temperature [K]")
    check.add_argument("--pressure", type=float, help="ignition start pressure [Pa] (default 1 atm)")
    check.add_argument("--end-time", type=float, default=1e-3, help="ignition end time [s]")
    check.add_argument("--sensitivity-time", type=float, help="time of d ln T / d ln A [s] (default: 0.9 x delay)")
    check.add_argument("--no-ignition", action="store_true", help="rates only")
    check.add_argument("--no-sensitivities", action="store_true", help="skip the sensitivity comparison")
    check.set_defaults(handler=run_check)
    bench = cli.bench("kinetics", "forward solve and gradient wrt every A-factor vs Cantera with and without "
                      "forward sensitivities, at equal tolerance")
    bench.add_argument("--out", type=pathlib.Path, default=pathlib.Path("results"))
    bench.add_argument("--mechanisms", nargs="+", default=["h2o2", "gri30"], choices=["h2o2", "gri30"],
                       help="built-in ignition cases (gri30: ~3 minutes, most of it compiling and Cantera's "
                            "325 sensitivities)")
    bench.add_argument("--repeats", type=int, default=5)
    bench.set_defaults(handler=run_bench)
    register_pharma(cli)
