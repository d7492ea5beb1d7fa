"""The ALM workload of `snapo bench scaling`: one reverse pass for the objective and its
sensitivities to N = 100 risk factors over 120 months, its paths split over the devices of
`mesh`. Strong scaling: 10,000 paths in all; weak: 5,000 per device. What the devices
exchange per pass is one all-reduce of the value and the N sensitivities."""

import equinox as eqx
import jax

from snapo_ode import compiled_temp_bytes, time_function, value_and_sensitivities

from ._policy import NeuralRebalancing
from ._sensitivities import objective_of_reported
from ._study import build_study, scenarios

RISK_FACTORS = 100
HORIZON_MONTHS = 120
STRONG_PATHS, WEAK_PATHS_PER_DEVICE = 10_000, 5_000
QUICK_STRONG_PATHS, QUICK_WEAK_PATHS_PER_DEVICE, QUICK_HORIZON_MONTHS = 64, 32, 6


def device_scaling(*, mesh, quick: bool, seed: int, repeats: int) -> list[dict]:
    """Rows of `snapo bench scaling` (see `snapo_ode._runtime.scaling`) for strong and weak scaling on
    `mesh` (None: one device; `quick`: a test's size), `repeats` timed calls a point."""
    devices = 1 if mesh is None else mesh.size
    horizon = QUICK_HORIZON_MONTHS if quick else HORIZON_MONTHS
    strong, weak = (QUICK_STRONG_PATHS, QUICK_WEAK_PATHS_PER_DEVICE) if quick else (STRONG_PATHS, WEAK_PATHS_PER_DEVICE)
    study = build_study(RISK_FACTORS, horizon_months=horizon)
    key = jax.random.key(seed)
    policy = NeuralRebalancing(study.market, key=jax.random.fold_in(key, 1))
    objective = objective_of_reported(study.problem, study.fixed, mesh=mesh)
    adjoint = eqx.filter_jit(lambda reported, policy, shocks: value_and_sensitivities(objective, reported, policy, shocks))
    rows = []
    for kind, paths in (("strong", strong), ("weak", weak * devices)):
        shocks = scenarios(study, paths, jax.random.fold_in(key, 2), mesh)
        timing, (value, _) = time_function(adjoint, study.reported, policy, shocks, repeats=repeats)
        rows.append(dict(
            workload=f"ALM sensitivities (N = {RISK_FACTORS}, {horizon} months)", scaling=kind, devices=devices,
            samples=paths, seconds=timing.median_seconds, compile_seconds=timing.compile_seconds,
            temp_megabytes_per_device=compiled_temp_bytes(adjoint, study.reported, policy, shocks) / 1e6,
            collective_bytes=8 * (study.layout.n_risk_factors + 1) if devices > 1 else 0, value=float(value)))
    return rows
