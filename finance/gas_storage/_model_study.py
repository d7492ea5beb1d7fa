"""Storage on a desk's own price model: every method on the same paths, in any dimension.

On training paths (a price model's simulation, or a paths file) LSMC regresses on the model's
state (`_state_lsmc.py`) and the SNAPO policy trains, started on the LSMC's targets
(`_state_policy.py`); on separate evaluation paths the intrinsic schedule, rolling intrinsic
(`_rolling_intrinsic.py`, on the first `rolling_paths`), LSMC and SNAPO are valued hard, paired;
the dual bound (`_dual.py`) with the state penalty (`_state_penalty.py`, fitted on the training
paths) bounds every non-anticipative policy from above (on the finest grid affordable on a few
paths, estimated by a correction to the grid affordable on all: `_bound`), each policy's gap
with the penalty as a control variate; SNAPO's and LSMC's forward-curve deltas come from one reverse pass each.

The bound is certified as `_certificate.certify` says (pathwise and mean checks) and, where the
evaluation paths come from a file, only if the penalty the intrinsic schedule pays has mean
zero on them (`penalty_mean_check`): otherwise its fields are null, with a warning.
"""

import time

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np

import snapo_ode
from snapo_ode import time_once

from ._certificate import _clear_bound, certify, intrinsic_schedule, pathwise_failures, penalty_mean_check
from ._dual import DUAL_WORK, dual_bound, relaxed_grid, schedule_penalty
from ._inputs import StorageInputs, check_positive_prices
from ._lp import solve_intrinsic
from ._lsmc import inventory_grid
from ._model import deterministic_scene, spot_prices, stochastic_scene
from ._model_lattice import lattice_points, solve_model_lattice
from ._model_lattice_penalty import (
    BLEND_WEIGHT,
    PILOT_PATHS,
    ModelLatticePenalty,
    penalty_lattices,
    pilot_gaps,
    tightest,
)
from ._paths import PricePaths
from ._penalty import BlendedPenalty
from ._price_models import AbstractPriceModel, model_paths
from ._results import standard_error
from ._rolling_intrinsic import rolling_intrinsic
from ._state_lsmc import fit_state_lsmc, run_state_lsmc, state_lsmc_value_and_deltas
from ._state_penalty import fit_state_lsmc_and_penalty
from ._state_policy import chosen_start, simulate_state_policy
from ._versus_lsmc import trading_nodes

STATE_DEGREE = 2  # the state LSMC's default total degree (`value_on_model`; `--lsmc-degree` sets it)
LEVELS_PER_FLOW = 4  # the state LSMC's default grid: steps to a day's full flow (`value_on_model`),
NODES_AT_LEAST = 101  # and this many levels at least
MODEL_TRAINING = dict(train_paths=512, train_steps=300, learning_rate=3e-3, sharpness=1000.0)
DUAL_PATHS = 2_000  # the bound runs on the first this many evaluation paths (its grid's work)
CORRECTION_PATHS = 250  # and its finer grid's correction on the first this many (`_bound`)
ROLLING_PATHS = 500  # rolling intrinsic on the first this many evaluation paths (its work grows as T^2)
# SNAPO chooses its start on, and draws its minibatches from, the first this many training paths:
# the start's targets are computed once for each, the larger cost of a long contract's start
# (docs/dev/gas_storage_notes.md, "The 60-second row": a smaller pool trains worse).
TRAINING_POOL = 10_000


def _paired(a, b) -> tuple[float, float]:
    difference = np.asarray(a) - np.asarray(b)
    return float(difference.mean()), standard_error(difference)


