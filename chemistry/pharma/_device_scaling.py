"""The pharma workload of `snapo bench scaling`: the design space's full-model Monte Carlo, the
chain's five CQAs on draws of every reaction's ln k (sigma 0.1), the draws split over the devices
of `mesh`. Strong scaling: 256 draws in all; weak: 64 per device. The devices exchange
nothing: each keeps its draws' CQAs, and the host gathers 40 bytes per draw."""

import jax
import numpy as np

from snapo_ode import compiled_temp_bytes, time_function

from ._chain import PharmaChain
from ._process import make_cpps
from ._sensitivities import _shifted_cqas, input_names, placed_shifts, shifted_cqas

STRONG_DRAWS, WEAK_DRAWS_PER_DEVICE = 256, 64
QUICK_STRONG_DRAWS, QUICK_WEAK_DRAWS_PER_DEVICE = 8, 4
SIGMA = 0.1


def device_scaling(*, mesh, quick: bool, seed: int, repeats: int) -> list[dict]:
    """Rows of `snapo bench scaling` (see `snapo_ode._runtime.scaling`) for strong and weak scaling on
    `mesh` (None: one device; `quick`: a test's size), `repeats` timed calls a point."""
    devices = 1 if mesh is None else mesh.size
    strong, weak = (QUICK_STRONG_DRAWS, QUICK_WEAK_DRAWS_PER_DEVICE) if quick else (STRONG_DRAWS,
                                                                                         WEAK_DRAWS_PER_DEVICE)
    chain = PharmaChain()
    inputs = chain.inputs(make_cpps())
    names = input_names(chain)
    columns = [k for k, name in enumerate(names) if name.startswith("log_multiplier[")]
    rows = []
    for kind, draws in (("strong", strong), ("weak", weak * devices)):
        shifts = np.zeros((draws, len(names)))
        shifts[:, columns] = SIGMA * np.asarray(jax.random.normal(jax.random.key(seed), (draws, len(columns))))
        timing, _ = time_function(lambda shifts: shifted_cqas(chain, inputs, shifts, mesh), shifts, repeats=repeats)
        rows.append(dict(
            workload="pharma Monte Carlo (full chain per draw)", scaling=kind, devices=devices, samples=draws,
            seconds=timing.median_seconds, compile_seconds=timing.compile_seconds,
            temp_megabytes_per_device=compiled_temp_bytes(_shifted_cqas, chain, inputs, placed_shifts(shifts, mesh), mesh) / 1e6, collective_bytes=0))
    return rows

