"""`snapo bench kinetics --batch N`: N constant-volume adiabatic ignitions from different initial
states, solved by us as one batch (`final_temperature_batch`, and each reactor's d T / d ln A_i
from a reverse pass each, vmapped, `temperature_sensitivities_batch`) and by Cantera one after the
other, at the single bench's tolerances and to the same time (the case's sensitivity time).

The conditions: T0 uniform in [T_case - 50 K, T_case] and P0 in [0.5, 1] x the case's pressure
(seed 0), the case's composition, so that every reactor is still in its induction at the end
time, as the single bench's reactor is (hotter starts ignite before it, and the bench would time
the burnt gas instead). Our programs are compiled ahead of time (`lower().compile()`, timed as
the compile) and then run `repeats` times (the median is reported): a gri30 batch of 256 runs
for minutes on a CPU, and a warm-up run would double that. `SINGLE_CHECKS` of the batch's
reactors are also solved alone, and the largest relative difference is reported: the batch must
give what single solves give (to 1e-10) on whatever device it ran. Likewise the batched gradients
are checked against central differences (`BUMP_CHECKS` of them) on that device."""

import statistics
import time

import equinox as eqx
import numpy as np
from tqdm import tqdm

from snapo_ode import agreement, central_differences, raise_if_failed

from ._batch import IgnitionBatch, temperature_program
from ._ignition import IgnitionCase
from ._sensitivities import temperature_at

TEMPERATURE_SPAN = 50.0
"""T0 spans [T_case - TEMPERATURE_SPAN, T_case] [K]."""
PRESSURE_SPAN = (0.5, 1.0)
"""P0 spans these fractions of the case's pressure."""
GROUP_SIZE = 32
"""Reactors per vmap in the grouped forward run (larger batches only), next to the one-vmap run:
what grouping conditions sorted by T0 (alike step counts) saves."""
GRADIENT_SAMPLE = 16
"""Reactors (evenly spaced through the sorted batch) whose gradients are timed, as one vmap: all
256 gri30 reverse passes would take too long (docs/dev/chemistry_notes.md, Measurements behind the design),
and their memory (a checkpoint a step) grows with N."""
SINGLE_CHECKS = 3
"""Reactors (the first, middle and last of the sorted batch) also solved one at a time."""
BUMP_CHECKS = 3
"""Reactions whose batched d ln T / d ln A (the gradient sample's first reactor, its largest
sensitivities) are checked against Richardson central differences of single solves."""
BUMP_STEP = 1e-3
"""The central differences' step in ln A (Richardson: error O(h^4), the solver's rtol over h far
below the agreement asked)."""


def device() -> str:
    """What runs our solves, e.g. "gpu: NVIDIA H200" or "cpu: cpu" (Cantera runs on the host's CPU)."""
    import jax

    return f"{jax.default_backend()}: {jax.devices()[0].device_kind}"


def batch_conditions(mechanism, case: IgnitionCase, size: int, seed: int = 0) -> IgnitionBatch:
    """`size` reactors around `case` (see the module docstring), sorted by T0."""
    rng = np.random.default_rng(seed)
    temperature = np.sort(case.temperature - TEMPERATURE_SPAN * rng.random(size))
    pressure = case.pressure * rng.uniform(*PRESSURE_SPAN, size)
    return IgnitionBatch(mechanism, temperature, pressure, case.composition)


def cantera_serial(path, batch: IgnitionBatch, end_time: float, repeats: int, *, rtol: float,
                   atol: float) -> tuple[float, np.ndarray]:
    """Median wall time [s] of Cantera's `IdealGasReactor` run to `end_time` [s] for every reactor
    of `batch`, one after the other (one `Solution`, a new reactor and network each), and T
    there [K], shape `(N,)`."""
    import cantera

    solution = cantera.Solution(str(path))
    conditions = [(float(t), float(p), np.asarray(x)) for t, p, x in
                  zip(batch.temperature, batch.pressure, batch.mole_fractions)]
    runs = []
    for _ in range(max(repeats, 1)):
        temperatures = []
        start = time.perf_counter()
        for condition in conditions:
            solution.TPX = condition
            reactor = cantera.IdealGasReactor(solution, clone=False)
            net = cantera.ReactorNet([reactor])
            net.rtol, net.atol, net.max_steps = rtol, atol, 200_000
            net.advance(end_time)
            temperatures.append(reactor.phase.T)
        runs.append(time.perf_counter() - start)
    return statistics.median(runs), np.array(temperatures)


