"""SNAPO against least-squares Monte Carlo on the same contract and the same fresh price paths:
both out-of-sample values, hard-evaluated, their paired difference, the perfect-foresight and
dual upper bounds with each policy's duality gap, the deltas of both, and the wall time of
each method."""

import jax
import numpy as np

from snapo_ode import InputError, agreement

from ._certificate import duality_gaps, intrinsic_schedule, lsmc_deltas
from ._inputs import StorageInputs
from ._lsmc import perfect_foresight, value_lsmc
from ._model import largest_flows, spot_prices, stochastic_scene
from ._paths import PricePaths
from ._results import LSMCComparison, standard_error
from ._study import StudySettings, run_study

LSMC_KEY = 7  # folded into the seed: the LSMC fitting paths are neither SNAPO's nor the evaluation's


def lsmc_fit_shocks(settings: StudySettings, n_days: int) -> jax.Array:
    """The normal shocks of LSMC's fitting paths, shape (paths, T): neither SNAPO's training paths
    nor the evaluation paths."""
    return jax.random.normal(jax.random.fold_in(jax.random.key(settings.seed), LSMC_KEY), (settings.paths, n_days))


def check_grid_trades(inputs: StorageInputs, nodes: int) -> None:
    """Refuse, before any compile, an LSMC grid whose step exceeds the largest daily injection
    (after fuel loss) or withdrawal: a day's trade would then end between two levels of the
    continuation values, which interpolation alone would price."""
    spacing = float(inputs.capacity) / (nodes - 1)
    largest = dict(zip(("injection", "withdrawal"), largest_flows(inputs, stochastic_scene())))
    verbs = {"injection": "inject", "withdrawal": "withdraw"}
    for flow, amount in largest.items():
        if amount < spacing:
            needed = int(np.ceil(float(inputs.capacity) / amount)) + 1
            on_grid = lambda n: abs(float(inputs.initial_inventory) * (n - 1) / float(inputs.capacity)  # noqa: E731
                                    - round(float(inputs.initial_inventory) * (n - 1) / float(inputs.capacity))) < 1e-9
            needed = next((n for n in range(needed, needed + 10_000) if on_grid(n)), needed)
            raise InputError(f"lsmc_nodes = {nodes} makes the inventory grid step {spacing:,.0f}, more than the largest "
                             f"daily {flow} ({amount:,.0f}): a day's {flow} would end between two levels of the "
                             f"continuation values (no level to {verbs[flow]} to). Use "
                             f"--lsmc-nodes {needed} or more (allowed: a step no larger than a day's flow).")


def trading_nodes(inputs: StorageInputs, at_least: int, per_flow: int = 1) -> int:
    """The fewest levels, `at_least` or more, with `per_flow` steps or more to a day's largest
    injection (after fuel loss) and to its largest withdrawal (one: what `check_grid_trades` asks)."""
    smallest = min(largest_flows(inputs, stochastic_scene()))
    return max(at_least, int(np.ceil(per_flow * float(inputs.capacity) / smallest * (1 + 1e-12))) + 1)


def compare_with_lsmc(inputs: StorageInputs, settings: StudySettings, *, nodes: int = 101, degree: int = 3,
                      foresight_paths: int = 256, lattice_points: int = 200, training_paths: PricePaths | None = None,
                      evaluation_paths: PricePaths | None = None) -> LSMCComparison:
    """Run the SNAPO study (`run_study`, stochastic) and value the contract by LSMC with
    regressions fitted on `settings.paths` paths of their own; evaluate LSMC's decision rule on the
    study's evaluation paths (SNAPO's hard schedule on them comes with the study), the
    perfect-foresight LP on the first `foresight_paths` of them, and the dual bound, the gaps and
    the deltas on all of them (`_certificate.py`). With a desk's own paths (`training_paths`,
    `evaluation_paths`), SNAPO trains and LSMC regresses on the first, and both are valued on the
    second; the bound is then checked to have a penalty of mean zero on them (`_certificate.py`)."""
    if not settings.stochastic:
        raise ValueError("the LSMC comparison needs StudySettings(stochastic=True)")
    check_grid_trades(inputs, nodes)
    study = run_study(inputs, settings, training_paths=training_paths, evaluation_paths=evaluation_paths)
    scene = stochastic_scene()
    eval_prices, _ = spot_prices(inputs, study.evaluation_shocks)
    fit_prices, _ = spot_prices(inputs, lsmc_fit_shocks(settings, inputs.n_days) if training_paths is None
                                else training_paths)
    lsmc = value_lsmc(inputs, scene, fit_prices, eval_prices, nodes=nodes, degree=degree)
    schedule, fit, grid = lsmc.pop("schedule"), lsmc.pop("fit"), lsmc.pop("grid")
    snapo_values = np.asarray(study.hard.value)
    difference = snapo_values - np.asarray(schedule.value)
    subset = min(foresight_paths, eval_prices.shape[0])
    foresight = perfect_foresight(inputs, scene, eval_prices[:subset], progress=settings.progress)
    policies = {"snapo": study.hard, "lsmc": schedule,
                "intrinsic": intrinsic_schedule(inputs, scene, study.intrinsic, eval_prices)}
    gaps = duality_gaps(inputs, scene, grid, study.evaluation_shocks, policies, lattice_points=lattice_points)
    deltas = lsmc_deltas(fit, inputs, scene, grid, study.evaluation_shocks, lsmc["lsmc_fit_seconds"],
                         lsmc["lsmc_eval_seconds"])
    return LSMCComparison(
        study=study, **lsmc, **gaps, **deltas,
        snapo_out_of_sample=float(snapo_values.mean()), snapo_se=standard_error(snapo_values),
        snapo_minus_lsmc=float(difference.mean()), snapo_minus_lsmc_se=standard_error(difference),
        perfect_foresight=float(foresight.mean()), perfect_foresight_se=standard_error(foresight),
        perfect_foresight_paths=subset,
        # Wall time from the start of training to the T deltas: the first (compiling) reverse pass too.
        snapo_seconds=study.train_wall_seconds + study.compile_breakdown["gradient"] + study.gradient_seconds,
        lsmc_inventory_mean=np.asarray(schedule.inventory).mean(0).tolist(), lsmc_schedule=schedule,
        deltas_snapo_vs_lsmc=agreement(np.asarray(study.deltas), np.asarray(deltas["lsmc_pathwise_deltas"])).normwise)
