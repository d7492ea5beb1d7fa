"""How much memory a study needs, estimated before anything is allocated, and the refusal of one
that would not fit."""

from snapo_ode import check_memory

from ._factors import FactorLayout
from ._liabilities import MINIMUM_RUN_OFF_MONTHS


RUNTIME_BYTES = 0.5 * 1024**3  # JAX, XLA and the interpreter before the model's arrays
VALUATION_ARRAYS = 6  # per path and outstanding month, while one month's liabilities are valued (counted)


def memory_estimate(layout: FactorLayout, horizon_months: int, n_paths: int = 0) -> float:
    """Peak bytes of building the fund and taking one reverse pass over `n_paths` paths: the
    liability grid (71 ages x R months of run-off, three arrays while the cash flows are built;
    the outstanding flows at every month of the horizon, with their cotangent; the tenor mapping)
    and the Monte Carlo (shocks, and each month's per-path state kept for the reverse pass; the
    month being differentiated values every outstanding flow on every path: its zero rates, two
    discount factors and their cotangents, `VALUATION_ARRAYS` arrays of paths x run-off).
    Calibrated against a measured peak (docs/dev/alm_notes.md, Measurements behind the design)."""
    run_off = max(layout.n_liability, MINIMUM_RUN_OFF_MONTHS)
    tenors, drivers = layout.n_tenors, 3 + layout.n_equities + 2
    grid = run_off * (3 * 71 + 2 * (horizon_months + 1) + tenors)
    paths = horizon_months * n_paths * (drivers + 2 * (tenors + 12)) + VALUATION_ARRAYS * n_paths * run_off
    return RUNTIME_BYTES + 8.0 * (grid + paths)


def check_size(layout: FactorLayout, horizon_months: int, n_paths: int = 0) -> None:
    """Refuse, before any allocation, a study that would not fit in memory (`memory_estimate`)."""
    check_memory(f"the ALM study with N = {layout.n_risk_factors} risk factors"
                 + (f", {n_paths} paths" if n_paths else "") + f" and {horizon_months} months",
                 memory_estimate(layout, horizon_months, n_paths),
                 "use fewer risk factors (the liability grid grows with N), paths or months.")
