"""`diffrax.diffeqsolve` that fails loudly: a solver failure raises with advice instead of
returning NaNs or a truncated solution, and a stiff model refuses `BacksolveAdjoint`."""

import diffrax
import equinox as eqx
import jax.numpy as jnp

from ._validation import InputError

_FAILURE_MESSAGES = (
    "the ODE solve reached max_steps before t1: raise max_steps, loosen rtol/atol, or check the "
    "state scaling (atol applies to every scaled component); on a stiff model after a fast "
    "transient, a chord root finder (VeryChord) often succeeds where Newton stalls.",
    "the ODE solve failed (step size collapsed, or the implicit solve did not converge or met a "
    "singular Jacobian): loosen rtol/atol, try the other root finder, or check the model for "
    "NaN or negative states.",
)


def diffeqsolve_checked(terms, solver, t0, t1, dt0, y0, args=None, *, stiff: bool = True, **kwargs):
    """`diffrax.diffeqsolve(terms, solver, t0, t1, dt0, y0, args, **kwargs)` with checks.

    **Arguments:** as `diffrax.diffeqsolve` (without `throw`), and `stiff`: whether the model is
    stiff; then `adjoint=diffrax.BacksolveAdjoint(...)` is refused, because its backward solve
    diverges on stiff problems (max_steps, or gradients near 1e297).

    **Returns:** the `diffrax.Solution`.

    **Raises:** `InputError` for `throw` or a backsolve adjoint on a stiff model (before any
    compile); inside jit, an `equinox.error_if` error with advice when the solve fails.
    """
    if "throw" in kwargs:
        raise InputError("throw is set by diffeqsolve_checked (failures always raise); remove it.")
    if stiff and isinstance(kwargs.get("adjoint"), diffrax.BacksolveAdjoint):
        raise InputError(
            "adjoint = BacksolveAdjoint on a stiff model: its backward solve diverges on stiff "
            "problems; use diffrax.RecursiveCheckpointAdjoint() (the default) for gradients, or "
            "diffrax.ForwardMode() for forward-mode Jacobians with few inputs."
        )
    solution = diffrax.diffeqsolve(terms, solver, t0, t1, dt0, y0, args, throw=False, **kwargs)
    failed = solution.result != diffrax.RESULTS.successful
    which = jnp.where(solution.result == diffrax.RESULTS.max_steps_reached, 0, 1)
    ys = eqx.branched_error_if(solution.ys, failed, which, _FAILURE_MESSAGES)
    return eqx.tree_at(lambda s: s.ys, solution, ys)
