"""Gas storage in `snapo bench accuracy`: study "smoothing" (what the smooth surrogates' sharpness
does to the value, its gradient and the trained policy) and study "monte-carlo" (what paths buy
in standard error, and cost in time), on the built-in sample facility and curve.

- Smoothing, deterministic model, one trained policy (the default basestock head): for each
  sharpness k, the smooth-hard gap |V_k - V_hard| / V_hard; the reverse-pass deltas of V_k against
  central bumps of V_k itself (the adjoint's accuracy) and of V_hard (how well the smooth
  gradient describes the exact value's); and, trained at k, the trained policy's hard value as a
  fraction of the intrinsic LP optimum.
- Monte Carlo, stochastic model, one trained policy: for each path count, the relative standard
  error of the hard value (from the per-path values) and the median relative standard error of
  the 365 deltas (batch means over 8 independent batches), with the wall time of the valuation
  and of the deltas."""

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np

from snapo_ode import AccuracyStudy, Panel, Point, agreement, central_differences, time_function

from ._files import sample_curve, sample_facility
from ._inputs import make_inputs
from ._model import deterministic_scene, stochastic_scene
from ._policy import expected_value, simulate
from ._study import HEAD_TRAINING, StudySettings, run_study

SHARPNESS = (10.0, 30.0, 100.0, 300.0, 1000.0, 3000.0, 10000.0)
BUMP_DAYS = (0, 45, 120, 200, 290, 364)
"""The days whose deltas are bumped (a spread over the year: each bump is two valuations)."""
BATCHES = 8


def _deltas_at(inputs, days):
    """`inputs` with the forward prices on `days` replaced: a function of those prices (n_days,)."""
    def with_prices(prices):
        return eqx.tree_at(lambda i: i.forward_curve, inputs, inputs.forward_curve.at[days].set(prices))
    return with_prices


def smoothing_panels(quick: bool, seed: int) -> list[Panel]:
    inputs = make_inputs(sample_facility(), sample_curve())
    scene = deterministic_scene()
    study = run_study(inputs, StudySettings(seed=seed, progress=False, repeats=1))
    policy, hard = study.policy, study.value_hard
    days = jnp.asarray(BUMP_DAYS)
    with_prices = _deltas_at(inputs, days)
    prices = inputs.forward_curve[days]

    def hard_value(p):
        return expected_value(policy, with_prices(p), scene, sharpness=None)

    hard_bumps = central_differences(jax.jit(hard_value), prices, relative_step=1e-6)
    default = HEAD_TRAINING[study.head]["sharpness"]
    # The sharpness as a traced argument: one program for every k.
    smooth = jax.jit(lambda p, k: expected_value(policy, with_prices(p), scene, sharpness=k))
    value_and_deltas = jax.jit(jax.value_and_grad(lambda i, k: expected_value(policy, i, scene, sharpness=k)))
    gap, gradient = [], []
    for k in SHARPNESS[::2] if quick else SHARPNESS:
        setting = f"k={k:g}"
        value, deltas = value_and_deltas(inputs, jnp.asarray(k))
        adjoint = np.asarray(deltas.forward_curve)[np.asarray(days)]
        gap.append(Point("smooth - hard, relative", setting, k, abs(float(value) - hard) / abs(hard)))
        smooth_bumps = central_differences(smooth, prices, jnp.asarray(k), relative_step=1e-6)
        gradient.append(Point("adjoint vs bumps of the smooth value", setting, k,
                              agreement(adjoint, smooth_bumps, floor=1.0).max_rel_diff))
        gradient.append(Point("adjoint vs bumps of the hard value", setting, k,
                              agreement(adjoint, hard_bumps, floor=1.0).max_rel_diff))
    panels = [
        Panel("smoothing_gas_gap", "Gas storage: the smooth-hard gap of one trained policy", "sharpness k",
              "|smooth - hard| / hard value", gap,
              notes=f"The library trains the {study.head} head at k = {default:g} (hard value {hard:,.0f} $)."),
        Panel("smoothing_gas_gradient", "Gas storage: the smooth value's deltas against central bumps", "sharpness k",
              f"max |difference| / max |delta| over {len(BUMP_DAYS)} days", gradient,
              notes=("Differences are relative to the largest of the bumped deltas. Against bumps of the smooth value "
                     "it differentiates, the adjoint's difference is the bumps' own error (step 1e-6 of the price; "
                     "it grows with k, the surrogate's curvature); against bumps of the hard value (the exact "
                     "constraints' deltas, which jump where the schedule changes) it measures how far the smooth "
                     "deltas are from the exact ones.")),
    ]
    if not quick:
        outcome = []
        for k in (30.0, 100.0, 300.0, 1000.0):
            trained = run_study(inputs, StudySettings(seed=seed, progress=False, repeats=1, sharpness=k))
            outcome.append(Point("trained policy's hard value / LP", f"k={k:g}", k, trained.hard_to_lp_ratio))
        panels.append(Panel("smoothing_gas_training", "Gas storage: trained at sharpness k, valued hard", "sharpness k",
                            "hard value / intrinsic LP optimum", outcome, log_y=False,
                            notes=f"Each point trains from the same seed at k (default {default:g})."))
    return panels


