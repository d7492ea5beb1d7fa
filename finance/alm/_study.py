"""A study: build the fund for N risk factors, train the policy, compare it with fixed mixes on
fresh paths, and measure the sensitivities three ways. Used by `snapo alm`, the notebook and
the tests.

Validation happens in `build_study`, before anything is traced or compiled.
"""

from typing import NamedTuple

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np

import snapo_ode
from snapo_ode import (
    InputError, TrainResult, check_count, check_divisible, compare_with_bumps, generate_sharded, mesh_of,
    per_sample, require_float64, time_function, value_and_sensitivities)

from ._results import ALMStudy, Evaluation, SensitivityMeasurement, funding_ratio_statistics
from ._sensitivities import (
    BUMP_RELATIVE_STEP, BUMP_ROWS_PER_CHUNK, FORWARD_ROWS_PER_CHUNK, PATH_SPECS, chunk_size, objective_of_reported)
from ._factors import (
    GROUPS,
    SCENARIO_GROUPS,
    FactorLayout,
    check_factors,
    default_factors,
    factor_names,
    layout_for,
    named_sensitivities,
    split_reported,
)
from ._market import Market, correlated_shocks, key_tenors
from ._board import BoardSettings, board_figures
from ._fund_file import Fund, fund_holdings
from ._memory import check_size
from ._scenario_file import ScenarioSet
from ._scenarios import batch_drawer, on_devices, scenario_start, split_for_training
from ._model import EFFECTS, ALMConfig, ALMProblem, indexed_share, initial_funding_ratio, initial_values, simulate
from ._baselines import baselines, liability_duration
from ._policy import AbstractRebalancing, NeuralRebalancing


class Study(NamedTuple):
    """`problem`; `reported` (the factors differentiated) and `fixed` (the rest), dicts of
    arrays."""

    problem: ALMProblem
    reported: dict
    fixed: dict

    @property
    def layout(self) -> FactorLayout:
        return self.problem.layout

    @property
    def market(self) -> Market:
        return self.problem.market


def build_study(n_risk_factors: int, *, horizon_months: int = 120, effects=None,
                without=(), config: ALMConfig | None = None, correlation=None,
                factors: dict | None = None) -> Study:
    """The fund with `n_risk_factors` reported factors (see `layout_for`) on default market
    data, or the given `correlation` and `factors`.

    **Raises:** `InputError` naming the field for a bad count, horizon, correlation, factor
    value, effect name or effect parameter.
    """
    require_float64("ALM studies")
    layout = layout_for(n_risk_factors)
    if isinstance(horizon_months, (int, np.integer)):
        check_size(layout, int(horizon_months))
    market = Market(key_tenors(layout.n_tenors), layout.n_equities, correlation=correlation)
    problem = ALMProblem(market, layout, EFFECTS.scene(effects, without=without), config or ALMConfig(), horizon_months)
    if factors is None:
        factors = default_factors(layout, market, indexation=indexed_share(problem.config, problem.scene),
                                  credit=problem.scene.has("credit"))
    return _assembled(problem, factors)


def build_fund_study(fund: Fund, *, horizon_months: int | None = None, effects=None, without=(),
                     scenario_set: ScenarioSet | None = None) -> Study:
    """The study of a fund read from its files (`load_fund`), over its horizon (or
    `horizon_months`), with its effects (or `effects`, less `without`): on the built-in
    generator, every factor group reported (N = key tenors x 2 + indices x 3 + 4 + 5 + liability
    rows, with 4 + 5 read as 4 + (asset classes - 1)); on a given `scenario_set`
    (`load_scenarios`), from the set's starting market, with the key rates, inflation and spread
    reported as shifts of every scenario, the equity levels, liability rows and holdings (N = key
    tenors + indices x 2 + 2 + (asset classes - 1) + liability rows). The holdings follow from the
    fund's assets on that initial market and the study's effects (`fund_holdings`).

    **Raises:** `InputError` as `build_study`, and for a set shorter than the horizon."""
    require_float64("ALM studies")
    market = fund.market
    layout = FactorLayout(market.n_tenors, market.n_equities, fund.schedule.n_rows,
                          GROUPS if scenario_set is None else SCENARIO_GROUPS, len(market.asset_classes) - 1)
    horizon = fund.horizon_months if horizon_months is None else horizon_months
    check_size(layout, horizon)
    scene = EFFECTS.scene(fund.effects if effects is None else effects, without=without)
    factors = dict(fund.factors)
    if scenario_set is not None:
        if scenario_set.months < horizon:
            raise InputError(f"scenario file {scenario_set.source}: {scenario_set.months} months; the horizon is "
                             f"{horizon}.")
        factors.update(scenario_start(scenario_set, market))
    factors["holdings"] = fund_holdings(fund, factors, scene)
    return _assembled(ALMProblem(market, layout, scene, fund.config, horizon, fund.schedule, scenario_set is not None),
                      factors)


