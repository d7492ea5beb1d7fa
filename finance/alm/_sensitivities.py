"""The objective as a function of the reported risk factors, and how the baselines of its
sensitivities are batched: central bump-and-revalue (2N revaluations) and forward mode (N
tangents), both through `snapo_ode.compare_with_bumps` on the same paths as the adjoint."""

from snapo_ode import SAMPLES, sample_mean, spec

from ._model import ALMProblem, objective

# Rows (revaluations x paths) per vmapped chunk of bumps. Measured on a 2-core CPU at N = 100,
# 128 paths, 120 months: one revaluation after another inside the compiled `lax.map` took 10 ms
# each; vmapping 8, 32 or 128 of them 16-29 ms each; a Python loop over a jitted revaluation
# 4.3 s for the 200 (its compile included). The paths already fill the vector units, so the fastest bump maps
# sequentially once a revaluation has 128 paths, and vmaps small-path revaluations together.
BUMP_ROWS_PER_CHUNK = 128
# Tangents share the primal computation in forward mode, so vmapping them pays (7 ms per
# factor at 128 paths with 100 tangents per chunk, against 11 ms per forward evaluation).
FORWARD_ROWS_PER_CHUNK = 16384
# Central differences on factors of order 1e-2 (rates, vols): a step of 1e-6 * max(|x|, 1)
# keeps truncation error near 1e-9 and round-off near 1e-10 relative (measured against the
# adjoint; the cube-root-of-epsilon default truncates at 1e-6 on the volatilities).
BUMP_RELATIVE_STEP = 1e-6
PATHS_PER_CHUNK = 500
"""Paths per pass of the objective on a device, one chunk after another when it divides the
device's paths (`snapo_ode.sample_mean`): measured on a 2-core CPU at N = 100, 10,000 paths, 120
months, one reverse pass took 3.3 s unchunked and 2.7 s in chunks of 500 on one device, 1.35 s
on two."""
PATH_SPECS = (spec(), spec(), spec(None, SAMPLES))
"""How three arguments, the last the shocks (months, paths, drivers), split over a samples mesh:
the paths along the shocks' axis 1, the other two (factors, policy) replicated."""


def objective_of_reported(problem: ALMProblem, fixed: dict, *, smooth_constraints: bool = True, mesh=None):
    """The objective as a function `(reported, policy, shocks) -> J`; with a samples `mesh`, the
    paths (the shocks' axis 1) split over its devices and J (and every sensitivity, differentiated)
    reduced in one all-reduce."""

    def fn(reported, policy, shocks):
        return objective(reported, policy, shocks, problem, fixed,
                         smooth_constraints=smooth_constraints)

    return sample_mean(fn, mesh, PATH_SPECS, chunk=PATHS_PER_CHUNK)


def chunk_size(n_revaluations: int, n_paths: int, rows: int) -> int | None:
    """Revaluations per chunk: `rows // n_paths`, at least 1; None (all at once, vmapped) when
    that covers every revaluation."""
    size = max(1, rows // max(n_paths, 1))
    return None if size >= n_revaluations else size
