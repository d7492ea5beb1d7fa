"""`diffrax.diffeqsolve` that fails loudly: a solver failure raises with advice instead of
returning NaNs or a truncated solution, and a stiff model refuses `BacksolveAdjoint`.

A failed solve is an `equinox.error_if` inside the program. That is a host callback, and JAX's
persistent compilation cache never stores a program that holds one (as of jax 0.10.2); nor does
it store a derivative through an implicit solver, whose linear solves lineax checks the same way
(the pharma chain's Jacobian was compiled again in every process: docs/architecture.md,
Measurements behind the design).
`call_checked` traces a jitted function with every such check as a NaN mark and raises on the
host instead, so its program is cached; entry points that compile their own programs (CLI
verbs, studies, benchmarks) call through it.
"""

import contextlib
import functools
from collections.abc import Sequence

import diffrax
import equinox as eqx
import equinox._errors as equinox_errors
import jax
import numpy as np

from ._platform.devices import to_host
from ._platform.resources import relieve_mappings_after_compiles
from ._jaxpr import equations
from ._platform.validation import InputError

class SolveResult(eqx.Enumeration):
    """How an ODE solve ended, each failure with its advice (diffrax's `RESULTS` style): what
    `diffeqsolve_checked` makes of Diffrax's result and what `snapo_ode._solver.bdf` returns.
    Inside a program a failure is an `equinox.error_if` with the advice as its message."""

    successful = ""
    max_steps_reached = (
        "the ODE solve reached max_steps before t1: raise max_steps, loosen rtol/atol, or check the "
        "state scaling (atol applies to every scaled component); on a stiff model after a fast "
        "transient, a chord root finder (VeryChord) often succeeds where Newton stalls.")
    failed = (
        "the ODE solve failed (step size collapsed, or the implicit solve did not converge or met a "
        "singular Jacobian): loosen rtol/atol, try another root finder (an ESDIRK solver's option, "
        "e.g. diffrax.Kvaerno5(root_finder=diffrax.VeryChord(...))) or solver, or check the model for "
        "NaN or negative states.")
    times_out_of_range = (
        "the ODE solve's times are out of order: t1 must exceed t0 and every output time lie within "
        "[t0, t1] (the solver integrates forward); pass increasing times.")


_FAILURE_MESSAGES = (SolveResult[SolveResult.max_steps_reached], SolveResult[SolveResult.failed])


class SolverFailed(RuntimeError):
    """An ODE solve failed (max_steps, step-size collapse, a diverged implicit solve)."""


def raise_if_failed(outputs, what: str = "the computation", causes: Sequence[str] = ()) -> None:
    """Raise `SolverFailed` with advice if any leaf of `outputs` (concrete arrays, after the
    compiled call returned) is not finite: the mark a failed check leaves under `call_checked`.
    `causes`: the model's own checks that leave the same mark, each as "what happened: what to
    do" (a domain's `error_if` messages), named after the solver's."""
    for leaf in jax.tree.leaves(outputs):
        if not np.all(np.isfinite(to_host(leaf))):
            raise SolverFailed(f"{what} gave non-finite values: an ODE solve failed. Either "
                               + " Or ".join((*_FAILURE_MESSAGES, *causes)))


def _callbacks_in(jaxpr) -> int:
    """The number of host-callback primitives in a jaxpr, loop and branch bodies included."""
    return sum("callback" in equation.primitive.name for equation in equations(jaxpr))


@functools.cache
def _check_equinox_error_mode() -> None:
    """`call_checked` relies on equinox reading the module global `equinox._errors.EQX_ON_ERROR`
    each time it traces an `error_if` whose `on_error` is the default (as in equinox 0.13.8,
    pinned): equinox's only public switch is the environment variable of that name, read once at
    import, which would turn every check in the process into NaN marks. Verify once per process
    that the global still works both ways, so that an equinox upgrade that changes it fails
    here, loudly, instead of silently dropping checks or compiling host callbacks."""
    def probe(x):
        return eqx.error_if(x, x > 0, "probe")

    mode = getattr(equinox_errors, "EQX_ON_ERROR", None)
    works = mode is not None
    if works and mode == "raise":
        works = _callbacks_in(jax.make_jaxpr(probe)(1.0)) > 0
    if works:
        with _runtime_checks_as_nan():
            works = _callbacks_in(jax.make_jaxpr(probe)(1.0)) == 0
    if not works:
        raise RuntimeError(
            f"equinox {eqx.__version__} no longer reads equinox._errors.EQX_ON_ERROR when it traces a "
            "runtime check, which snapo_ode.call_checked relies on (tested with equinox 0.13.8): install "
            "the pinned versions (requirements.lock), or adapt snapo_ode/_ode.py to the new mechanism.")


