"""`snapo bench accuracy`, study "gradients", ignition panel: what accurate d ln T / d ln A cost on
h2o2 ignition (the built-in 1000 K case, at its sensitivity time 0.27 ms, late in the induction).
Ours from one reverse pass through Rodas4 per tolerance; Cantera's CVODES forward sensitivities
per tolerance; central bumps of our solve. Error: the largest relative difference over the 29
reactions (entries below 1e-3 of the largest compared at that scale) against our reverse pass at
rtol 1e-12, itself checked against central bumps at that tolerance."""

import pathlib
import statistics
import time

import jax.numpy as jnp
import numpy as np

from snapo_ode import Panel, Point, agreement, compare_with_bumps

from ._ignition import IGNITION_CASES, initial_concentrations
from ._mechanism import Mechanism
from ._reactor import REACTOR_SOLVER
from ._sensitivities import cantera_sensitivities, final_temperature

TARGET = 1e-6
REFERENCE_RTOL = 1e-12
ATOL_RATIO = 1e-3
"""atol = rtol x 1e-3 on the scaled state [T / T0, N_k / N_total0] (the reactors' default ratio)."""
BUMP_STEP = 1e-4
"""Central bumps' step in ln A."""
FLOOR = 1e-3
"""Entries below 1e-3 of the largest |d ln T / d ln A| are compared at that scale: the reactions
that matter, not the round-off of those that do not."""


def _settings(rtol: float):
    return REACTOR_SOLVER.replace(rtol=rtol, atol=rtol * ATOL_RATIO, max_steps=20_000)


def _cantera_seconds(path, case, time_s, rtol: float, repeats: int) -> tuple[float, np.ndarray]:
    """Median wall time [s] of Cantera's run with every reaction's forward sensitivity, and
    d ln T / d ln A (n_reactions,). Sensitivity tolerances equal the state's rtol."""
    runs = []
    for _ in range(repeats):
        start = time.perf_counter()
        values, _ = cantera_sensitivities(path, case, time_s, rtol=rtol, atol=rtol * 1e-7,
                                          rtol_sensitivity=rtol, atol_sensitivity=rtol)
        runs.append(time.perf_counter() - start)
    return statistics.median(runs), values


def ignition_gradient_panel(rtols, repeats: int) -> Panel:
    """The h2o2 panel: ours (one reverse pass) and our central bumps, timed side by side
    (`snapo_ode.compare_with_bumps`), and Cantera's forward sensitivities, per tolerance."""
    import cantera

    path = pathlib.Path(cantera.__file__).parent / "data" / "h2o2.yaml"
    case = IGNITION_CASES["h2o2"]
    mechanism = Mechanism.from_yaml(path)
    concentrations = jnp.asarray(initial_concentrations(path, case))
    time_s = case.sensitivity_time
    zero = jnp.zeros(mechanism.n_reactions)

    def compared(rtol):  # d ln T / d ln A: our reverse pass next to central bumps of ln T in ln A
        settings = _settings(rtol)
        return compare_with_bumps(
            lambda log_a: jnp.log(final_temperature(log_a, mechanism, concentrations, case, time_s, settings)),
            zero, relative_step=BUMP_STEP, step_floor=1.0, floor=FLOOR, repeats=repeats,
            bump_repeats=max(1, repeats // 3))

    reference_run = compared(REFERENCE_RTOL)
    reference = np.asarray(reference_run.adjoint)
    points = []
    for rtol in rtols:
        setting = f"rtol={rtol:g}"
        run = compared(rtol)
        points.append(Point("ours: one reverse pass (Rodas4)", setting, run.adjoint_seconds,
                            agreement(np.asarray(run.adjoint), reference, floor=FLOOR).max_rel_diff,
                            {"compile_seconds": run.adjoint_compile_seconds}))
        points.append(Point(f"ours: central bumps ({2 * mechanism.n_reactions} solves)", setting, run.bump_seconds,
                            agreement(np.asarray(run.bumped), reference, floor=FLOOR).max_rel_diff,
                            {"compile_seconds": run.bump_compile_seconds}))
        seconds, values = _cantera_seconds(path, case, time_s, rtol, repeats=min(repeats, 3))
        points.append(Point("Cantera CVODES forward sensitivities", setting, seconds,
                            agreement(values, reference, floor=FLOOR).max_rel_diff))
    return Panel(
        "gradients_h2o2_ignition", "h2o2 ignition (1000 K, 1 atm): 29 d ln T / d ln A at 0.27 ms",
        "wall time after compile [s]", "max relative error of d ln T / d ln A", points, target=TARGET,
        notes=(f"Reference: our reverse pass at rtol {REFERENCE_RTOL:g}; central bumps (step {BUMP_STEP:g} in ln A) "
               f"at that tolerance agree with it to {reference_run.max_rel_diff:.1e}. Cantera's sensitivity "
               "tolerances equal its state rtol (atol 1e-7 of it); its time is a whole run (no compile)."))
