"""`snapo bench gas-lsmc`: SNAPO against LSMC on the Boogert & de Jong (2008) contract, both
volatilities, the same fresh paths, in one run."""

import pathlib

from snapo_ode import Column, format_table, write_table

from ._cases import BDJ_MEAN_REVERSION, BDJ_PUBLISHED, BDJ_VOLATILITY, CASES
from ._inputs import make_inputs
from ._study import StudySettings
from ._versus_lsmc import compare_with_lsmc


def _million(value: float) -> str:
    return f"{value / 1e6:.3f}"


COLUMNS = (
    Column("volatility", "volatility"), Column("intrinsic LP", "intrinsic_lp", _million),
    Column("LSMC published", "published_lsmc", _million), Column("LSMC in sample", "lsmc_in_sample", _million),
    Column("LSMC out of sample", "lsmc_out_of_sample", _million), Column("+-", "lsmc_se", _million),
    Column("SNAPO out of sample", "snapo_out_of_sample", _million), Column("+-", "snapo_se", _million),
    Column("SNAPO - LSMC (paired)", "snapo_minus_lsmc", _million), Column("+-", "snapo_minus_lsmc_se", _million),
    Column("perfect foresight", "perfect_foresight", _million), Column("+-", "perfect_foresight_se", _million),
    Column("dual bound", "dual_upper_bound", _million), Column("+-", "dual_upper_bound_se", _million),
    Column("SNAPO gap", "snapo_gap", lambda v: f"{100 * v:.3f}%"), Column("LSMC gap", "lsmc_gap", lambda v: f"{100 * v:.3f}%"),
    Column("lattice rule", "lattice_out_of_sample", _million),
    Column("SNAPO training + 365 deltas s", "snapo_seconds", ".1f"), Column("LSMC valuation s", "lsmc_fit_seconds", ".2f"),
    Column("LSMC + pathwise deltas s", "lsmc_plus_deltas_seconds", ".1f"),
    Column("LSMC + 730 bumps (est.) min", "lsmc_plus_bumps_seconds", lambda v: f"{v / 60:.0f}"),
    Column("deltas SNAPO vs LSMC", "deltas_snapo_vs_lsmc", ".1%"),
)


def run_lsmc_benchmark(out: pathlib.Path, *, paths: int, train_paths: int | None, train_steps: int | None,
                       foresight_paths: int, nodes: int, degree: int, seed: int = 0,
                       head: str = "basestock", progress: bool = True) -> list[dict]:
    """For B&dJ's low and high volatility: train SNAPO (`head`; `train_paths`, `train_steps` None:
    the head's defaults), value by LSMC with `paths` fitting paths,
    and evaluate both (and perfect foresight on `foresight_paths`) on the same `paths` fresh
    paths (`progress`: show the training's progress bar); print the side-by-side table and write
    `bench_gas_lsmc.csv` / `.json` under `out`."""
    facility, curve = CASES["bdj"]()
    rows, results = [], {}
    for level, volatility in BDJ_VOLATILITY.items():
        inputs = make_inputs(facility, curve, volatility=volatility, mean_reversion=BDJ_MEAN_REVERSION)
        settings = StudySettings(stochastic=True, paths=paths, head=head, train_paths=train_paths,
                                 train_steps=train_steps, seed=seed, repeats=3, progress=progress)
        comparison = compare_with_lsmc(inputs, settings, nodes=nodes, degree=degree, foresight_paths=foresight_paths)
        results[level] = {key: value for key, value in comparison.to_json().items()
                          if key not in ("schedule", "deltas", "lp_envelope_deltas")}
        study = comparison.study
        rows.append({
            "volatility": f"{level} ({volatility / 365 ** 0.5:.2%}/sqrt(day))",
            "intrinsic_lp": study.intrinsic_lp, "published_lsmc": BDJ_PUBLISHED[f"lsmc_{level}"],
            **{key: getattr(comparison, key) for key in (
                "lsmc_in_sample", "lsmc_out_of_sample", "lsmc_se", "snapo_out_of_sample", "snapo_se",
                "snapo_minus_lsmc", "snapo_minus_lsmc_se", "perfect_foresight", "perfect_foresight_se",
                "dual_upper_bound", "dual_upper_bound_se", "snapo_gap", "snapo_gap_se", "lsmc_gap", "lsmc_gap_se",
                "lattice_out_of_sample", "lattice_gap", "dual_seconds", "lsmc_fit_seconds", "lsmc_eval_seconds",
                "lsmc_deltas_seconds", "lsmc_plus_deltas_seconds", "lsmc_plus_bumps_seconds", "snapo_seconds",
                "lsmc_compile_seconds", "deltas_snapo_vs_lsmc")},
            "snapo_train_seconds": study.train_seconds, "snapo_deltas_seconds": study.gradient_seconds,
            "snapo_compile_seconds": study.compile_seconds,
        })
    print(f"\nB&dJ (2008) storage, {paths:,} fresh evaluation paths (LSMC fitted on {paths:,} others; "
          f"SNAPO's {settings.head} head trained {settings.train_steps} steps x {settings.train_paths} paths), "
          "EUR million, +- one standard error")
    print(format_table(rows, COLUMNS))
    written = write_table(out, "bench_gas_lsmc", rows, {"results": results, "nodes": nodes, "degree": degree})
    print(f"written: {', '.join(map(str, written))}")
    return rows
