"""`snapo bench kinetics`: constant-volume adiabatic ignition over the whole case (h2o2 to 1 ms,
gri30 to 5 ms) at equal tolerance: our forward solve, our gradient of T(end) with respect to every
reaction's A-factor (one reverse pass), Cantera's integration and Cantera's integration with
forward sensitivities to every reaction switched on."""

import pathlib
import statistics
import time

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np

from snapo_ode import atomic_write_json, atomic_write_text, time_function

from ._ignition import IGNITION_CASES, initial_concentrations
from ._mechanism import Mechanism
from ._reactor import SolverSettings
from ._sensitivities import final_temperature

RTOL, ATOL = 1e-8, 1e-11
"""The tolerances of both solvers (ours on [T/T0, N_k/N0]; Cantera's on [m, V, T, Y_k])."""
SENSITIVITY_TOLERANCE = 1e-6
"""Cantera's sensitivity rtol and atol: where its h2o2 sensitivities agree with its own bumps."""
CANTERA_SENSITIVITY_REPEATS = {"h2o2": 3, "gri30": 1}  # gri30 with 325 sensitivities: ~30 s a run


def _cantera_seconds(path, case, sensitivities: bool, repeats: int) -> tuple[float, float]:
    """Median wall time [s] of Cantera's run to the end time, and T(end) [K]."""
    import cantera

    runs = []
    for _ in range(repeats):
        solution = cantera.Solution(str(path))
        solution.TPX = case.temperature, case.pressure, case.composition
        start = time.perf_counter()
        reactor = cantera.IdealGasReactor(solution, clone=False)
        net = cantera.ReactorNet([reactor])
        net.rtol, net.atol, net.max_steps = RTOL, ATOL, 200_000
        if sensitivities:
            for i in range(solution.n_reactions):
                reactor.add_sensitivity_reaction(i)
            net.rtol_sensitivity = net.atol_sensitivity = SENSITIVITY_TOLERANCE
        net.advance(case.end_time)
        runs.append(time.perf_counter() - start)
    return statistics.median(runs), reactor.phase.T


def benchmark_mechanism(name: str, repeats: int) -> dict:
    """One row of the benchmark for built-in case `name` ("h2o2" or "gri30")."""
    import cantera

    path = pathlib.Path(cantera.__file__).parent / "data" / f"{name}.yaml"
    case = IGNITION_CASES[name]
    mechanism = Mechanism.from_yaml(path)
    concentrations = jnp.asarray(initial_concentrations(path, case))
    settings = SolverSettings(rtol=RTOL, atol=ATOL, max_steps=50_000)
    zero = jnp.zeros(mechanism.n_reactions)

    def objective(log_multiplier):
        return final_temperature(log_multiplier, mechanism, concentrations, case, case.end_time, settings)

    forward, temperature = time_function(eqx.filter_jit(objective), zero, repeats=repeats)
    gradient, (_, grad) = time_function(eqx.filter_jit(jax.value_and_grad(objective)), zero, repeats=repeats)
    cantera_forward, cantera_temperature = _cantera_seconds(path, case, False, repeats)
    cantera_sensitivity, _ = _cantera_seconds(path, case, True, CANTERA_SENSITIVITY_REPEATS[name])
    return {
        "mechanism": name, "parameters": mechanism.n_reactions, "end_time_s": case.end_time,
        "rtol": RTOL, "atol": ATOL, "cantera_sensitivity_tolerance": SENSITIVITY_TOLERANCE,
        "forward_s": forward.median_seconds, "forward_compile_s": forward.compile_seconds,
        "gradient_s": gradient.median_seconds, "gradient_compile_s": gradient.compile_seconds,
        "cantera_forward_s": cantera_forward, "cantera_sensitivities_s": cantera_sensitivity,
        "cantera_sensitivity_runs": CANTERA_SENSITIVITY_REPEATS[name],
        "gradient_speedup_vs_cantera_sensitivities": cantera_sensitivity / gradient.median_seconds,
        "final_temperature_K": float(temperature), "cantera_final_temperature_K": cantera_temperature,
        "gradient_finite": bool(np.all(np.isfinite(np.asarray(grad)))),
    }


COLUMNS = ("mechanism", "parameters", "forward_s", "forward_compile_s", "gradient_s", "gradient_compile_s",
           "cantera_forward_s", "cantera_sensitivities_s", "gradient_speedup_vs_cantera_sensitivities")


def run_kinetics_benchmark(out: pathlib.Path, *, mechanisms=("h2o2", "gri30"), repeats: int = 5) -> list[dict]:
    """Print the table and write `bench_kinetics.json` and `bench_kinetics.csv` under `out`."""
    rows = [benchmark_mechanism(name, repeats) for name in mechanisms]
    print(f"constant-volume adiabatic ignition, rtol {RTOL:g} / atol {ATOL:g} (Cantera's sensitivities "
          f"{SENSITIVITY_TOLERANCE:g}); medians after compile")
    print("mechanism | parameters | forward s | gradient s (all A) | Cantera s | Cantera + sensitivities s | "
          "speed-up | compile s (fwd / grad)")
    for row in rows:
        print(f"{row['mechanism']} | {row['parameters']} | {row['forward_s']:.3f} | {row['gradient_s']:.3f} | "
              f"{row['cantera_forward_s']:.3f} | {row['cantera_sensitivities_s']:.2f} | "
              f"{row['gradient_speedup_vs_cantera_sensitivities']:.1f}x | {row['forward_compile_s']:.0f} / "
              f"{row['gradient_compile_s']:.0f}")
    atomic_write_json(out / "bench_kinetics.json", {"rows": rows})
    csv = [",".join(COLUMNS)] + [",".join(str(row[c]) for c in COLUMNS) for row in rows]
    atomic_write_text(out / "bench_kinetics.csv", "\n".join(csv) + "\n")
    print(f"  written: {out / 'bench_kinetics.json'}, {out / 'bench_kinetics.csv'}")
    return rows
