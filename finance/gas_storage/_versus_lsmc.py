"""SNAPO against least-squares Monte Carlo on the same contract and the same fresh price paths:
both out-of-sample values, hard-evaluated, their paired difference, the perfect-foresight bound,
and the wall time of each method."""

import jax
import numpy as np

from ._inputs import StorageInputs
from ._lsmc import perfect_foresight, value_lsmc
from ._model import simulate, spot_prices, stochastic_scene
from ._study import StudySettings, evaluation_shocks, run_study, standard_error

LSMC_KEY = 7  # folded into the seed: the LSMC fitting paths are neither SNAPO's nor the evaluation's


def compare_with_lsmc(inputs: StorageInputs, settings: StudySettings, *, nodes: int = 101, degree: int = 3,
                      foresight_paths: int = 256) -> tuple[dict, object]:
    """Run the SNAPO study (`run_study`, stochastic) and value the contract by LSMC with
    regressions fitted on `settings.paths` paths of their own; evaluate both decision rules on
    the study's evaluation paths, and the perfect-foresight LP on the first `foresight_paths`.

    Returns the study's result extended with `lsmc_in_sample, lsmc_out_of_sample, lsmc_se,
    snapo_out_of_sample, snapo_se, snapo_minus_lsmc, snapo_minus_lsmc_se` (paired, same paths),
    `perfect_foresight, perfect_foresight_se, perfect_foresight_paths` [$], and timings
    `lsmc_fit_seconds` (the valuation), `lsmc_eval_seconds`, `lsmc_compile_seconds`,
    `snapo_seconds` (training after compile + one reverse pass for every delta); and the policy.
    """
    if not settings.stochastic:
        raise ValueError("the LSMC comparison needs StudySettings(stochastic=True)")
    result, policy = run_study(inputs, settings)
    scene = stochastic_scene()
    eval_shocks = evaluation_shocks(settings, inputs.n_days)
    eval_prices, _ = spot_prices(inputs, eval_shocks)
    fit_key = jax.random.fold_in(jax.random.key(settings.seed), LSMC_KEY)
    fit_prices, _ = spot_prices(inputs, jax.random.normal(fit_key, (settings.paths, inputs.n_days)))
    lsmc = value_lsmc(inputs, scene, fit_prices, eval_prices, nodes=nodes, degree=degree)
    lsmc_schedule = lsmc.pop("schedule")
    snapo_values = np.asarray(simulate(policy, inputs, scene, sharpness=None, shocks=eval_shocks).value)
    difference = snapo_values - np.asarray(lsmc_schedule.value)
    subset = min(foresight_paths, settings.paths)
    foresight = perfect_foresight(inputs, scene, eval_prices[:subset], progress=settings.progress)
    result.update(lsmc)
    result.update(
        snapo_out_of_sample=float(snapo_values.mean()),
        snapo_se=standard_error(snapo_values),
        snapo_minus_lsmc=float(difference.mean()),
        snapo_minus_lsmc_se=standard_error(difference),
        perfect_foresight=float(foresight.mean()),
        perfect_foresight_se=standard_error(foresight),
        perfect_foresight_paths=subset,
        snapo_seconds=result["train_seconds"] + result["gradient_seconds"],
        lsmc_inventory_mean=np.asarray(lsmc_schedule.inventory).mean(0).tolist(),
    )
    return result, policy
