"""The pharma chain in `snapo bench accuracy`: the solvers' panel of study "stiff" (the five CQAs'
error against wall time per solver and tolerance) and study "gradients": what an accurate
dCQA/dCPP costs. The 20 sensitivities by each way of differentiating through the solves (reverse mode with
a checkpoint at every step, reverse mode with few checkpoints, forward mode, central bumps) at
each tolerance: relative error against the tight reference (`REFERENCE`, Kvaerno5 at rtol 1e-12)
against the median wall time after compile, with compile time and XLA's temporary memory."""

import equinox as eqx
import numpy as np

from snapo_ode import (
    AccuracyStudy, Panel, Point, Rodas4, agreement, call_checked, compare_with_bumps, compiled_temp_bytes,
    time_function, timed_point)

from ..kinetics._gradient_accuracy import ignition_gradient_panel
from ._chain import CHAIN_SOLVER, PharmaChain, chain_method
from ._cqa import cqa_vector
from ._process import make_cpps
from ._sensitivities import _values_and_jacobian, cpp_only, jacobian_function
from ._study import REFERENCE, REFERENCE_METHODS

TARGET = 1e-6
"""The report's accuracy: a relative error of the 20 dCQA/dCPP at or below 1e-6."""
BUMP_RELATIVE_STEP = 1e-4
"""Central bumps' relative step: truncation ~1e-8 relative, round-off and solver noise over the
step ~rtol / 1e-4."""
METHODS = {
    "reverse, a checkpoint a step": {"differentiation": "reverse"},
    "reverse, 16 checkpoints": {"differentiation": "reverse", "checkpoints": 16},
    "forward mode (4 tangents)": {"differentiation": "forward"},
}


CHAIN_SOLVERS = {
    "Rodas5 + Tsit5 (default)": {"solver": "rodas5", "nonstiff_solver": "tsit5"},
    "Rodas4 + Tsit5": {"solver": "rodas4", "nonstiff_solver": "tsit5"},
    "Kvaerno5 + Tsit5": {"solver": "kvaerno5", "nonstiff_solver": "tsit5"},
    "Kvaerno5 on every unit": {"solver": "kvaerno5", "nonstiff_solver": "kvaerno5"},
    "SUNDIALS CVODE on every unit (host)": {"solver": "cvode", "nonstiff_solver": "cvode"},
    "SciPy BDF on every unit (host)": {"solver": "scipy-bdf", "nonstiff_solver": "scipy-bdf"},
    "SciPy Radau on every unit (host)": {"solver": "scipy-radau", "nonstiff_solver": "scipy-radau"},
}
"""Solvers of the stiff units (R1, R2) and of the non-stiff ones (crystallizer, dryer)."""


def chain_solver_panel(rtols, repeats: int) -> Panel:
    """The five CQAs' max relative error against `REFERENCE` (Kvaerno5 at rtol 1e-12) against the
    median wall time of one simulation, per solver pair and rtol (atol = rtol / 100)."""
    base = PharmaChain()
    inputs = base.inputs(make_cpps())

    def simulation(chain):
        return eqx.filter_jit(lambda inputs: cqa_vector(chain.simulate(inputs)))

    reference = np.asarray(call_checked(simulation(base.with_solver(REFERENCE)), inputs))
    rodas_check = np.asarray(call_checked(simulation(base.with_solver(REFERENCE.replace(
        solver=Rodas4(), nonstiff_solver=Rodas4()))), inputs))
    points = []
    for rtol in rtols:
        for method, solvers in CHAIN_SOLVERS.items():
            methods = {field: chain_method(name, field) for field, name in solvers.items()}
            fn = simulation(base.with_solver(CHAIN_SOLVER.replace(rtol=rtol, atol=rtol / 100, **methods)))
            points.append(timed_point(method, f"rtol={rtol:g}", fn, inputs,
                                      lambda cqas: agreement(np.asarray(cqas), reference).max_rel_diff, repeats))
    return Panel("stiff_pharma_chain", "Pharma chain (R1, R2, crystallizer, dryer): the five CQAs",
                 "wall time after compile [s]", "max relative error of the CQAs", points, target=TARGET,
                 notes=(f"Reference: {REFERENCE_METHODS} at rtol {REFERENCE.rtol:g}; Rodas4 on every unit at the same "
                        f"tolerances agrees with it to {agreement(rodas_check, reference).max_rel_diff:.1e}. The host "
                        "solvers (SUNDIALS CVODE through scikit-sundae, SciPy) integrate each unit of the same chain, "
                        "calling our compiled right-hand side and Jacobian from Python at every evaluation: their "
                        "times include that call, so they overstate what the same method costs in C."))


