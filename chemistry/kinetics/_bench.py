"""`snapo bench kinetics`: constant-volume adiabatic ignition at equal tolerance, from the start to
the case's sensitivity time (late in the induction: h2o2 0.27 ms, gri30 1.0 ms, where
`snapo kinetics check` compares the sensitivities with Cantera's): our forward solves (Rodas5,
the reactors' default, and the BDF of `REACTOR_BDF_SOLVER`), our gradient of T there with
respect to every reaction's A-factor (one reverse pass, through each), Cantera's integration
and Cantera's integration with forward sensitivities to every reaction switched on; and each
solver's error in T against a converged reference (Rodas5 at rtol 1e-13), so that a speed is
read with the accuracy it bought.

Rodas5 (Rosenbrock: one closed-form Jacobian and one LU a step) at the same rtol 1e-10 / atol
1e-14, with a checkpoint at every step for the reverse pass. Kvaerno5 (ESDIRK, a Newton iteration
per stage) was the slower forward and its reverse pass failed on gri30 (the root finder's implicit
derivative on a rejected step); docs/chemistry.md has those figures (Speed against Cantera, and
Measurements behind the design)."""

import pathlib
import statistics
import time

import equinox as eqx
import jax
import jax.numpy as jnp

from snapo_ode import Column, call_checked, format_table, time_function, write_table

from ._batch_bench import benchmark_batch, benchmark_scaling, device
from ._ignition import IGNITION_CASES, initial_concentrations
from ._mechanism import Mechanism
from ._reactor import REACTOR_BDF_SOLVER, REACTOR_SOLVER
from ._sensitivities import final_temperature

RTOL, ATOL = 1e-10, 1e-14
"""The tolerances of both solvers (ours on [T/T0, N_k/N0]; Cantera's on [m, V, T, Y_k])."""
SENSITIVITY_TOLERANCE = 1e-6
"""Cantera's sensitivity rtol and atol: where its h2o2 sensitivities agree with its own bumps."""
MAX_STEPS = 4000
"""Per solve, well above what gri30 takes at these tolerances (docs/dev/chemistry_notes.md, Measurements
behind the design); also the reverse pass's checkpoints."""
REFERENCE_RTOL = 1e-13
"""The converged reference's rtol (Rodas5, atol = rtol x 1e-4): h2o2's T barely moves from
rtol 1e-12 to 1e-13 (docs/dev/chemistry_notes.md, Measurements behind the design)."""
CANTERA_SENSITIVITY_REPEATS = {"h2o2": 3, "gri30": 1}  # gri30 with 325 sensitivities: seconds a run


def cantera_seconds(path, case, end_time: float, sensitivities: bool, repeats: int, *, rtol: float = RTOL,
                    atol: float = ATOL) -> tuple[float, float]:
    """Median wall time [s] of Cantera's run to `end_time` [s] at `rtol`, `atol` (on [m, V, T,
    Y_k]), and T there [K]."""
    import cantera

    runs = []
    for _ in range(repeats):
        solution = cantera.Solution(str(path))
        solution.TPX = case.temperature, case.pressure, case.composition
        start = time.perf_counter()
        reactor = cantera.IdealGasReactor(solution, clone=False)
        net = cantera.ReactorNet([reactor])
        net.rtol, net.atol, net.max_steps = rtol, atol, 200_000
        if sensitivities:
            for i in range(solution.n_reactions):
                reactor.add_sensitivity_reaction(i)
            net.rtol_sensitivity = net.atol_sensitivity = SENSITIVITY_TOLERANCE
        net.advance(end_time)
        runs.append(time.perf_counter() - start)
    return statistics.median(runs), reactor.phase.T


