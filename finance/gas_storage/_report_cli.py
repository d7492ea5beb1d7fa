"""`snapo report gas`: the storage report's verb (kept apart from `_cli` so the study's verbs and
the report change independently). Heavy imports happen inside the handler."""

import datetime
import re

from snapo_ode.cli import add_training_options

from ._cli import add_lsmc_arguments, add_study_arguments

# Boogert & de Jong's contract starts on 1 Jul 2005; the built-in sample's curve on 1 April (its
# year is not given: 2025, a year whose April-to-March has 365 days, as the curve).
SAMPLE_START_DATES = {"bdj": (datetime.date(2005, 7, 1), "Boogert and de Jong's contract start"),
                      "sample": (datetime.date(2025, 4, 1), "the built-in sample starts on 1 April; the year is "
                                                            "illustrative")}
CODE = re.compile(r"[A-Za-z][A-Za-z0-9$/.]{0,11}")  # a currency or energy unit as the report shows it


def _start_date(args) -> tuple[datetime.date | None, str | None]:
    """The contract's start and where it came from."""
    from snapo_ode import InputError

    if args.start_date is None:
        return SAMPLE_START_DATES.get(args.sample, (None, None)) if args.curve is None else (None, None)
    try:
        return datetime.date.fromisoformat(args.start_date), "given with --start-date"
    except ValueError:
        raise InputError(f"--start-date = {args.start_date!r} is not a date; give YYYY-MM-DD.") from None


def _unit(args, name: str) -> str:
    from snapo_ode import InputError

    text = getattr(args, name.replace("-", "_"))
    if CODE.fullmatch(text) is None:
        raise InputError(f"--{name} = {text!r} is not a unit: give 1 to 12 letters, digits or $/. starting with a "
                         "letter (USD, EUR, MWh, GJ).")
    return text


def run_report(args) -> int:
    from snapo_ode import InputError
    from snapo_ode.cli import publish_report

    from ._cli import ONE_FACTOR_DEGREE, ONE_FACTOR_NODES, study_from_args
    from ._report import build_gas_report, gas_report, report_provenance

    for flag, given in (("--price-model", args.price_model), ("--train-paths-file", args.train_paths_file),
                        ("--value-paths-file", args.value_paths_file)):
        if given is not None:
            raise InputError(f"{flag} {given}: the storage report is on the built-in one-factor model only; value "
                             f"on a price model or the desk's paths with `snapo gas {flag} ...` (its JSON has every "
                             "method, the bound and the deltas).")
    start, start_source = _start_date(args)
    currency, energy_unit = _unit(args, "currency"), _unit(args, "energy-unit")
    inputs, settings = study_from_args(args)
    if args.lsmc and not settings.stochastic:
        raise InputError("--lsmc needs --stochastic (LSMC values the optionality on simulated spot paths).")
    data = build_gas_report(inputs, settings, lsmc=args.lsmc, nodes=args.lsmc_nodes or ONE_FACTOR_NODES,
                            degree=args.lsmc_degree or ONE_FACTOR_DEGREE, foresight_paths=args.foresight_paths, start=start,
                            start_source=start_source, currency=currency, energy_unit=energy_unit)
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
                        "(default: the sample's own, 1 Jul 2005 for bdj, 1 Apr 2025 for the sample; else months of a "
                        "non-leap year from day 0, named month 1, 2, ...)")
    report.add_argument("--currency", default="USD", help="the curve's currency, as the report names it (default USD)")
    report.add_argument("--energy-unit", default="MMBtu",
                        help="the curve's and the facility's energy unit, as the report names it (default MMBtu)")
    report.set_defaults(handler=run_report)