def value_on_model(model: AbstractPriceModel | None, inputs: StorageInputs, training: PricePaths,
                   evaluation: PricePaths, *, nodes: int | None = None, degree: int = STATE_DEGREE, seed: int = 0,
                   train_steps: int | None = None, train_paths: int | None = None, rolling_paths: int = ROLLING_PATHS,
                   dual_paths: int = DUAL_PATHS, external: bool = False, progress: bool = False) -> dict:
    """Every method on `training` / `evaluation` paths (module docstring); `model` None (a paths
    file without a price model): no rolling intrinsic and no bound (null, with a warning).
    `nodes`: the LSMC's inventory levels; None: LEVELS_PER_FLOW steps to a day's full injection
    and withdrawal, NODES_AT_LEAST levels at least (a slow facility trades fractions of a day's flow:
    docs/gas_storage.md).
    Returns the JSON-ready figures, and under `"policy"` the trained `StatePolicy`."""
    check_positive_prices(inputs)
    scene = stochastic_scene()
    settings = dict(MODEL_TRAINING, **{k: v for k, v in dict(train_steps=train_steps, train_paths=train_paths).items()
                                       if v is not None})
    grid = inventory_grid(inputs, scene, trading_nodes(inputs, NODES_AT_LEAST, LEVELS_PER_FLOW) if nodes is None else nodes)
    warnings = []
    intrinsic = solve_intrinsic(inputs, deterministic_scene())
    eval_prices = spot_prices(inputs, evaluation)[0]
    # LSMC on the training paths, valued with its deltas on the evaluation paths.
    bounded = model is not None and evaluation.factors is not None and training.factors is not None
    start = time.perf_counter()
    if bounded:  # the bound's penalty regressed in the same backward pass (`fit_state_lsmc_and_penalty`)
        fit, penalty = fit_state_lsmc_and_penalty(model, inputs, scene, grid, training, degree)
    else:
        fit, penalty = fit_state_lsmc(inputs, scene, grid, training, degree), None
    lsmc_fit_seconds = time.perf_counter() - start
    lsmc_value, lsmc_deltas = state_lsmc_value_and_deltas(fit, inputs, scene, grid, evaluation)
    lsmc = run_state_lsmc(fit, inputs, scene, grid, evaluation)
    # SNAPO, started on the better on its pool of training paths of the LSMC's and the factor lattice's
    # targets, trained on samples of the pool.
    start = time.perf_counter()
    pool = training[:TRAINING_POOL]
    points = lattice_points(model, inputs, scene, grid) if bounded else None
    lattices = penalty_lattices(model, inputs, scene, grid, points) if bounded else []
    # One lattice for both, its tables kept, where the penalty's only lattice is the start's.
    shared = points is not None and len(lattices) == 1 and lattices[0][1] is grid and lattices[0][0] == points
    lattice = None if points is None else solve_model_lattice(model, inputs, scene, grid, points, keep_values=shared)
    # The policy carries the lattice's targets only: its value tables would ride in the optimiser and the saved file.
    start_lattice = None if lattice is None else lattice._replace(values=None)
    policy, train_start, starts = chosen_start(start_lattice, fit, inputs, scene, grid, pool, seed)
    out_start = dict(starts, lattice_points=points, start_seconds=time.perf_counter() - start)
    scale = float(inputs.capacity * jnp.mean(jnp.abs(inputs.forward_curve)))

    start = time.perf_counter()
    # The start's targets depend on the paths alone: computed once for every pool and evaluation path.
    eval_start = eqx.filter_jit(policy.start_logits)(inputs, scene, evaluation)

    def loss(policy, step_key, data):
        paths, start = data
        rows = jax.random.randint(step_key, (settings["train_paths"],), 0, paths.shape[0])
        value = jnp.mean(simulate_state_policy(policy, inputs, scene, paths[rows], sharpness=settings["sharpness"],
                                               start=start[rows]).value)
        return -value / scale, {"value": value}

    untrained = policy
    trained = snapo_ode.train(loss, policy, steps=settings["train_steps"], learning_rate=settings["learning_rate"],
                              key=jax.random.fold_in(jax.random.key(seed), 1), progress=progress,
                              description="training storage policy (price model)", data=(pool, train_start))
    policy = trained.params

    @eqx.filter_jit
    def smooth_value_and_deltas(policy, inputs, paths, start):
        def value(curve):
            moved = eqx.tree_at(lambda i: i.forward_curve, inputs, curve)
            return jnp.mean(simulate_state_policy(policy, moved, scene, paths, sharpness=settings["sharpness"],
                                                  start=start).value)
        return jax.value_and_grad(value)(inputs.forward_curve)

    snapo_smooth, snapo_deltas = smooth_value_and_deltas(policy, inputs, evaluation, eval_start)
    snapo_seconds = time.perf_counter() - start
    # The report's hard values, on the evaluation paths: the start untrained, and the trained policy.
    start = time.perf_counter()
    hard = eqx.filter_jit(simulate_state_policy)
    start_schedule, snapo = (hard(p, inputs, scene, evaluation, sharpness=None, start=eval_start)
                             for p in (untrained, policy))
    out_start["snapo_valuation_seconds"] = time.perf_counter() - start
    policies = {"snapo": snapo, "lsmc": lsmc, "intrinsic": intrinsic_schedule(inputs, scene, intrinsic, eval_prices)}
    out = {
        "price_model": None if model is None else type(model).__name__, "paths": evaluation.shape[0],
        "train_paths_available": training.shape[0], "snapo_train_pool": pool.shape[0], "intrinsic_lp": intrinsic.value,
        "lsmc_out_of_sample": float(np.mean(lsmc.value)), "lsmc_se": standard_error(lsmc.value),
        "lsmc_in_sample": float(np.mean(fit.values)), "lsmc_degree": degree, "lsmc_nodes": grid.nodes,
        "lsmc_fit_seconds": lsmc_fit_seconds, "lsmc_pathwise_deltas": np.asarray(lsmc_deltas).tolist(),
        "snapo_start_out_of_sample": float(np.mean(start_schedule.value)),
        "snapo_out_of_sample": float(np.mean(snapo.value)), "snapo_se": standard_error(snapo.value),
        "snapo_smooth": float(snapo_smooth), "deltas": np.asarray(snapo_deltas).tolist(),
        "snapo_seconds": snapo_seconds, "training_settings": settings, **out_start,
    }
    out["snapo_minus_lsmc"], out["snapo_minus_lsmc_se"] = _paired(snapo.value, lsmc.value)
    out["snapo_minus_intrinsic"], out["snapo_minus_intrinsic_se"] = _paired(snapo.value, policies["intrinsic"].value)
    if not bounded:
        warnings.append("no price model with the paths' factors: rolling intrinsic and the dual bound need its "
                        "conditional expectations; their fields are null")
        out.update(rolling_intrinsic=None, snapo_minus_rolling=None, dual_upper_bound=None, snapo_gap=None,
                   lsmc_gap=None)
        return {**out, "warnings": warnings, "policy": policy}
    # Rolling intrinsic on the first rolling_paths evaluation paths, paired with SNAPO on them.
    count = min(rolling_paths, evaluation.shape[0])
    rolling_seconds, rolling = time_once(rolling_intrinsic, model, inputs, scene, grid, evaluation[:count])
    out.update(rolling_intrinsic=float(np.mean(rolling.value)), rolling_intrinsic_se=standard_error(rolling.value),
               rolling_paths=count, rolling_every_days=1, rolling_seconds=rolling_seconds)
    out["snapo_minus_rolling"], out["snapo_minus_rolling_se"] = _paired(np.asarray(snapo.value)[:count], rolling.value)
    policies["rolling_intrinsic"] = rolling
    start = time.perf_counter()
    penalty, choice = _chosen_penalty(penalty, lattices, lattice if shared else None, model, fit, inputs, scene, grid,
                                      seed, min(dual_paths, evaluation.shape[0]))
    out.update(choice, penalty_choice_seconds=time.perf_counter() - start)
    out.update(_bound(penalty, inputs, scene, grid, evaluation, policies, dual_paths, external))
    warnings += out.pop("bound_warnings")
    return {**out, "warnings": warnings, "policy": policy}