def benchmark_mechanism(name: str, repeats: int, batch: int | None = None, scaling=()) -> tuple[dict, list[dict]]:
    """One row of the benchmark for built-in case `name` ("h2o2" or "gri30"); with `batch`, also
    the fields of `benchmark_batch` (that many reactors solved as one batch, and Cantera serially).
    And the rows of `benchmark_scaling` for the batch sizes `scaling` (none if empty)."""
    import cantera

    path = pathlib.Path(cantera.__file__).parent / "data" / f"{name}.yaml"
    case = IGNITION_CASES[name]
    mechanism = Mechanism.from_yaml(path)
    concentrations = jnp.asarray(initial_concentrations(path, case))
    settings = REACTOR_SOLVER.replace(rtol=RTOL, atol=ATOL, max_steps=MAX_STEPS)
    zero = jnp.zeros(mechanism.n_reactions)

    end_time = case.sensitivity_time

    def objective(log_multiplier):
        return final_temperature(log_multiplier, mechanism, concentrations, case, end_time, settings)

    def checked(fn):
        return lambda x: call_checked(fn, x, what=f"the {name} ignition")

    def bdf_objective(log_multiplier):
        return final_temperature(log_multiplier, mechanism, concentrations, case, end_time, bdf_settings)

    forward, temperature = time_function(checked(eqx.filter_jit(objective)), zero, repeats=repeats)
    bdf_settings = REACTOR_BDF_SOLVER.replace(rtol=RTOL, atol=ATOL, max_steps=MAX_STEPS)
    forward_bdf, bdf_temperature = time_function(checked(eqx.filter_jit(bdf_objective)), zero, repeats=repeats)
    gradient_bdf, (_, bdf_gradient) = time_function(checked(eqx.filter_jit(jax.value_and_grad(bdf_objective))), zero,
                                                    repeats=repeats)
    reference_settings = REACTOR_SOLVER.replace(rtol=REFERENCE_RTOL, atol=REFERENCE_RTOL * 1e-4, max_steps=50_000)
    reference = float(call_checked(eqx.filter_jit(final_temperature), zero, mechanism, concentrations, case, end_time,
                                   reference_settings, what=f"the {name} reference"))
    gradient, (_, rodas5_gradient) = time_function(checked(eqx.filter_jit(jax.value_and_grad(objective))), zero,
                                                   repeats=repeats)
    cantera_forward, cantera_temperature = cantera_seconds(path, case, end_time, False, repeats)
    cantera_sensitivity, _ = cantera_seconds(path, case, end_time, True,
                                              CANTERA_SENSITIVITY_REPEATS[name])
    row = {
        "mechanism": name, "parameters": mechanism.n_reactions, "end_time_s": end_time,
        "device": device(),
        "rtol": RTOL, "atol": ATOL, "cantera_sensitivity_tolerance": SENSITIVITY_TOLERANCE,
        "forward_s": forward.median_seconds, "forward_compile_s": forward.compile_seconds,
        "gradient_s": gradient.median_seconds, "gradient_compile_s": gradient.compile_seconds,
        "cantera_forward_s": cantera_forward, "cantera_sensitivities_s": cantera_sensitivity,
        "cantera_sensitivity_runs": CANTERA_SENSITIVITY_REPEATS[name],
        "gradient_speedup_vs_cantera_sensitivities": cantera_sensitivity / gradient.median_seconds,
        "final_temperature_K": float(temperature), "cantera_final_temperature_K": cantera_temperature,
        "forward_bdf_s": forward_bdf.median_seconds, "forward_bdf_compile_s": forward_bdf.compile_seconds,
        "bdf_final_temperature_K": float(bdf_temperature), "reference_final_temperature_K": reference,
        "reference_rtol": REFERENCE_RTOL,
        "gradient_bdf_s": gradient_bdf.median_seconds, "gradient_bdf_compile_s": gradient_bdf.compile_seconds,
        "gradient_bdf_speedup_vs_cantera_sensitivities": cantera_sensitivity / gradient_bdf.median_seconds,
        "gradient_bdf_vs_rodas5_max_relative_difference": float(
            jnp.max(jnp.abs(bdf_gradient - rodas5_gradient)) / jnp.max(jnp.abs(rodas5_gradient))),
        "gradient_forward_ratio": gradient.median_seconds / forward.median_seconds,
        "gradient_bdf_forward_ratio": gradient_bdf.median_seconds / forward_bdf.median_seconds,
        "forward_slowdown_vs_cantera": forward.median_seconds / cantera_forward,
        "forward_bdf_slowdown_vs_cantera": forward_bdf.median_seconds / cantera_forward,
        **{f"{who}_temperature_rel_error": abs(value - reference) / reference
           for who, value in (("rodas5", float(temperature)), ("bdf", float(bdf_temperature)),
                              ("cantera", cantera_temperature))},
    }
    if batch is not None:
        row.update(benchmark_batch(name, path, mechanism, case, batch, end_time, settings, repeats))
    return row, benchmark_scaling(name, path, mechanism, case, scaling, end_time, settings, repeats)


COLUMNS = (
    Column("mechanism", "mechanism"), Column("parameters", "parameters"),
    Column("to ms", "end_time_s", lambda v: f"{1e3 * v:g}"), Column("our forward s (Rodas5)", "forward_s", ".4f"),
    Column("our forward s (BDF)", "forward_bdf_s", ".4f"), Column("Cantera s", "cantera_forward_s", ".4f"),
    Column("Rodas5 / Cantera", "forward_slowdown_vs_cantera", lambda v: f"{v:.1f}x"),
    Column("BDF / Cantera", "forward_bdf_slowdown_vs_cantera", lambda v: f"{v:.1f}x"),
    Column("T error Rodas5", "rodas5_temperature_rel_error", ".1e"), Column("T error BDF", "bdf_temperature_rel_error", ".1e"),
    Column("T error Cantera", "cantera_temperature_rel_error", ".1e"),
    Column("our gradient s (Rodas5; all A, one reverse pass)", "gradient_s", ".3f"),
    Column("our gradient s (BDF)", "gradient_bdf_s", ".4f"),
    Column("gradient / forward (Rodas5)", "gradient_forward_ratio", ".1f"),
    Column("gradient / forward (BDF)", "gradient_bdf_forward_ratio", ".1f"),
    Column("Cantera + forward sensitivities s", "cantera_sensitivities_s", ".2f"),
    Column("Rodas5 gradient vs Cantera's sensitivities", "gradient_speedup_vs_cantera_sensitivities",
           lambda v: f"{v:.1f}x"),
    Column("BDF gradient vs Cantera's sensitivities", "gradient_bdf_speedup_vs_cantera_sensitivities",
           lambda v: f"{v:.1f}x"),
    Column("BDF gradient vs Rodas5's", "gradient_bdf_vs_rodas5_max_relative_difference", ".1e"),
    Column("compile s (forward)", "forward_compile_s", ".0f"), Column("compile s (BDF)", "forward_bdf_compile_s", ".0f"),
    Column("compile s (gradient)", "gradient_compile_s", ".0f"),
    Column("compile s (BDF gradient)", "gradient_bdf_compile_s", ".0f"),
)