@contextlib.contextmanager
def _runtime_checks_as_nan():
    # equinox reads this module global when it traces an `error_if` whose `on_error` is the
    # default (as lineax's and optimistix's are); "nan" makes a failed check a NaN output
    # instead of a host callback. Set only while tracing our own programs, then restored.
    # JAX caches traces by function, arguments and its trace context, not by this global, so
    # the mode must also change the trace context: otherwise a trace made in one mode is reused
    # in the other (a plain call after a checked one then returns NaN without raising).
    # The matmul precision is part of that context; "highest" is what float64 on a CPU computes
    # anyway.
    previous = equinox_errors.EQX_ON_ERROR
    equinox_errors.EQX_ON_ERROR = "nan"
    try:
        with jax.default_matmul_precision("highest"):
            yield
    finally:
        equinox_errors.EQX_ON_ERROR = previous


def call_checked(fn, *args, what: str = "the computation", causes: Sequence[str] = (), **kwargs):
    """`fn(*args, **kwargs)` for a jitted `fn`, with every equinox runtime check in it (ours, and
    those of lineax and optimistix inside derivatives of implicit solves) traced as a NaN mark
    rather than a host callback, so that JAX's persistent compilation cache stores the program
    and a second process does not compile it again.

    **Returns:** the outputs. **Raises:** `SolverFailed` (via `raise_if_failed`, naming `what`
    and advising on the solver's failures and on the model's own `causes`) if any output is not
    finite, which is how a failed check shows.

    Traces made inside `call_checked` are kept apart from those made outside it (see
    `_runtime_checks_as_nan`), so a plain call of the same function still raises."""
    _check_equinox_error_mode()
    relieve_mappings_after_compiles()
    with _runtime_checks_as_nan():
        out = fn(*args, **kwargs)
    raise_if_failed(out, what, causes)
    return out


def prefetch_checked(program, *args, elsewhere: bool = False) -> bool:
    """`program.prefetch(*args, elsewhere=elsewhere)` (a `snapo_ode.exported` program,
    `ExportedProgram.prefetch`) keyed and traced as `call_checked(program, *args)` will look it
    up: prefetch the programs a command will run before running the first, and those on disk
    load, and those traced here (or, with `elsewhere`, in a helper process) compile, on other
    cores while it runs. **Returns:** whether the entry was on disk."""
    _check_equinox_error_mode()
    with _runtime_checks_as_nan():
        return program.prefetch(*args, elsewhere=elsewhere)


def diffeqsolve_checked(terms, solver, t0, t1, dt0, y0, args=None, *, stiff: bool = True, **kwargs):
    """`diffrax.diffeqsolve(terms, solver, t0, t1, dt0, y0, args, **kwargs)` with checks.

    **Arguments:** as `diffrax.diffeqsolve` (without `throw`), and `stiff`: whether the model is
    stiff; then `adjoint=diffrax.BacksolveAdjoint(...)` is refused, because its backward solve
    diverges on stiff problems (max_steps, or gradients near 1e297).

    **Returns:** the `diffrax.Solution`.

    **Raises:** `InputError` for `throw` or a backsolve adjoint on a stiff model (before any
    compile); inside jit, an `equinox.error_if` error with advice when the solve fails (under
    `call_checked`: `SolverFailed`, on the host).
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
    result = SolveResult.where(
        solution.result == diffrax.RESULTS.successful, SolveResult.successful,
        SolveResult.where(solution.result == diffrax.RESULTS.max_steps_reached, SolveResult.max_steps_reached,
                          SolveResult.failed))
    return eqx.tree_at(lambda s: s.ys, solution, checked_ys(solution.ys, result))


def checked_ys(ys, result: SolveResult):
    """`ys` behind an `equinox.error_if` that raises with `result`'s advice unless it is
    `SolveResult.successful` (a traced result)."""
    return result.error_if(ys, result != SolveResult.successful)
