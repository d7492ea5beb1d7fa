"""The ALM report's check of its sensitivities against central bump-and-revalue on a sample of
them: a fund's own set has hundreds of risk factors and thousands of long paths, where bumping
every one (2N revaluations) takes longer than the report itself. The sample is seeded and always
holds the largest sensitivities (those a reader acts on); the rest are drawn at random."""

import time

import equinox as eqx
import jax.numpy as jnp
import numpy as np
from tqdm.auto import tqdm

from snapo_ode import flatten_inputs
from snapo_ode._verification import bump_steps

from ._sensitivities import BUMP_RELATIVE_STEP, objective_of_reported

DEFAULT_BUMP_SAMPLE = 20
FLOOR = 1e-8  # as `snapo_ode.agreement`: an entry below FLOOR x the largest is compared at that scale


def sample_indices(gradient: np.ndarray, size: int, seed: int) -> np.ndarray:
    """`size` indices of `gradient` (shape (n,)), sorted: the largest quarter of them (at least
    one) by |gradient|, the rest drawn without replacement from the others with `seed`; all of
    them when `size >= n`."""
    n = gradient.size
    if size >= n:
        return np.arange(n)
    largest = np.argsort(-np.abs(gradient), kind="stable")[:max(1, size // 4)]
    others = np.setdiff1d(np.arange(n), largest)
    drawn = np.random.default_rng(seed).choice(others, size - largest.size, replace=False)
    return np.sort(np.concatenate([largest, drawn]))


def sampled_bump_check(study, policy, shocks, gradient, flat_names: list[str], *, size: int = DEFAULT_BUMP_SAMPLE,
                       seed: int = 0, progress: bool = True) -> dict:
    """The adjoint `gradient` (a pytree like `study.reported`) against central differences of
    the smooth objective on `size` of its entries (`sample_indices`), one revaluation pair
    after another with a progress bar.

    **Returns:** a dict `bump_checked` (how many), `bump_total` (N), `max_rel_diff` (the worst
    relative difference over the sample, as `snapo_ode.agreement` measures it), `worst_factor`
    (its name), `bump_seconds` (the sample's wall time) and `checked` (name -> adjoint, bumped,
    relative difference)."""
    fn = objective_of_reported(study.problem, study.fixed, mesh=None)
    flat, rebuild = flatten_inputs(study.reported)
    adjoint = np.asarray(flatten_inputs(gradient)[0])
    steps = bump_steps(np.asarray(flat), BUMP_RELATIVE_STEP)
    value = eqx.filter_jit(lambda vector, policy, shocks: fn(rebuild(vector), policy, shocks))
    indices = sample_indices(adjoint, size, seed)
    scale_floor = FLOOR * np.max(np.abs(adjoint), initial=0.0)
    checked, worst, worst_name = {}, 0.0, None
    began = time.perf_counter()
    for k in tqdm(indices, desc="bump check", disable=not progress, leave=False):
        bump = jnp.zeros_like(flat).at[k].set(steps[k])
        bumped = (float(value(flat + bump, policy, shocks)) - float(value(flat - bump, policy, shocks))) / (2 * steps[k])
        difference = abs(adjoint[k] - bumped)
        relative = 0.0 if difference == 0 else difference / max(abs(bumped), scale_floor)
        name = flat_names[k]
        checked[name] = {"adjoint": float(adjoint[k]), "bumped": bumped, "relative_difference": relative}
        if relative >= worst:
            worst, worst_name = relative, name
    return {"bump_checked": int(indices.size), "bump_total": int(adjoint.size), "max_rel_diff": worst,
            "worst_factor": worst_name, "bump_seconds": time.perf_counter() - began, "checked": checked}
