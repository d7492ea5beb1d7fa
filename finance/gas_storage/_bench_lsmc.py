"""`snapo bench gas-lsmc`: SNAPO against LSMC on the Boogert & de Jong (2008) contract, both
volatilities, the same fresh paths, in one run."""

import pathlib

from ._bench import write_tables
from ._cases import BDJ_MEAN_REVERSION, BDJ_PUBLISHED, BDJ_VOLATILITY, CASES
from ._inputs import make_inputs
from ._study import StudySettings
from ._versus_lsmc import compare_with_lsmc


def run_lsmc_benchmark(out: pathlib.Path, *, paths: int, train_paths: int, train_steps: int,
                       foresight_paths: int, nodes: int, degree: int, seed: int = 0) -> list[dict]:
    """For B&dJ's low and high volatility: train SNAPO, value by LSMC with `paths` fitting paths,
    and evaluate both (and perfect foresight on `foresight_paths`) on the same `paths` fresh
    paths; print the side-by-side table and write `bench_gas_lsmc.csv` / `.json` under `out`."""
    facility, curve = CASES["bdj"]()
    rows, results = [], {}
    for level, volatility in BDJ_VOLATILITY.items():
        inputs = make_inputs(facility, curve, volatility=volatility, mean_reversion=BDJ_MEAN_REVERSION)
        settings = StudySettings(stochastic=True, paths=paths, train_paths=train_paths, train_steps=train_steps,
                                 seed=seed, repeats=3)
        result, _ = compare_with_lsmc(inputs, settings, nodes=nodes, degree=degree, foresight_paths=foresight_paths)
        results[level] = {key: value for key, value in result.items() if key not in ("schedule", "deltas",
                                                                                        "lp_envelope_deltas")}
        rows.append({
            "volatility": f"{level} ({volatility / 365 ** 0.5:.2%}/sqrt(day))",
            "intrinsic_lp": result["intrinsic_lp"],
            "published_lsmc": BDJ_PUBLISHED[f"lsmc_{level}"],
            "lsmc_in_sample": result["lsmc_in_sample"],
            "lsmc_out_of_sample": result["lsmc_out_of_sample"],
            "lsmc_se": result["lsmc_se"],
            "snapo_out_of_sample": result["snapo_out_of_sample"],
            "snapo_se": result["snapo_se"],
            "snapo_minus_lsmc": result["snapo_minus_lsmc"],
            "snapo_minus_lsmc_se": result["snapo_minus_lsmc_se"],
            "perfect_foresight": result["perfect_foresight"],
            "perfect_foresight_se": result["perfect_foresight_se"],
            "lsmc_fit_seconds": result["lsmc_fit_seconds"],
            "lsmc_eval_seconds": result["lsmc_eval_seconds"],
            "snapo_train_seconds": result["train_seconds"],
            "snapo_deltas_seconds": result["gradient_seconds"],
            "snapo_seconds": result["snapo_seconds"],
            "snapo_compile_seconds": result["compile_seconds"],
            "lsmc_compile_seconds": result["lsmc_compile_seconds"],
        })
    million = lambda x: f"{x / 1e6:.3f}"  # noqa: E731
    print(f"\nB&dJ (2008) storage, {paths:,} fresh evaluation paths (LSMC fitted on {paths:,} others; "
          f"SNAPO trained {train_steps} steps x {train_paths} paths), EUR million, +- one standard error")
    print("volatility | intrinsic LP | LSMC published | LSMC in sample | LSMC out of sample | SNAPO out of sample | "
          "SNAPO - LSMC (paired) | perfect foresight | LSMC valuation s | SNAPO train + 365 deltas s")
    for row in rows:
        print(f"{row['volatility']} | {million(row['intrinsic_lp'])} | {million(row['published_lsmc'])} | "
              f"{million(row['lsmc_in_sample'])} | {million(row['lsmc_out_of_sample'])} +- {million(row['lsmc_se'])} | "
              f"{million(row['snapo_out_of_sample'])} +- {million(row['snapo_se'])} | "
              f"{million(row['snapo_minus_lsmc'])} +- {million(row['snapo_minus_lsmc_se'])} | "
              f"{million(row['perfect_foresight'])} +- {million(row['perfect_foresight_se'])} | "
              f"{row['lsmc_fit_seconds']:.2f} | {row['snapo_train_seconds']:.1f} + {row['snapo_deltas_seconds']:.2f}")
    write_tables(out, "bench_gas_lsmc", rows, {"rows": rows, "results": results, "nodes": nodes, "degree": degree})
    return rows