def _chosen_penalty(state, lattices, shared, model, fit, inputs, scene, grid, seed, count):
    """The bound's penalty: the state LSMC's `state`, the factor lattices' (`lattices`: (points,
    inventory grid), `penalty_lattices`; `shared`: the start's lattice, solved, where it is the
    only one) or the even blend of the state's and the better lattice's (`BlendedPenalty`),
    whichever bounds the LSMC `fit`'s rule most tightly on fresh paths of the model (PILOT_PATHS,
    no more than the bound's `count`), on the grid the bound takes for `count` evaluation paths
    (`pilot_gaps`). The lattices are solved one at a time, the better kept. Returns the penalty
    and the JSON fields of the choice: the pilot's candidates are "state", "lattice" (on the
    LSMC's grid), "lattice_per_flow" (on a grid of its own) and "blend";
    `penalty_lattice_points` and `penalty_lattice_levels` are those of the better lattice."""
    if not lattices:
        return state, {"dual_penalty_choice": "state", "penalty_lattice_points": None, "penalty_lattice_levels": None,
                       "penalty_pilot_paths": None, "penalty_pilot_bounds": None, "penalty_pilot_gaps": None,
                       "penalty_pilot_gap_difference_se": None}
    pilot = model_paths(model, inputs.forward_curve, min(PILOT_PATHS, count), jax.random.fold_in(jax.random.key(seed), 2))
    relaxed = relaxed_grid(inputs, scene, paths=count, work=DUAL_WORK)
    reference = run_state_lsmc(fit, inputs, scene, grid, pilot)
    bounds, gaps, penalties = {}, {}, {"state": state}
    bounds["state"], gaps["state"] = pilot_gaps(state, inputs, scene, grid, pilot, relaxed, reference)
    better = None
    for points, own in lattices:
        name = "lattice" if own is grid else "lattice_per_flow"
        solved = shared if shared is not None else solve_model_lattice(model, inputs, scene, own, points,
                                                                       keep_values=True)
        lattice = ModelLatticePenalty(model, solved, own, grid)
        bounds[name], gaps[name] = pilot_gaps(lattice, inputs, scene, grid, pilot, relaxed, reference)
        if better is None or gaps[name].mean() < gaps[better[0]].mean():
            better = name, lattice, points, own
        del solved, lattice  # a losing lattice's tables are freed before the next is solved
    name, penalties[name], points, own = better
    penalties["blend"] = BlendedPenalty(state, penalties[name], BLEND_WEIGHT)
    bounds["blend"], gaps["blend"] = pilot_gaps(penalties["blend"], inputs, scene, grid, pilot, relaxed, reference)
    chosen, difference_se = tightest(gaps)
    return penalties[chosen], {
        "dual_penalty_choice": chosen if chosen in ("state", "blend") else "lattice", "penalty_lattice_points": points,
        "penalty_lattice_levels": own.nodes, "penalty_pilot_paths": pilot.shape[0],
        "penalty_pilot_bounds": {k: float(v.mean()) for k, v in bounds.items()},
        "penalty_pilot_gaps": {k: float(v.mean()) for k, v in gaps.items()},
        "penalty_pilot_gap_difference_se": difference_se}


