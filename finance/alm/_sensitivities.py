"""The objective as a function of the reported risk factors, and how the baselines of its
sensitivities are batched: central bump-and-revalue (2N revaluations) and forward mode (N
tangents), both through `snapo_ode.compare_with_bumps` on the same paths as the adjoint."""

from snapo_ode import SAMPLES, sample_mean, spec

from ._model import ALMProblem, objective

# Rows (revaluations x paths) per vmapped chunk of bumps. The paths already fill the vector
# units, so the fastest bump maps sequentially inside the compiled `lax.map` once a revaluation
# has 128 paths (vmapping several, or a Python loop over a jitted revaluation, was slower:
# docs/alm.md, Sensitivities), and vmaps small-path revaluations together.
BUMP_ROWS_PER_CHUNK = 128
# Tangents share the primal computation in forward mode, so vmapping them pays: a factor's
# tangent in a vmapped chunk costs less than a forward evaluation (docs/dev/alm_notes.md, Measurements
# behind the design).
FORWARD_ROWS_PER_CHUNK = 16384
# Central differences on factors of order 1e-2 (rates, vols): a step of 1e-6 * max(|x|, 1)
# keeps both truncation error and round-off small against the adjoint, where the
# cube-root-of-epsilon default's larger step truncates visibly on the volatilities (docs/dev/alm_notes.md,
# Measurements behind the design).
BUMP_RELATIVE_STEP = 1e-6
PATHS_PER_CHUNK = 500
"""Paths per pass of the objective on a device, one chunk after another when it divides the
device's paths (`snapo_ode.sample_mean`): a chunk's working set stays in cache, so a reverse pass
is faster than unchunked, on one device and on two (docs/dev/alm_notes.md, Measurements behind the
design)."""
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