BATCH_COLUMNS = (
    Column("mechanism", "mechanism"), Column("reactors", "batch"), Column("our device", "device"),
    Column("our batch forward ms/reactor", "batch_forward_s_per_reactor", lambda v: f"{1e3 * v:.1f}"),
    Column("the same in sorted groups", "batch_forward_grouped_s_per_reactor", lambda v: f"{1e3 * v:.1f}"),
    Column("our gradient ms/reactor (vmapped sample)", "batch_gradient_s_per_reactor", lambda v: f"{1e3 * v:.1f}"),
    Column("Cantera serial ms/reactor", "cantera_serial_s_per_reactor", lambda v: f"{1e3 * v:.1f}"),
    Column("forward vs Cantera", "batch_forward_speedup_vs_cantera_serial", lambda v: f"{v:.2f}x"),
    Column("batch vs single solves", "batch_max_relative_difference_vs_single", ".1e"),
    Column("gradient vs bumps", "batch_gradient_max_relative_difference_vs_bumps", ".1e"),
    Column("gradient vs Cantera forward", "batch_gradient_speedup_vs_cantera_serial_forward", lambda v: f"{v:.2f}x"),
    Column("compile s (forward)", "batch_forward_compile_s", ".0f"),
    Column("compile s (gradient)", "batch_gradient_compile_s", ".0f"),
)


SCALING_COLUMNS = (
    Column("mechanism", "mechanism"), Column("reactors", "batch"), Column("our device", "device"),
    Column("our batch forward ms/reactor", "batch_forward_s_per_reactor", lambda v: f"{1e3 * v:.2f}"),
    Column("Cantera serial ms/reactor", "cantera_serial_s_per_reactor", lambda v: f"{1e3 * v:.2f}"),
    Column("forward vs Cantera", "batch_forward_speedup_vs_cantera_serial", lambda v: f"{v:.2f}x"),
    Column("T vs Cantera", "batch_max_relative_difference_vs_cantera", ".1e"),
    Column("compile s", "batch_forward_compile_s", ".0f"),
)


def run_kinetics_benchmark(out: pathlib.Path, *, mechanisms=("h2o2", "gri30"), repeats: int = 5,
                           batch: int | None = None, scaling=()) -> list[dict]:
    """Print the table and write `bench_kinetics.json` and `bench_kinetics.csv` under `out`; with
    `batch`, a second table of the batched solves (the same rows carry its fields); with batch
    sizes `scaling`, a third table, written as `bench_kinetics_scaling.{csv,json}`."""
    results = [benchmark_mechanism(name, repeats, batch, scaling) for name in mechanisms]
    rows = [row for row, _ in results]
    scaling_rows = [row for _, rows_of_one in results for row in rows_of_one]
    print(f"constant-volume adiabatic ignition to late induction, rtol {RTOL:g} / atol {ATOL:g} (Cantera's "
          f"sensitivities {SENSITIVITY_TOLERANCE:g}); medians after compile")
    print(format_table(rows, COLUMNS))
    if batch is not None:
        print(f"{batch} reactors (T0 and P0 spread, see chemistry.kinetics._batch_bench), our forward solves as one batch, "
              f"our gradients vmapped over a sample of them, Cantera serially; per reactor, medians of "
              f"{rows[0]['batch_repeats']} run(s) after an ahead-of-time compile")
        print(format_table(rows, BATCH_COLUMNS))
    if scaling_rows:
        print(f"our forward solves as one vmap of N reactors, Cantera serially on the same N; per reactor, medians "
              f"of {scaling_rows[0]['batch_repeats']} run(s) after an ahead-of-time compile (Cantera: one run)")
        print(format_table(scaling_rows, SCALING_COLUMNS))
    paths = write_table(out, "bench_kinetics", rows)
    if scaling_rows:
        paths += write_table(out, "bench_kinetics_scaling", scaling_rows)
    print(f"  written: {', '.join(map(str, paths))}")
    return rows