def monte_carlo_panels(quick: bool, seed: int) -> list[Panel]:
    inputs = make_inputs(sample_facility(), sample_curve(), volatility=0.5, mean_reversion=2.0)
    scene = stochastic_scene()
    settings = StudySettings(stochastic=True, paths=256, seed=seed, progress=False, repeats=1,
                             **({"train_steps": 100} if quick else {}))
    policy = run_study(inputs, settings).policy
    key = jax.random.key(seed + 1)
    value_points, delta_points, time_points = [], [], []
    for paths in (256, 1024, 4096) if quick else (256, 1024, 4096, 16384):
        setting = f"paths={paths}"
        shocks = jax.random.normal(jax.random.fold_in(key, paths), (paths, inputs.n_days))
        per_path = jax.jit(lambda s: simulate(policy, inputs, scene, sharpness=None, shocks=s).value)
        value_timing, values = time_function(per_path, shocks, repeats=3)
        values = np.asarray(values)
        relative_se = values.std(ddof=1) / np.sqrt(paths) / abs(values.mean())
        batch = shocks.reshape(BATCHES, paths // BATCHES, inputs.n_days)
        deltas = jax.jit(jax.vmap(jax.grad(lambda i, s: expected_value(policy, i, scene, sharpness=200.0, shocks=s)),
                                  in_axes=(None, 0)))
        delta_timing, gradients = time_function(deltas, inputs, batch, repeats=1)
        by_batch = np.asarray(gradients.forward_curve)  # (BATCHES, n_days)
        delta_se = by_batch.std(axis=0, ddof=1) / np.sqrt(BATCHES) / np.maximum(np.abs(by_batch.mean(axis=0)), 1e-12)
        value_points.append(Point("hard value", setting, paths, relative_se, {"seconds": value_timing.median_seconds}))
        delta_points.append(Point("365 deltas (median)", setting, paths, float(np.median(delta_se)),
                                  {"seconds": delta_timing.median_seconds}))
        time_points += [Point("hard value", setting, value_timing.median_seconds, relative_se),
                        Point("365 deltas, 8 reverse passes", setting, delta_timing.median_seconds,
                              float(np.median(delta_se)))]
    return [
        Panel("monte_carlo_gas_se", "Stochastic gas storage: standard error against paths", "paths",
              "relative standard error", value_points + delta_points,
              notes="The standard error falls like 1 / sqrt(paths): a 10x smaller error costs 100x the paths."),
        Panel("monte_carlo_gas_time", "Stochastic gas storage: standard error against wall time",
              "wall time after compile [s]", "relative standard error", time_points),
    ]


def smoothing_study(*, quick: bool, seed: int) -> list[AccuracyStudy]:
    return [AccuracyStudy("smoothing", "Smoothing: sharpness against gap, gradient accuracy and training outcome",
                          smoothing_panels(quick, seed))]


def monte_carlo_study(*, quick: bool, seed: int) -> list[AccuracyStudy]:
    return [AccuracyStudy("monte-carlo", "Monte Carlo: paths against standard error and time",
                          monte_carlo_panels(quick, seed))]