def _bound(penalty, inputs, scene, grid, evaluation, policies, dual_paths, external) -> dict:
    """The dual bound with `penalty` on the first `dual_paths` evaluation paths, each
    policy's value with the penalty as control variate and its gap, and the checks.

    The bound estimated is the one on the finest grid affordable on the first CORRECTION_PATHS
    of them (`fine`), by a two-level estimator (Giles 2008): the mean on all paths of the bound
    on the grid affordable there (`control`) plus the mean, on the first CORRECTION_PATHS, of
    the difference between the two grids' bounds. Both grids are fixed before any path is seen,
    so this is an unbiased estimate of E[fine bound], a valid upper bound whose relaxation is
    the finer grid's; the difference varies little from path to path (the same prices and
    penalty), so its standard error adds little to the control's. Each grid is checked path
    by path against every policy's cash less that grid's penalty."""
    start = time.perf_counter()
    count = min(dual_paths, evaluation.shape[0])
    paths = evaluation[:count]
    prices = spot_prices(inputs, paths)[0]
    few = min(count, CORRECTION_PATHS)
    control = relaxed_grid(inputs, scene, paths=count, work=DUAL_WORK)
    fine = relaxed_grid(inputs, scene, paths=few, work=DUAL_WORK)
    upper = np.asarray(dual_bound(penalty, inputs, scene, grid, prices, relaxed=control, price_paths=paths).values)
    lowers = _lowers(penalty, inputs, grid, prices, paths, policies, control, count)
    correction, fine_lowers = np.zeros(1), {}
    if fine.relaxation < control.relaxation:
        fine_upper = np.asarray(dual_bound(penalty, inputs, scene, grid, prices[:few], relaxed=fine,
                                           price_paths=paths[:few]).values)
        correction = fine_upper - upper[:few]
        fine_lowers = _lowers(penalty, inputs, grid, prices[:few], paths[:few], policies, fine, few)
    else:
        fine, few = control, 0
    estimate = float(upper.mean() + correction.mean())
    spread = float(np.hypot(standard_error(upper), standard_error(correction)))
    out = {"dual_upper_bound": estimate, "dual_upper_bound_se": spread,
           "dual_penalty": f"{penalty.label}, exact conditional means under "
                           f"{type(penalty.model).__name__}",
           "dual_paths": count, "dual_grid_nodes": fine.nodes, "dual_relaxation": fine.relaxation,
           "dual_control_grid_nodes": control.nodes, "dual_control_relaxation": control.relaxation,
           "dual_correction_paths": few, "dual_correction": float(correction.mean()),
           "dual_correction_se": standard_error(correction)}
    for name, (cash, lower) in lowers.items():
        margin = upper[:cash.size] - lower
        out.update({f"{name}_value_control_variate": float(lower.mean()),
                    f"{name}_value_control_variate_se": standard_error(lower),
                    f"{name}_gap": float(margin.mean() + correction.mean()) / estimate,
                    f"{name}_gap_se": float(np.hypot(standard_error(margin), standard_error(correction))) / estimate})
    out.update(_paired_with_penalty(lowers))
    # certify compares every policy path by path on the bound's paths: rolling intrinsic has fewer.
    full = {name: pair for name, pair in lowers.items() if pair[0].size == upper.size}
    warnings = certify(out, upper, full, fine.relaxation)
    if fine_lowers and out["dual_upper_bound"] is not None:
        failures = pathwise_failures(fine_upper, {name: pair for name, pair in fine_lowers.items()
                                                  if pair[0].size == few})
        if failures:
            _clear_bound(out)
        warnings += failures
    if external:
        warnings += penalty_mean_check(out, *lowers["intrinsic"])
    out["dual_seconds"] = time.perf_counter() - start
    return {**out, "bound_warnings": warnings}


