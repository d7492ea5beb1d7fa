"""`snapo bench gas-family`: SNAPO, LSMC, the dual bound and the intrinsic LP on every generated
contract of `_family.py`, both volatilities, the same fresh paths, one table; each row says
whether it meets the issue's goals (SNAPO >= LSMC paired, its gap <= 0.5%, training and all
deltas <= 60 s)."""

import pathlib
import time

from snapo_ode import Column, check_choice, format_table, write_table

from ._cases import BDJ_MEAN_REVERSION, BDJ_VOLATILITY
from ._family import family
from ._inputs import make_inputs
from ._study import StudySettings
from ._versus_lsmc import compare_with_lsmc, trading_nodes

GAP_GOAL, SECONDS_GOAL = 0.005, 60.0


def _percent(value) -> str:
    return "null" if value is None else f"{100 * value:.3f}%"


COLUMNS = (
    Column("case", "case"), Column("volatility", "volatility"), Column("intrinsic LP", "intrinsic_lp", ",.0f"),
    Column("LSMC", "lsmc_out_of_sample", ",.0f"), Column("SNAPO", "snapo_out_of_sample", ",.0f"),
    Column("SNAPO - LSMC", "snapo_minus_lsmc", ",.0f"), Column("paired SE", "snapo_minus_lsmc_se", ",.0f"),
    Column("dual bound", "dual_upper_bound", lambda v: "null" if v is None else f"{v:,.0f}"),
    Column("relaxation", "dual_relaxation", ".1%"),
    Column("SNAPO gap", "snapo_gap", _percent), Column("LSMC gap", "lsmc_gap", _percent),
    Column("SNAPO s", "snapo_seconds", ".1f"), Column("goals met", "goals"),
    Column("warnings", "warning_count", "d"),
)


def _goals(comparison) -> str:
    """Which goals a row misses: '>= LSMC' (paired, not below), 'gap' (<= 0.5%), 'time' (<= 60 s)."""
    missed = []
    if comparison.snapo_minus_lsmc < 0:
        missed.append(">= LSMC")
    if comparison.snapo_gap is None or comparison.snapo_gap > GAP_GOAL:
        missed.append("gap")
    if comparison.snapo_seconds > SECONDS_GOAL:
        missed.append("time")
    return "all" if not missed else "missed: " + ", ".join(missed)


def chosen_cases(cases: int | None, names: tuple[str, ...] | None, seed: int) -> list:
    """The first `cases` of the family, or those `names` (in the family's order; each checked)."""
    if not names:
        return family(cases, seed)
    every = family(None, seed)
    for name in names:
        check_choice("--case", name, [case.name for case in every])
    return [case for case in every if case.name in names]


def run_family_benchmark(out: pathlib.Path, *, paths: int, cases: int | None, seed: int, train_steps: int | None,
                         nodes: int, volatilities: tuple[str, ...] = ("low", "high"), progress: bool = True,
                         names: tuple[str, ...] | None = None) -> list[dict]:
    """Value each generated case (`_family.family(cases, seed)`; the cases `names` instead where
    given) at B&dJ's mean reversion and each of `volatilities` (B&dJ's low and high), `paths` fresh paths (LSMC fitted on as many others,
    on `nodes` levels or as many more as a slow facility's daily flow needs);
    print the table and write `bench_gas_family.csv` / `.json` under `out`, after every row (so a
    long run that stops keeps the rows it finished)."""
    chosen = chosen_cases(cases, names, seed)
    rows, results = [], {}
    start = time.perf_counter()
    for case in chosen:
        for level in volatilities:
            inputs = make_inputs(case.facility, case.curve, volatility=BDJ_VOLATILITY[level],
                                 mean_reversion=BDJ_MEAN_REVERSION)
            settings = StudySettings(stochastic=True, paths=paths, seed=seed, train_steps=train_steps, repeats=1,
                                     progress=progress)
            comparison = compare_with_lsmc(inputs, settings, nodes=trading_nodes(inputs, nodes),
                                           foresight_paths=min(16, paths))
            json = comparison.to_json()
            results[f"{case.name}/{level}"] = {key: value for key, value in json.items() if key not in (
                "schedule", "deltas", "lp_envelope_deltas", "lsmc_pathwise_deltas", "lsmc_inventory_mean",
                "training_history", "training_curve", "parameter_sensitivities")}
            rows.append({"case": case.name, "volatility": level, "intrinsic_lp": comparison.study.intrinsic_lp,
                         "goals": _goals(comparison), "warning_count": len(comparison.warnings),
                         **{key: getattr(comparison, key) for key in (
                             "lsmc_out_of_sample", "snapo_out_of_sample", "snapo_minus_lsmc", "snapo_minus_lsmc_se",
                             "dual_upper_bound", "dual_relaxation", "snapo_gap", "lsmc_gap", "snapo_seconds")}})
            written = record_row(out, "bench_gas_family", rows, COLUMNS, {"results": results, "paths": paths,
                                                                            "seed": seed, "nodes": nodes})
    summarise(f"Gas-storage family ({len(rows)} rows, seed {seed}, {paths:,} fresh evaluation paths, "
              f"{time.perf_counter() - start:.0f} s)", rows, COLUMNS, written)
    return rows


def record_row(out, name: str, rows: list[dict], columns, meta: dict) -> list:
    """Print the family's newest row and write every row so far (`write_table` under `out`, with
    `meta` and the count of rows meeting every goal), so that a long run that stops keeps them;
    returns the files written."""
    print(format_table(rows[-1:], columns), flush=True)
    return write_table(out, name, rows, {**meta, "goals_met": sum(row["goals"] == "all" for row in rows)})


def summarise(title: str, rows: list[dict], columns, written) -> None:
    """The family's closing lines: `title`, how many rows met every goal, the table, the files."""
    met = sum(row["goals"] == "all" for row in rows)
    print(f"\n{title}: every goal met in {met} of {len(rows)}")
    print(format_table(rows, columns))
    print(f"written: {', '.join(map(str, written))}")