def _assembled(problem: ALMProblem, factors: dict) -> Study:
    names = [name for group in factor_names(problem.layout, problem.market, problem.schedule).values() for name in group]
    repeated = sorted({name for name in names if names.count(name) > 1})
    if repeated:
        raise InputError(f"factor name {repeated[0]!r} is given to two factors (tenors, equity indices, asset classes "
                         "and cohorts must name them apart); rename one.")
    values = check_factors(factors, problem.layout)
    reported, fixed = split_reported({k: jnp.asarray(v) for k, v in values.items()}, problem.layout)
    return Study(problem, reported, fixed)


def scenarios(study: Study, n_paths: int, key, mesh=None) -> jax.Array:
    """Correlated shocks for `n_paths` paths over the study's horizon (common random numbers),
    shape (months, paths, drivers). With a samples `mesh` (`snapo_ode.sample_mesh`) the paths are
    split over its devices, each device drawing only its own: the same numbers as without it, and
    every computation on them runs sharded (`n_paths` must be a multiple of the device count)."""
    check_count("paths", n_paths)
    if mesh is None:
        return correlated_shocks(study.market, n_paths, study.problem.horizon_months, key)
    check_divisible("paths", n_paths, mesh)
    draw = generate_sharded(lambda key: correlated_shocks(study.market, n_paths, study.problem.horizon_months, key),
                            mesh, samples_axis=1, ndim=3)
    return draw(key)


def compared_baselines(study: Study, shocks, board: BoardSettings, strategic_mix: dict | None = None) -> dict:
    """Each baseline of `baselines` evaluated on `shocks` (`evaluate`'s JSON) with its `board`
    figures (`board_figures`, as the policy's), and the strategic mix's `weights`: the `baselines`
    of `snapo alm`'s JSON."""
    out = {}
    for name, mix in baselines(study, strategic_mix).items():
        out[name] = {**evaluate(study, mix, shocks).to_json(), "board": board_figures(study, mix, shocks, board)}
        if name == "strategic_mix":
            out[name]["weights"] = dict(strategic_mix)
    return out


def train_policy(study: Study, *, steps: int, n_paths: int = 256, key=None,
                 learning_rate: float = 3e-3, progress: bool = True,
                 checkpoint_path=None, resume: bool = False, mesh=None, draw=None) -> tuple[NeuralRebalancing, TrainResult]:
    """Train a `NeuralRebalancing` policy on the smooth objective, fresh paths every step (split
    over the devices of `mesh`, when given): generated, or `draw(key)`'s (a given set's
    training scenarios, `_scenarios.batch_drawer`).

    Returns the best policy and the `TrainResult` (its history has the loss, -J, per step).
    """
    check_count("train_steps", steps)
    check_count("train_paths", n_paths)
    if mesh is not None:
        check_divisible("train_paths", n_paths, mesh)
    key = jax.random.key(0) if key is None else key
    initial = NeuralRebalancing(study.market, key=jax.random.fold_in(key, 0))
    objective_fn = objective_of_reported(study.problem, study.fixed, mesh=mesh)
    reported = study.reported

    def loss(policy, step_key):
        paths = scenarios(study, n_paths, step_key) if draw is None else draw(step_key)
        value = objective_fn(reported, policy, paths)
        return -value, {"value": value}

    result = snapo_ode.train(loss, initial, steps=steps, key=jax.random.fold_in(key, 1),
                             learning_rate=learning_rate, progress=progress,
                             checkpoint_path=checkpoint_path, checkpoint_every=50, resume=resume,
                             description="alm policy", fingerprint={"fund": study, "train_paths": n_paths,
                                                                    "given_scenarios": draw is not None})
    return result.params, result


