"""`snapo bench pharma`: the 20 CQA/CPP sensitivities from 5 reverse passes against 4 forward
tangents, per tolerance, each timed (median after compile) and compared with a tight reference."""

import pathlib

import jax
import numpy as np

from snapo_ode import Column, agreement, call_checked, format_table, time_function, write_table

from ._chain import CHAIN_SOLVER, PharmaChain
from ._cqa import cqa_vector
from ._process import make_cpps
from ._sensitivities import jacobian_function
from ._study import REFERENCE

GOAL_SECONDS = 0.015
GOAL_ERROR = 1e-4
PAPER_SECONDS = 0.0745
COLUMNS = (
    Column("rtol (atol = rtol/100)", "rtol", "g"), Column("mode", "mode"), Column("passes", "passes"),
    Column("median ms", "seconds_median", lambda v: f"{1e3 * v:.2f}"), Column("compile s", "compile_seconds", ".1f"),
    Column("CQAs alone ms", "forward_pass_seconds", lambda v: f"{1e3 * v:.2f}"),
    Column("ratio", "ratio_to_forward_pass", ".2f"), Column("relative error vs reference", "rel_error_vs_reference", ".1e"),
    Column(f"goal (<= {1e3 * GOAL_SECONDS:.0f} ms at <= {GOAL_ERROR:g})", "meets_goal", lambda v: "yes" if v else "no"),
)


def run_pharma_benchmark(out: pathlib.Path, *, rtols, repeats: int) -> int:
    """Print the table and write `bench_pharma.csv` and `bench_pharma.json` under `out`."""
    cpps = make_cpps()
    base = PharmaChain()
    inputs = base.inputs(cpps)
    _, reference = jacobian_function(base.with_solver(REFERENCE), False, "reverse")(inputs)
    reference = np.asarray(reference)
    rows = []
    for rtol in rtols:
        chain = base.with_solver(CHAIN_SOLVER.replace(rtol=rtol, atol=rtol / 100))
        cqas = jax.jit(lambda inputs, chain=chain: cqa_vector(chain.simulate(inputs)))
        value_timing, _ = time_function(lambda inputs: call_checked(cqas, inputs, what="the chain"), inputs,
                                        repeats=repeats)
        for mode in ("reverse", "forward"):
            timing, (_, matrix) = time_function(jacobian_function(chain, False, mode), inputs, repeats=repeats)
            error = agreement(np.asarray(matrix), reference).max_rel_diff
            ratio = timing.median_seconds / value_timing.median_seconds
            rows.append({"rtol": rtol, "atol": rtol / 100, "mode": mode,
                         "passes": 5 if mode == "reverse" else 4,
                         "seconds_median": timing.median_seconds, "compile_seconds": timing.compile_seconds,
                         "forward_pass_seconds": value_timing.median_seconds,
                         "ratio_to_forward_pass": ratio, "gradient_forward_ratio": ratio,
                         "rel_error_vs_reference": error,
                         "meets_goal": bool(timing.median_seconds <= GOAL_SECONDS and error <= GOAL_ERROR)})
    print(f"20 dCQA/dCPP sensitivities of the 4-unit chain (reference: rtol {REFERENCE.rtol:g}); "
          f"goal <= {1e3 * GOAL_SECONDS:.0f} ms at <= {GOAL_ERROR:g}; paper {1e3 * PAPER_SECONDS:.1f} ms")
    print(format_table(rows, COLUMNS))
    accurate = [row for row in rows if row["rel_error_vs_reference"] <= GOAL_ERROR]
    if accurate:
        best = min(accurate, key=lambda row: row["seconds_median"])
        print(f"fastest at <= {GOAL_ERROR:g}: {best['mode']} mode at rtol {best['rtol']:g}, "
              f"{1e3 * best['seconds_median']:.2f} ms ({PAPER_SECONDS / best['seconds_median']:.1f}x faster than the paper)")
    paths = write_table(out, "bench_pharma", rows, {"goal_seconds": GOAL_SECONDS, "goal_error": GOAL_ERROR,
                                                    "paper_seconds": PAPER_SECONDS,
                                                    "reference_solver": REFERENCE.as_dict()})
    print(f"written: {', '.join(map(str, paths))}")
    return 0
