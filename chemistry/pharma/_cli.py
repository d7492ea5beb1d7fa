"""`snapo pharma sensitivities`, `snapo bench pharma` and `snapo report pharma`."""

import argparse
import pathlib

from ._parameters import CPP_RANGES

DEFAULT_OUT = pathlib.Path("snapo-out")


def add_chain_arguments(parser: argparse.ArgumentParser) -> None:
    """CPP values, solver tolerances and effects."""
    for spec in CPP_RANGES:
        parser.add_argument(f"--{spec.name.replace('_', '-')}", type=float, default=spec.nominal,
                            help=f"{spec.description} [{spec.unit}] (nominal {spec.nominal:g}, PAR "
                                 f"{spec.par[0]:g}-{spec.par[1]:g})")
    parser.add_argument("--rtol", type=float, default=1e-8, help="relative tolerance of every unit's solve")
    parser.add_argument("--atol", type=float, default=1e-10, help="absolute tolerance (scaled states)")
    parser.add_argument("--solver", default="kvaerno5", help="kvaerno5, kvaerno4 or kvaerno3")
    parser.add_argument("--without", action="append", default=[], metavar="EFFECT",
                        help="leave an effect out (repeatable)")


def chain_from_args(args):
    """The chain and the CPPs from parsed arguments, validated before any compile."""
    from ._chain import PHARMA_EFFECTS, PharmaChain
    from ._parameters import make_cpps
    from ._solver import ChainSolver

    solver = ChainSolver(rtol=args.rtol, atol=args.atol, solver=args.solver)
    scene = PHARMA_EFFECTS.scene(without=args.without)
    cpps = make_cpps(**{spec.name: getattr(args, spec.name) for spec in CPP_RANGES})
    return PharmaChain(scene=scene, solver=solver), cpps


def run_sensitivities(args) -> int:
    from snapo_ode import atomic_write_json, check_choice

    from ._solver import ChainSolver
    from ._study import REFERENCE, sensitivity_study, summary_table

    check_choice("mode", args.mode, ("auto", "reverse", "forward"))
    chain, cpps = chain_from_args(args)
    reference = None if args.no_reference else ChainSolver(rtol=args.reference_rtol, atol=args.reference_atol,
                                                           max_steps=REFERENCE.max_steps)
    study, _ = sensitivity_study(chain, cpps, mode=args.mode, repeats=args.repeats,
                                 check_bumps=not args.no_bumps, reference=reference)
    print(summary_table(study))
    if args.json:
        atomic_write_json(args.json, study)
        print(f"written: {args.json}")
    return 0


def run_bench(args) -> int:
    from ._bench import run_pharma_benchmark

    return run_pharma_benchmark(args.out, rtols=[float(x) for x in args.rtols.split(",")], repeats=args.repeats)


def register_pharma(cli) -> None:
    """Add `snapo pharma sensitivities` and `snapo bench pharma`."""
    pharma = cli.command("pharma", "the 4-unit API chain: ICH Q8 sensitivities of the CQAs to the CPPs "
                         "and to every kinetic and physical parameter")
    verbs = pharma.add_subparsers(dest="pharma_verb", metavar="VERB")
    sens = verbs.add_parser("sensitivities", help="the 5x4 dCQA/dCPP matrix and every parameter sensitivity, "
                            "checked against central differences and a tight-tolerance reference")
    add_chain_arguments(sens)
    sens.add_argument("--mode", default="auto", help="auto (the cheaper for the Jacobian's shape), reverse, forward")
    sens.add_argument("--repeats", type=int, default=10, help="timed runs after the compile")
    sens.add_argument("--no-bumps", action="store_true", help="skip the central-difference check")
    sens.add_argument("--no-reference", action="store_true", help="skip the tight-tolerance reference")
    sens.add_argument("--reference-rtol", type=float, default=1e-12)
    sens.add_argument("--reference-atol", type=float, default=1e-14)
    sens.add_argument("--json", type=pathlib.Path, help="output JSON path")
    sens.set_defaults(handler=run_sensitivities)
    bench = cli.bench("pharma", "20 sensitivities from 5 reverse passes vs 4 forward tangents: median after "
                      "compile and accuracy against a tight-tolerance reference, per tolerance")
    bench.add_argument("--out", type=pathlib.Path, default=DEFAULT_OUT)
    bench.add_argument("--rtols", default="1e-6,1e-8", help="comma-separated rtol values (atol = rtol / 100)")
    bench.add_argument("--repeats", type=int, default=25)
    bench.set_defaults(handler=run_bench)
