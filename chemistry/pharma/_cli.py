"""`snapo pharma sensitivities|train|design-space`, `snapo bench pharma` and `snapo report pharma`.

Heavy imports (JAX, the model) happen inside the handlers, so `snapo --help` stays quick.
"""

import argparse
import sys

from snapo_ode.cli import count, number, numbers, positive, add_device_options, add_training_options

from ._chain_cli import add_chain_arguments, chain_from_args
from ._fit_cli import add_grid_arguments, add_posterior_argument, posterior_option, register_fit


def add_accuracy_arguments(parser: argparse.ArgumentParser) -> None:
    """`--max-solver-error` and `--strict`: what the solver error against the tight reference may be."""
    parser.add_argument("--max-solver-error", type=positive(), default=1e-4, help="relative error against the reference "
                        "above which the result warns (JSON, stderr, report)")
    parser.add_argument("--strict", action="store_true", help="a solver error above --max-solver-error is an "
                        "error (exit 3, nothing written), not a warning")


def check_solver_errors(args, warnings) -> None:
    """Say each solver-error warning on stderr at once; with `--strict`, raise `SolverFailed`."""
    from snapo_ode import SolverFailed

    solver_errors = [warning for warning in warnings if warning.startswith("solver error")]
    for warning in solver_errors:
        print(f"snapo: warning: {warning}", file=sys.stderr)
    if args.strict and solver_errors:
        raise SolverFailed(f"--strict: {solver_errors[0]} (nothing written).")


def _finish(result, path) -> int:
    print(result.summary())
    print(f"written: {result.write_json(path)}")
    return 0


def run_sensitivities(args) -> int:
    from snapo_ode import check_choice

    from ._study import REFERENCE, sensitivity_study

    check_choice("mode", args.mode, ("auto", "reverse", "forward"))
    chain, inputs = chain_from_args(args)
    reference = None if args.no_reference else REFERENCE.replace(rtol=args.reference_rtol, atol=args.reference_atol)
    study = sensitivity_study(chain, inputs, mode=args.mode, repeats=args.repeats, check_bumps=not args.no_bumps,
                              reference=reference, max_solver_error=args.max_solver_error)
    check_solver_errors(args, study.warnings)
    return _finish(study, args.json)


def run_train(args) -> int:
    from snapo_ode import policy_bytes

    from ._policy import train_profiles

    chain, inputs = chain_from_args(args)
    study = train_profiles(chain, inputs.cpps, inputs.physical, steps=args.steps, learning_rate=args.learning_rate,
                           penalty_weight=args.penalty_weight, sharpness=args.sharpness, seed=args.seed,
                           progress=args.progress, checkpoint_path=args.checkpoint, resume=args.resume)
    profiles = study.profiles
    policies = {f".{profiles.jacket_unit}.eqx": policy_bytes(profiles.r1_jacket.policy)}  # the built-in's: .r1.eqx
    if profiles.cooling is not None:
        policies[".cooling.eqx"] = policy_bytes(profiles.cooling.policy)
    written = study.publish(args.json, policies)
    print(study.summary())
    print(f"written: {', '.join(map(str, written))}")
    return 0


def _space_options(args) -> dict:
    """The design space's options, checked against the process's CPPs (read from its file, before
    anything is built or computed), and the mesh."""
    from ._design_space import DesignSpaceSettings
    from ._process_file import load_process

    names = tuple(spec.name for spec in load_process(args.process).cpps)
    settings = DesignSpaceSettings(x=args.x, y=args.y, cpp_names=names, points=args.points, samples=args.samples, sigma=args.sigma,
                                   seed=args.seed, level=args.level, verify_points=args.verify_points,
                                   surrogate_samples=args.surrogate_samples, curvature_points=args.curvature_points)
    options = settings.as_dict()
    del options["cpp_names"]  # the chain's own
    return {**options, "mesh": args.mesh}


def run_design_space(args) -> int:
    from ._design_space import design_space

    from snapo_ode import is_writer

    options = _space_options(args)
    chain, inputs = chain_from_args(args)
    space = design_space(chain, inputs, **options, **posterior_option(args, chain))
    return _finish(space, args.json) if is_writer() else 0


def run_report(args) -> int:
    from snapo_ode.cli import publish_report

    from ._report import build_report, pharma_report, report_provenance

    options = _space_options(args)
    chain, inputs = chain_from_args(args)
    data = build_report(chain, inputs, repeats=args.repeats, max_solver_error=args.max_solver_error,
                        check_warnings=lambda warnings: check_solver_errors(args, warnings), **options,
                        **posterior_option(args, chain))
    from snapo_ode import is_writer

    if not is_writer():
        return 0
    return publish_report(args, pharma_report(data, report_provenance(chain, inputs, command=args.command_line)))