def _paired_with_penalty(lowers: dict) -> dict:
    """SNAPO less LSMC and less rolling intrinsic, paired path by path on each policy's cash less
    the penalty it pays (`_lowers`): the penalty has mean zero for every non-anticipative policy,
    so each difference is an unbiased estimate of the values' difference, and much of the paths'
    common noise (what the spot did, which every policy trades on) cancels in it.
    `snapo_minus_<other>_control_variate` and `_se`, where both were valued."""
    out = {}
    for name, short in (("lsmc", "lsmc"), ("rolling_intrinsic", "rolling")):
        if "snapo" in lowers and name in lowers:
            other = lowers[name][1]
            out[f"snapo_minus_{short}_control_variate"], out[f"snapo_minus_{short}_control_variate_se"] = _paired(
                lowers["snapo"][1][:other.size], other)
    return out


def _lowers(penalty, inputs, grid, prices, paths, policies, relaxed, count) -> dict:
    """Each policy's (cash, cash - penalty) per path on the first `count` paths (fewer where it
    was valued on fewer), the penalty interpolated on `relaxed` as the bound on it charges it."""
    lowers = {}
    for name, schedule in policies.items():
        used = min(count, schedule.value.shape[0])
        cash = np.asarray(schedule.value)[:used]
        paid = np.asarray(schedule_penalty(penalty, inputs, grid, prices[:used], schedule.inventory[:used], relaxed,
                                           paths[:used]))
        lowers[name] = (cash, cash - paid)
    return lowers