@eqx.filter_jit
def _hard_and_smooth(problem: ALMProblem, policy: AbstractRebalancing, factors: dict, shocks, mesh):
    def both(policy, factors, shocks):
        return (simulate(problem, policy, factors, shocks, smooth_constraints=False),
                simulate(problem, policy, factors, shocks, smooth_constraints=True))

    return per_sample(both, mesh, PATH_SPECS)(policy, factors, shocks)


def evaluate(study: Study, policy: AbstractRebalancing, shocks) -> Evaluation:
    """The policy evaluated hard and smooth on `shocks` (on their devices, when sharded).

    **Raises:** `FloatingPointError` if the objective is not finite.
    """
    hard, soft = _hard_and_smooth(study.problem, policy, {**study.fixed, **study.reported}, shocks, mesh_of(shocks))
    objective, smooth = float(jnp.mean(hard.utility)), float(jnp.mean(soft.utility))
    if not np.all(np.isfinite([objective, smooth])):
        raise FloatingPointError(f"the ALM objective is not finite ({objective}, smooth {smooth}); check the inputs.")
    return Evaluation(objective=objective, objective_smooth=smooth, smoothing_gap=smooth - objective,
                      funding_ratio=funding_ratio_statistics(hard.funding_ratio),
                      mean_surplus=float(jnp.mean(hard.surplus)))


def measure_sensitivities(study: Study, policy: AbstractRebalancing, shocks, *, baselines: bool = True,
                          repeats: int = 3, baseline_repeats: int | None = None) -> SensitivityMeasurement:
    """Sensitivities of the smooth objective to every reported factor by one reverse pass (and
    the objective alone, timed beside it for `gradient_forward_ratio`), and, with `baselines`, by batched central bump-and-revalue and batched forward mode on the same
    paths (`snapo_ode.compare_with_bumps`), timed side by side in this call.

    **Raises:** `FloatingPointError` if the objective or a sensitivity is not finite.
    """
    n, n_paths = study.layout.n_risk_factors, shocks.shape[1]
    fn = objective_of_reported(study.problem, study.fixed, mesh=mesh_of(shocks))
    args = (study.reported, policy, shocks)
    comparison = None
    if baselines:
        comparison = compare_with_bumps(
            fn, *args, relative_step=BUMP_RELATIVE_STEP, batch_size=chunk_size(2 * n, n_paths, BUMP_ROWS_PER_CHUNK),
            repeats=repeats, bump_repeats=baseline_repeats, forward_mode=True,
            forward_batch_size=chunk_size(n, n_paths, FORWARD_ROWS_PER_CHUNK))
        value, gradient = comparison.value, comparison.adjoint
        seconds, compile_seconds = comparison.adjoint_seconds, comparison.adjoint_compile_seconds
    else:
        adjoint = eqx.filter_jit(lambda *args: value_and_sensitivities(fn, *args))
        timing, (value, gradient) = time_function(adjoint, *args, repeats=repeats)
        seconds, compile_seconds = timing.median_seconds, timing.compile_seconds
    value_timing, _ = time_function(eqx.filter_jit(fn), *args, repeats=repeats)
    named = named_sensitivities(gradient, study.layout, study.market, study.problem.schedule)
    if not np.isfinite(float(value)) or not all(np.isfinite(v) for v in named.values()):
        raise FloatingPointError("the ALM objective or a sensitivity is not finite; check the inputs.")
    baseline = {}
    if comparison is not None:
        baseline = dict(bump_seconds=comparison.bump_seconds, forward_mode_seconds=comparison.forward_mode_seconds,
                        speedup=comparison.speedup,
                        forward_mode_speedup=comparison.forward_mode_seconds / comparison.adjoint_seconds,
                        max_rel_diff=comparison.max_rel_diff,
                        max_rel_diff_forward_mode=comparison.forward_mode_agreement.max_rel_diff)
    return SensitivityMeasurement(
        value=float(value), sensitivities=named, adjoint_seconds=seconds, value_seconds=value_timing.median_seconds,
        gradient_forward_ratio=seconds / value_timing.median_seconds,
        **{key: baseline.get(key) for key in ("bump_seconds", "forward_mode_seconds", "speedup",
                                              "forward_mode_speedup", "max_rel_diff", "max_rel_diff_forward_mode")},
        compile_seconds=dict(adjoint=compile_seconds, value=value_timing.compile_seconds,
                             bump=comparison.bump_compile_seconds if comparison else None,
                             forward_mode=comparison.forward_mode_compile_seconds if comparison else None),
        gradient=gradient, comparison=comparison)


