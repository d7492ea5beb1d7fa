"""SNAPO against least-squares Monte Carlo on the same contract and the same fresh price paths:
both out-of-sample values, hard-evaluated, their paired difference, the perfect-foresight bound,
and the wall time of each method."""

import jax
import numpy as np

from ._inputs import StorageInputs
from ._lsmc import perfect_foresight, value_lsmc
from ._model import spot_prices, stochastic_scene
from ._results import LSMCComparison, standard_error
from ._study import StudySettings, run_study

LSMC_KEY = 7  # folded into the seed: the LSMC fitting paths are neither SNAPO's nor the evaluation's


def lsmc_fit_shocks(settings: StudySettings, n_days: int) -> jax.Array:
    """The normal shocks of LSMC's fitting paths, shape (paths, T): neither SNAPO's training paths
    nor the evaluation paths."""
    return jax.random.normal(jax.random.fold_in(jax.random.key(settings.seed), LSMC_KEY), (settings.paths, n_days))


def compare_with_lsmc(inputs: StorageInputs, settings: StudySettings, *, nodes: int = 101, degree: int = 3,
                      foresight_paths: int = 256) -> LSMCComparison:
    """Run the SNAPO study (`run_study`, stochastic) and value the contract by LSMC with
    regressions fitted on `settings.paths` paths of their own; evaluate LSMC's decision rule on the
    study's evaluation paths (SNAPO's hard schedule on them comes with the study), and the
    perfect-foresight LP on the first `foresight_paths` of them."""
    if not settings.stochastic:
        raise ValueError("the LSMC comparison needs StudySettings(stochastic=True)")
    study = run_study(inputs, settings)
    scene = stochastic_scene()
    eval_prices, _ = spot_prices(inputs, study.evaluation_shocks)
    fit_prices, _ = spot_prices(inputs, lsmc_fit_shocks(settings, inputs.n_days))
    lsmc = value_lsmc(inputs, scene, fit_prices, eval_prices, nodes=nodes, degree=degree)
    schedule = lsmc.pop("schedule")
    snapo_values = np.asarray(study.hard.value)
    difference = snapo_values - np.asarray(schedule.value)
    subset = min(foresight_paths, settings.paths)
    foresight = perfect_foresight(inputs, scene, eval_prices[:subset], progress=settings.progress)
    return LSMCComparison(
        study=study, **lsmc,
        snapo_out_of_sample=float(snapo_values.mean()), snapo_se=standard_error(snapo_values),
        snapo_minus_lsmc=float(difference.mean()), snapo_minus_lsmc_se=standard_error(difference),
        perfect_foresight=float(foresight.mean()), perfect_foresight_se=standard_error(foresight),
        perfect_foresight_paths=subset, snapo_seconds=study.train_seconds + study.gradient_seconds,
        lsmc_inventory_mean=np.asarray(schedule.inventory).mean(0).tolist(), lsmc_schedule=schedule)
