"""Sensitivities of the objective to every reported risk factor, three ways, on the same paths:

- `adjoint`: one reverse pass (`snapo_ode.value_and_sensitivities`);
- `bump`: central bump-and-revalue, 2N revaluations (plus the base value), vmapped in chunks;
- `forward`: forward mode, N Jacobian-vector products, vmapped in chunks.

Each is a jitted function of `(reported, policy, shocks)`; `time_compiled` compiles it ahead of
time (compile time reported apart) and reports the median of the runs after.
"""

import statistics
import time
from collections.abc import Callable

import equinox as eqx
import jax
import jax.numpy as jnp

from snapo_ode import Timing, bump_and_revalue, flatten_inputs, value_and_sensitivities

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


def objective_of_reported(problem: ALMProblem, fixed: dict, *, smooth_constraints: bool = True):
    """The objective as a function `(reported, policy, shocks) -> J`."""

    def fn(reported, policy, shocks):
        return objective(reported, policy, shocks, problem, fixed,
                         smooth_constraints=smooth_constraints)

    return fn


def chunk_size(n_revaluations: int, n_paths: int, rows: int) -> int:
    """Revaluations per vmapped chunk: `rows // n_paths`, at least 1, at most all."""
    return int(max(1, min(n_revaluations, rows // max(n_paths, 1))))


def adjoint(fn: Callable) -> Callable:
    """`(reported, policy, shocks) -> (J, dJ/dreported)` from one reverse pass."""
    return eqx.filter_jit(lambda reported, policy, shocks: value_and_sensitivities(
        fn, reported, policy, shocks))


def bump(fn: Callable, n_factors: int, n_paths: int, *,
         relative_step: float = BUMP_RELATIVE_STEP) -> Callable:
    """`(reported, policy, shocks) -> (J, dJ/dreported)` by central bump-and-revalue: the base
    value and 2N revaluations, vmapped in chunks of `chunk_size` revaluations."""
    batch = chunk_size(2 * n_factors, n_paths, BUMP_ROWS_PER_CHUNK)

    def run(reported, policy, shocks):
        gradient = bump_and_revalue(fn, reported, policy, shocks, relative_step=relative_step,
                                    batch_size=None if batch >= 2 * n_factors else batch)
        return fn(reported, policy, shocks), gradient

    return eqx.filter_jit(run)


def forward(fn: Callable, n_factors: int, n_paths: int) -> Callable:
    """`(reported, policy, shocks) -> (J, dJ/dreported)` by forward mode: one Jacobian-vector
    product per factor, vmapped in chunks of `chunk_size` tangents."""
    batch = chunk_size(n_factors, n_paths, FORWARD_ROWS_PER_CHUNK)

    def run(reported, policy, shocks):
        flat, rebuild = flatten_inputs(reported)

        def directional(tangent):
            return jax.jvp(lambda x: fn(rebuild(x), policy, shocks), (flat,), (tangent,))[1]

        basis = jnp.eye(flat.size, dtype=flat.dtype)
        columns = jax.lax.map(directional, basis, batch_size=batch)
        return fn(reported, policy, shocks), rebuild(columns)

    return eqx.filter_jit(run)


def time_compiled(jitted, *args, repeats: int = 3) -> tuple[Timing, object]:
    """Compile `jitted` (an `equinox.filter_jit` function) ahead of time, then run it `repeats`
    times. `compile_seconds` is the ahead-of-time compile; `median_seconds` the median run."""
    start = time.perf_counter()
    compiled = jitted.lower(*args).compile()
    compile_seconds = time.perf_counter() - start
    runs, out = [], None
    for _ in range(max(repeats, 1)):
        start = time.perf_counter()
        out = jax.block_until_ready(compiled(*args))
        runs.append(time.perf_counter() - start)
    median = statistics.median(runs)
    return Timing(median, compile_seconds, compile_seconds + runs[0], tuple(runs)), out