def study_for(n_risk_factors: int = 100, fund: Fund | None = None, horizon_months: int | None = None,
              scenario_set: ScenarioSet | None = None) -> Study:
    """The built-in fund with `n_risk_factors` factors (`build_study`, 120 months unless
    `horizon_months`), or `fund` (`build_fund_study`, over its own horizon unless
    `horizon_months`, on the given `scenario_set` where there is one)."""
    if fund is None:
        return build_study(n_risk_factors, horizon_months=120 if horizon_months is None else horizon_months)
    return build_fund_study(fund, horizon_months=horizon_months, scenario_set=scenario_set)


def run_alm(n_risk_factors: int = 100, *, n_paths: int = 1000, horizon_months: int | None = None,
            bump: bool = False, train_steps: int = 0, train_paths: int = 256, seed: int = 0,
            progress: bool = True, checkpoint_path=None, resume: bool = False, mesh=None,
            fund: Fund | None = None, scenario_set: ScenarioSet | None = None,
            board: BoardSettings | None = None) -> ALMStudy:
    """The `snapo alm` study of the built-in fund with `n_risk_factors` factors, or of `fund`
    (`load_fund`; its N follows from its files), on `n_paths` generated paths or on the given
    `scenario_set` of the fund (`load_scenarios`; then every scenario evaluates, or with training
    the second half, the first half training: `_scenarios.split_for_training`);
    `horizon_months` (default: 120, or the fund's); `checkpoint_path`, `resume`: of the training,
    see `snapo_ode.train`; `mesh`: the devices the paths are split over, see
    `snapo_ode.sample_mesh`; `board`: where the board's figures are taken (default: the fund's,
    or `BoardSettings()`)."""
    if scenario_set is not None and fund is None:
        raise InputError("given scenarios need the fund they were written for (fund=load_fund(...)).")
    check_count("paths", n_paths)
    check_count("train_steps", train_steps, low=0)
    check_count("train_paths", train_paths)
    if mesh is not None:
        check_divisible("paths", n_paths, mesh)
        if train_steps:
            check_divisible("train_paths", train_paths, mesh)
    study = study_for(n_risk_factors, fund, horizon_months, scenario_set)
    horizon_months = study.problem.horizon_months
    key = jax.random.key(seed)
    draw = None
    if scenario_set is None:
        check_size(study.layout, horizon_months, max(n_paths, train_paths))
        shocks = scenarios(study, n_paths, jax.random.fold_in(key, 2), mesh)
    else:
        evaluation, training = split_for_training(scenario_set, train_steps)
        shocks, n_paths = on_devices(evaluation, mesh), evaluation.shape[1]
        draw = None if training is None else batch_drawer(training, train_paths)
    if train_steps:
        policy, result = train_policy(study, steps=train_steps, n_paths=train_paths,
                                      key=jax.random.fold_in(key, 1), progress=progress,
                                      checkpoint_path=checkpoint_path, resume=resume, mesh=mesh, draw=draw)
        train_seconds, train_compile = result.seconds, result.compile_seconds
    else:
        policy = NeuralRebalancing(study.market, key=jax.random.fold_in(jax.random.fold_in(key, 1), 0))
        train_seconds = train_compile = 0.0
    board = board or (fund.board if fund is not None else BoardSettings())
    strategic_mix = None if fund is None else fund.strategic_mix
    return ALMStudy(
        n_risk_factors=study.layout.n_risk_factors, layout=study.layout._asdict(), paths=n_paths,
        horizon_months=horizon_months, effects=sorted(study.problem.scene.active), trained=bool(train_steps),
        evaluation=evaluate(study, policy, shocks),
        baselines=compared_baselines(study, shocks, board, strategic_mix), strategic_mix=strategic_mix,
        train_seconds=train_seconds, train_compile_seconds=train_compile,
        measurement=measure_sensitivities(study, policy, shocks, baselines=bump), policy=policy, shocks=shocks,
        fund=None if fund is None else fund.name, scenarios="generated" if scenario_set is None else scenario_set.source,
        initial_funding_ratio=initial_funding_ratio(study.problem, {**study.fixed, **study.reported}),
        initial_liability_value=float(initial_values(study.problem, {**study.fixed, **study.reported})[1]),
        liability_duration=liability_duration(study),
        board=board_figures(study, policy, shocks, board))
