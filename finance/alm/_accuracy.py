"""ALM in `snapo bench accuracy`: its panels of the "smoothing" and "monte-carlo" studies.

- Smoothing: the floor penalty's sharpness k against the smooth-hard gap of the objective.
- Monte Carlo: paths against the relative standard error of the objective (per path, exact
  constraints) and of the 40 sensitivities (32 batches of paths, one reverse pass each), and
  against wall time.

One untrained policy (seeded) on N = 40 risk factors over 120 months: the panels measure the
model and its estimators, not a training run."""

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np

from snapo_ode import AccuracyStudy, Panel, Point, time_function, value_and_sensitivities

from ._model import ALMConfig, simulate
from ._policy import NeuralRebalancing
from ._sensitivities import objective_of_reported
from ._study import build_study, scenarios

RISK_FACTORS = 40
BATCHES = 32
"""Batches of the paths whose sensitivities give their standard error (the spread of a standard
error from k batches is ~1 / sqrt(2 (k - 1)) of it: 13% here, 27% with 8)."""
SHARPNESS = (5.0, 10.0, 20.0, 50.0, 100.0, 200.0, 500.0)
DEFAULT_SHARPNESS = ALMConfig().floor_sharpness


def _policy(study, seed: int):
    return NeuralRebalancing(study.market, key=jax.random.fold_in(jax.random.key(seed), 1))


def smoothing_panel(quick: bool, seed: int) -> Panel:
    """The floor penalty's sharpness k against |J_smooth - J_hard| / |J_hard| on 1,024 paths."""
    points = []
    for k in SHARPNESS[1::2] if quick else SHARPNESS:
        study = build_study(RISK_FACTORS, config=ALMConfig(floor_sharpness=k))
        shocks = scenarios(study, 1024, jax.random.fold_in(jax.random.key(seed), 2))
        factors = {**study.fixed, **study.reported}
        both = eqx.filter_jit(lambda policy, shocks: tuple(
            jnp.mean(simulate(study.problem, policy, factors, shocks, smooth_constraints=smooth).utility)
            for smooth in (True, False)))
        smooth, hard = (float(v) for v in both(_policy(study, seed), shocks))
        points.append(Point("objective", f"k={k:g}", k, abs(smooth - hard) / abs(hard),
                            {"smooth": smooth, "hard": hard}))
    return Panel("smoothing_alm_gap", "ALM: the floor penalty's sharpness against the smooth-hard gap",
                 "sharpness k of the smooth max(floor - funding ratio, 0)", "|J smooth - J hard| / |J hard|", points,
                 notes=(f"N = {RISK_FACTORS}, 120 months, 1,024 paths, one untrained policy; the turnover's |.| keeps "
                        f"its default sharpness. The library's default is k = {DEFAULT_SHARPNESS:g}."))


def monte_carlo_panels(quick: bool, seed: int) -> list[Panel]:
    """Paths against the relative standard error of J and of its sensitivities, and time."""
    study = build_study(RISK_FACTORS)
    policy = _policy(study, seed)
    objective = objective_of_reported(study.problem, study.fixed)
    factors = {**study.fixed, **study.reported}
    per_path = eqx.filter_jit(lambda shocks: simulate(study.problem, policy, factors, shocks,
                                                      smooth_constraints=False).utility)
    per_batch = eqx.filter_jit(jax.vmap(lambda reported, shocks: value_and_sensitivities(objective, reported, policy,
                                                                                            shocks), in_axes=(None, 1)))
    value_points, sensitivity_points, time_points = [], [], []
    for paths in (256, 1024) if quick else (256, 1024, 4096, 16384):
        setting = f"paths={paths}"
        shocks = scenarios(study, paths, jax.random.fold_in(jax.random.key(seed + 1), paths))
        batches = shocks.reshape(shocks.shape[0], BATCHES, paths // BATCHES, shocks.shape[2])
        value_timing, values = time_function(per_path, shocks, repeats=3)
        values = np.asarray(values)
        value_se = values.std(ddof=1) / np.sqrt(paths) / abs(values.mean())
        timing, (_, gradients) = time_function(per_batch, study.reported, batches, repeats=1 if paths > 4096 else 3)
        by_batch = np.concatenate([np.asarray(leaf).reshape(BATCHES, -1) for leaf in jax.tree.leaves(gradients)], axis=1)
        mean = np.abs(by_batch.mean(axis=0))
        sensitivity_se = by_batch.std(axis=0, ddof=1) / np.sqrt(BATCHES) / np.maximum(mean, 1e-3 * mean.max())
        value_points.append(Point("objective J (exact constraints)", setting, paths, value_se,
                                  {"seconds": value_timing.median_seconds}))
        sensitivity_points.append(Point(f"{by_batch.shape[1]} sensitivities (median)", setting, paths,
                                        float(np.median(sensitivity_se)), {"seconds": timing.median_seconds}))
        time_points += [Point("objective J (exact constraints)", setting, value_timing.median_seconds, value_se,
                              {"compile_seconds": value_timing.compile_seconds}),
                        Point(f"J and every sensitivity, {BATCHES} reverse passes", setting, timing.median_seconds,
                              float(np.median(sensitivity_se)), {"compile_seconds": timing.compile_seconds})]
    return [
        Panel("monte_carlo_alm_se", "ALM: standard error against paths", "paths", "relative standard error",
              value_points + sensitivity_points,
              notes=(f"N = {RISK_FACTORS}, 120 months, one untrained policy; standard errors from {BATCHES} batches of "
                     "the paths, one reverse pass each (sensitivities below 1e-3 of the largest at that scale).")),
        Panel("monte_carlo_alm_time", "ALM: standard error against wall time", "wall time after compile [s]",
              "relative standard error (median over the sensitivities)", time_points),
    ]


def smoothing_study(*, quick: bool, seed: int) -> list[AccuracyStudy]:
    return [AccuracyStudy("smoothing", "Smoothing, ALM: the floor penalty's sharpness",
                          [smoothing_panel(quick, seed)])]


def monte_carlo_study(*, quick: bool, seed: int) -> list[AccuracyStudy]:
    return [AccuracyStudy("monte-carlo", "Monte Carlo, ALM: paths against standard error and time",
                          monte_carlo_panels(quick, seed))]