def single_solve_difference(mechanism, batch: IgnitionBatch, temperature, end, settings) -> float:
    """The largest relative difference between `temperature` [K] (shape `(N,)`, the batch's T at
    `end`) and single solves of `SINGLE_CHECKS` of its reactors (`chemistry.temperature_at`)."""
    single = eqx.filter_jit(temperature_at)
    indices = np.unique(np.linspace(0, batch.size - 1, min(batch.size, SINGLE_CHECKS)).astype(int))
    return max(abs(float(temperature[i]) / float(single(batch.log_multiplier[i], mechanism, batch.temperature[i],
                                                          batch.concentrations[i], end, settings)) - 1)
               for i in indices)


def _compiled_and_timed(fn, args: tuple, repeats: int):
    """Compile `fn` (an `equinox.filter_jit` function) for `args` ahead of time, then run it
    `repeats` times: (compile seconds, median run seconds, the outputs). **Raises:**
    `SolverFailed` if an output is not finite: a time of NaN results is no result (a batch's
    gradients once were, `chemistry.kinetics._reactor.TRIAL_TEMPERATURE_CEILING`)."""
    import jax

    start = time.perf_counter()
    compiled = fn.lower(*args).compile()
    compile_seconds = time.perf_counter() - start
    runs = []
    for _ in range(max(repeats, 1)):
        start = time.perf_counter()
        out = jax.block_until_ready(compiled(*args))
        runs.append(time.perf_counter() - start)
    raise_if_failed(out, "the batch bench's program")
    return compile_seconds, statistics.median(runs), out


def gradient_bump_difference(mechanism, sample: IgnitionBatch, sensitivities, end, settings) -> float:
    """The largest relative difference between the batched d ln T / d ln A_i of `sample`'s first
    reactor (`sensitivities`, shape `(N, n_reactions)`) at its `BUMP_CHECKS` largest and
    Richardson central differences of its single solves (one vmap of 4 x `BUMP_CHECKS` solves),
    on the device the batch ran on."""
    import jax.numpy as jnp

    first = np.asarray(sensitivities[0])
    reactions = np.argsort(-np.abs(first))[:BUMP_CHECKS]

    def log_temperature(log_multiplier):
        full = sample.log_multiplier[0].at[reactions].set(log_multiplier)
        return jnp.log(temperature_at(full, mechanism, sample.temperature[0], sample.concentrations[0], end,
                                      settings))

    bumped = central_differences(log_temperature, sample.log_multiplier[0][reactions], relative_step=BUMP_STEP,
                                 richardson=True)
    return agreement(first[reactions], np.asarray(bumped)).max_rel_diff


def _forward_against_cantera(path, mechanism, batch: IgnitionBatch, end_time: float, settings, repeats: int,
                             cantera_repeats: int):
    """Our batch's forward solve (one vmap, compiled ahead of time, median of `repeats` runs) and
    Cantera's serial runs (median of `cantera_repeats`) on the same conditions: (compile seconds,
    our seconds, Cantera's seconds, our T [K] (shape `(N,)`), the largest relative difference from
    Cantera's T)."""
    import jax.numpy as jnp

    compile_seconds, forward, temperature = _compiled_and_timed(
        temperature_program, (mechanism, batch, jnp.asarray(end_time), settings, None, False), repeats)
    cantera, cantera_temperature = cantera_serial(path, batch, end_time, cantera_repeats, rtol=settings.rtol,
                                                  atol=settings.atol)
    difference = float(np.max(np.abs(np.asarray(temperature) / cantera_temperature - 1)))
    return compile_seconds, forward, cantera, temperature, difference