def add_design_space_arguments(parser: argparse.ArgumentParser) -> None:
    """The design space's grid, uncertainty, level and verification."""
    add_grid_arguments(parser)
    parser.add_argument("--level", "--confidence", type=number(0, 1, low_open=True, high_open=True), default=0.95, dest="level",
                        help="the probability of meeting every spec that defines the design space (default 0.95)")
    parser.add_argument("--sigma", type=positive(2), default=0.1, help="standard deviation of each uncertain ln k")
    parser.add_argument("--surrogate-samples", type=count(), default=4096, help="draws of the surrogate map")
    parser.add_argument("--curvature-points", type=count(0), default=6,
                        help="coarse grid per CPP of the surrogate's second-order term (0: first order)")
    parser.add_argument("--verify-points", type=count(), default=9, help="grid points checked by full Monte Carlo")
    parser.add_argument("--samples", type=count(), default=1000, help="full-model draws at each verification point")
    add_posterior_argument(parser)


def run_bench(args) -> int:
    from ._bench import run_pharma_benchmark

    return run_pharma_benchmark(args.out, rtols=args.rtols, repeats=args.repeats)


def gradient_accuracy(args):
    from ._accuracy import gradient_study

    return gradient_study(quick=args.quick)


def device_scaling(args):
    from ._device_scaling import device_scaling

    return device_scaling(mesh=args.mesh, quick=args.quick, seed=args.seed, repeats=args.repeats)


def register_pharma(cli) -> None:
    """Add `snapo pharma sensitivities|train|design-space`, `snapo bench pharma`,
    `snapo report pharma`, the "gradients" study of `snapo bench accuracy`, the "pharma"
    workload of `snapo bench scaling` and two of `snapo bench first-result`."""
    pharma = cli.group("pharma", "a process (--process FILE; the built-in API chain by default): ICH Q8 "
                       "sensitivities of the CQAs to the CPPs and to every kinetic and physical parameter")
    sens = cli.command("sensitivities", "the 5x4 dCQA/dCPP matrix and every parameter sensitivity, checked "
                       "against central differences and a tight-tolerance reference", group=pharma)
    add_chain_arguments(sens)
    sens.add_argument("--mode", default="auto", help="auto (the cheaper for the Jacobian's shape), reverse, forward")
    sens.add_argument("--repeats", type=count(), default=10, help="timed runs after the compile")
    sens.add_argument("--no-bumps", action="store_true", help="skip the central-difference check")
    sens.add_argument("--no-reference", action="store_true", help="skip the tight-tolerance reference")
    sens.add_argument("--reference-rtol", type=positive(1), default=1e-12)
    sens.add_argument("--reference-atol", type=positive(), default=1e-14)
    add_accuracy_arguments(sens)
    sens.set_defaults(handler=run_sensitivities)
    train = cli.command("train", "train the jacket profile of the process's first reactor whose temperature is a "
                        "CPP and a cooling crystallizer's cooling profile for yield, specs as smooth penalties; "
                        "evaluate with hard spec checks (JSON 'profiles' by unit; policies beside it, "
                        ".UNIT.eqx and .cooling.eqx)", group=pharma)
    add_chain_arguments(train)
    train.add_argument("--steps", type=count(), default=60)
    train.add_argument("--learning-rate", type=positive(), default=3e-2)
    train.add_argument("--penalty-weight", type=number(0), default=1.0)
    train.add_argument("--sharpness", type=positive(), default=50.0, help="of the softplus spec penalty")
    add_training_options(train)
    train.set_defaults(handler=run_train)
    space = cli.command("design-space", "P(all specs) over a fine grid of two CPPs under uncertain rate constants, "
                        "from a sensitivity-based surrogate checked by full Monte Carlo", group=pharma)
    add_chain_arguments(space)
    add_design_space_arguments(space)
    add_device_options(space)
    space.set_defaults(handler=run_design_space)
    register_fit(cli, pharma)
    report = cli.report("pharma", "the ICH Q8 sensitivity and design-space report: report.html, report.pdf "
                        "(printed from it), CSV files, report.json")
    add_chain_arguments(report)
    add_design_space_arguments(report)
    add_device_options(report)
    report.add_argument("--repeats", type=count(), default=5, help="timed runs of the sensitivities")
    add_accuracy_arguments(report)
    report.set_defaults(handler=run_report)
    bench = cli.bench("pharma", "20 sensitivities from 5 reverse passes vs 4 forward tangents: median after "
                      "compile and accuracy against a tight-tolerance reference, per tolerance")
    bench.add_argument("--rtols", type=numbers(0, 1, low_open=True, high_open=True), default="1e-5,3e-6,1e-6,1e-7,1e-8",
                       help="comma-separated rtol values (atol = rtol / 100)")
    bench.add_argument("--repeats", type=count(), default=25)
    bench.set_defaults(handler=run_bench)
    cli.accuracy("gradients", gradient_accuracy)
    cli.scaling("pharma", device_scaling)
    cli.first_result("pharma sensitivities", ["pharma", "sensitivities"])
    cli.first_result("report pharma", ["report", "pharma", "--no-pdf"])