def gradient_points(rtols, repeats: int) -> tuple[list[Point], float]:
    """Every (method, rtol) point (atol = rtol / 100) and the reference's own check: the largest
    relative difference between reverse and forward mode at the reference tolerances."""
    base = PharmaChain()
    inputs = base.inputs(make_cpps())
    reference_chain = base.with_solver(REFERENCE)
    _, reference = jacobian_function(reference_chain, False, "reverse")(inputs)
    _, forward_reference = jacobian_function(reference_chain, False, "forward")(inputs)
    reference = np.asarray(reference)
    reference_check = agreement(np.asarray(forward_reference), reference).max_rel_diff
    points = []
    for rtol in rtols:
        setting = f"rtol={rtol:g}"
        for method, options in METHODS.items():
            chain = base.with_solver(CHAIN_SOLVER.replace(rtol=rtol, atol=rtol / 100, **options))
            mode = options["differentiation"]
            timing, (_, matrix) = time_function(jacobian_function(chain, False, mode), inputs, repeats=repeats)
            memory = compiled_temp_bytes(_values_and_jacobian, chain, inputs, False, mode)
            points.append(Point(method, setting, timing.median_seconds, agreement(np.asarray(matrix), reference).max_rel_diff,
                                {"compile_seconds": timing.compile_seconds, "temp_megabytes": memory / 1e6}))
        chain = base.with_solver(CHAIN_SOLVER.replace(rtol=rtol, atol=rtol / 100))
        bumps = compare_with_bumps(cpp_only(chain, inputs), inputs.cpps, mode="reverse", step_floor=0.0,
                                   relative_step=BUMP_RELATIVE_STEP, repeats=1, bump_repeats=repeats)
        points.append(Point("central bumps (8 solves)", setting, bumps.bump_seconds,
                            agreement(np.asarray(bumps.bumped), reference).max_rel_diff,
                            {"compile_seconds": bumps.bump_compile_seconds}))
    return points, reference_check


def gradient_study(*, quick: bool) -> list[AccuracyStudy]:
    """The "gradients" study (`snapo bench accuracy --only gradients`)."""
    rtols = (1e-6, 1e-9) if quick else (1e-4, 1e-5, 1e-6, 1e-7, 1e-8, 1e-9, 1e-10)
    points, reference_check = gradient_points(rtols, repeats=3 if quick else 10)
    panel = Panel(
        "gradients_pharma_chain", "Pharma chain: 20 dCQA/dCPP, error against wall time",
        "wall time after compile [s]", "max relative error of the 20 dCQA/dCPP", points, target=TARGET,
        notes=(f"Reference: reverse mode through {REFERENCE_METHODS} at rtol {REFERENCE.rtol:g}; forward mode at "
               f"the same tolerances agrees with it to {reference_check:.1e}. Each method's points run from the loosest "
               "tolerance (left) to the tightest. `temp_megabytes` in the CSV is XLA's temporary memory of the "
               "compiled program: what the checkpoints cost."))
    text = ("How the derivative is taken through the chain's solves (R1, R2: Rodas5; crystallizer and dryer: "
            "Tsit5) changes its cost and its accuracy at a given tolerance. Reverse mode takes 5 passes (one per "
            "CQA) and forward mode 4 tangents (one per CPP); central bumps 8 solves.")
    ignition = ignition_gradient_panel((1e-6, 1e-9) if quick else (1e-5, 1e-6, 1e-7, 1e-8, 1e-9, 1e-10),
                                       repeats=3 if quick else 5)
    return [AccuracyStudy("gradients", "Gradients: error against time and memory", [panel, ignition], text)]
