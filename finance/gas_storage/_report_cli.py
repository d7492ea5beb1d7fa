"""`snapo report gas`: the storage report's verb (kept apart from `_cli` so the study's verbs and
the report change independently). Heavy imports happen inside the handler."""

import datetime

from snapo_ode.cli import add_training_options

from ._cli import add_lsmc_arguments, add_study_arguments

SAMPLE_START_DATES = {"bdj": datetime.date(2005, 7, 1)}  # Boogert & de Jong's contract starts on 1 Jul 2005


def _start_date(args) -> datetime.date | None:
    from snapo_ode import InputError

    if args.start_date is None:
        return SAMPLE_START_DATES.get(args.sample) if args.curve is None else None
    try:
        return datetime.date.fromisoformat(args.start_date)
    except ValueError:
        raise InputError(f"--start-date = {args.start_date!r} is not a date; give YYYY-MM-DD.") from None


def run_report(args) -> int:
    from snapo_ode import InputError
    from snapo_ode.cli import publish_report

    from ._cli import study_from_args
    from ._report import build_gas_report, gas_report, report_provenance

    start = _start_date(args)
    inputs, settings = study_from_args(args)
    if args.lsmc and not settings.stochastic:
        raise InputError("--lsmc needs --stochastic (LSMC values the optionality on simulated spot paths).")
    data = build_gas_report(inputs, settings, lsmc=args.lsmc, nodes=args.lsmc_nodes, degree=args.lsmc_degree,
                            foresight_paths=args.foresight_paths, start=start)
    return publish_report(args, gas_report(data, report_provenance(inputs, settings, args.command_line)))


def register_gas_report(cli) -> None:
    """Add `snapo report gas`."""
    report = cli.report("gas", "the storage report: value (hard, smooth, intrinsic LP; with --lsmc also LSMC, "
                        "perfect foresight and the dual bound where available), the monthly delta ladder, the "
                        "schedule and the facility sensitivities")
    add_study_arguments(report)
    add_training_options(report)
    add_lsmc_arguments(report)
    report.add_argument("--start-date", metavar="YYYY-MM-DD", help="the calendar date of day 0, for the monthly ladder "
                        "(default: the sample's own, 1 Jul 2005 for bdj; else months of a non-leap year from day 0)")
    report.set_defaults(handler=run_report)