def benchmark_batch(name: str, path, mechanism, case: IgnitionCase, size: int, end_time: float, settings,
                    repeats: int) -> dict:
    """The batch fields of the kinetics bench's row for mechanism `name`: per-reactor times and
    throughputs of our batched forward solve (one vmap, and in groups of `GROUP_SIZE` of the
    conditions sorted by T0), our gradients (vmapped over `GRADIENT_SAMPLE` of them; the first
    reactor's checked against central differences, `gradient_bump_difference`) and Cantera's
    serial runs."""
    import jax
    import jax.numpy as jnp

    batch = batch_conditions(mechanism, case, size)
    end = jnp.asarray(end_time)
    group = GROUP_SIZE if size > GROUP_SIZE else None
    stages = tqdm(total=5, desc=f"{name} batch of {size}", unit="stage")  # minutes on a CPU
    stages.set_postfix_str("forward, one vmap; Cantera, serially")
    forward_compile, forward, cantera, temperature, cantera_difference = _forward_against_cantera(
        path, mechanism, batch, end_time, settings, repeats, repeats)
    stages.update()
    stages.set_postfix_str(f"forward, groups of {group}")
    grouped_compile, grouped, _ = _compiled_and_timed(
        temperature_program, (mechanism, batch, end, settings, group, False), repeats) if group else (None,) * 3
    stages.update()
    stages.set_postfix_str("gradients")
    sample = jax.tree.map(lambda x: x[np.linspace(0, size - 1, min(size, GRADIENT_SAMPLE)).astype(int)], batch)
    gradient_compile, gradient, (sensitivities, _) = _compiled_and_timed(
        temperature_program, (mechanism, sample, end, settings, None, True), repeats)
    stages.update()
    stages.set_postfix_str("single solves")
    single_difference = single_solve_difference(mechanism, batch, temperature, end, settings)
    stages.update()
    stages.set_postfix_str("gradients against central differences")
    bump_difference = gradient_bump_difference(mechanism, sample, sensitivities, end, settings)
    stages.update()
    stages.close()
    forward, gradient, cantera = forward / size, gradient / sample.size, cantera / size  # per reactor
    grouped = grouped and grouped / size
    return {
        "batch": size, "batch_group_size": group or size,
        "batch_temperature_min_K": float(batch.temperature.min()),
        "batch_temperature_max_K": float(batch.temperature.max()),
        "batch_pressure_min_Pa": float(batch.pressure.min()), "batch_pressure_max_Pa": float(batch.pressure.max()),
        "batch_forward_s_per_reactor": forward, "batch_forward_reactors_per_s": 1 / forward,
        "batch_forward_compile_s": forward_compile,
        "batch_forward_grouped_s_per_reactor": grouped, "batch_forward_grouped_compile_s": grouped_compile,
        "batch_gradient_s_per_reactor": gradient, "batch_gradient_reactors_per_s": 1 / gradient,
        "batch_gradient_compile_s": gradient_compile, "batch_gradient_reactors": sample.size,
        "cantera_serial_s_per_reactor": cantera, "cantera_serial_reactors_per_s": 1 / cantera,
        "batch_forward_speedup_vs_cantera_serial": cantera / forward,
        "batch_forward_grouped_speedup_vs_cantera_serial": grouped and cantera / grouped,
        "batch_gradient_speedup_vs_cantera_serial_forward": cantera / gradient,
        "batch_max_relative_difference_vs_cantera": cantera_difference,
        "batch_max_relative_difference_vs_single": single_difference,
        "batch_single_reactors": min(size, SINGLE_CHECKS),
        "batch_gradient_max_relative_difference_vs_bumps": bump_difference,
        "batch_gradient_bump_checks": min(BUMP_CHECKS, mechanism.n_reactions),
        "batch_repeats": max(repeats, 1),
    }


def benchmark_scaling(name: str, path, mechanism, case: IgnitionCase, sizes, end_time: float, settings,
                      repeats: int) -> list[dict]:
    """One row per N in `sizes`: the per-reactor time of our batched forward solve (one vmap of N
    reactors, `batch_conditions`) and of Cantera run serially on the same N conditions, side by
    side: how batching amortises as N grows (on a GPU, until the device is full). Cantera runs
    the N reactors once per size (N solves already, which take a while at large N:
    docs/dev/chemistry_notes.md, Measurements behind the design)."""
    rows = []
    for size in tqdm(sizes, desc=f"{name} batch scaling", unit="size", disable=not sizes):
        batch = batch_conditions(mechanism, case, size)
        compile_seconds, forward, cantera, _, difference = _forward_against_cantera(
            path, mechanism, batch, end_time, settings, repeats, 1)
        forward, cantera = forward / size, cantera / size  # per reactor
        rows.append({
            "mechanism": name, "batch": size, "device": device(),
            "end_time_s": end_time, "rtol": settings.rtol, "atol": settings.atol,
            "batch_forward_s_per_reactor": forward, "batch_forward_reactors_per_s": 1 / forward,
            "batch_forward_compile_s": compile_seconds,
            "cantera_serial_s_per_reactor": cantera, "cantera_serial_reactors_per_s": 1 / cantera,
            "batch_forward_speedup_vs_cantera_serial": cantera / forward,
            "batch_max_relative_difference_vs_cantera": difference, "batch_repeats": max(repeats, 1),
        })
    return rows
