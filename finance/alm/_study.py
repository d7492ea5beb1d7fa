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
from snapo_ode import InputError, TrainResult, max_relative_difference

from . import _sensitivities as sensitivities
from ._factors import (
    FactorLayout,
    check_factors,
    default_factors,
    layout_for,
    named_sensitivities,
    split_reported,
)
from ._liabilities import key_rate_profile
from ._market import Market, correlated_shocks, key_tenors
from ._model import EFFECTS, ALMConfig, ALMProblem, simulate
from ._policy import AbstractRebalancing, NeuralRebalancing, liability_matching, sixty_forty


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


def check_count(field: str, value, low: int = 1) -> int:
    """Raise unless `value` is an integer >= `low`."""
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < low:
        raise InputError(f"{field} = {value!r}; allowed: an integer >= {low}.")
    return int(value)


def build_study(n_risk_factors: int, *, horizon_months: int = 120, effects=None,
                without=(), config: ALMConfig | None = None, correlation=None,
                factors: dict | None = None) -> Study:
    """The fund with `n_risk_factors` reported factors (see `layout_for`) on default market
    data, or the given `correlation` and `factors`.

    **Raises:** `InputError` naming the field for a bad count, horizon, correlation, factor
    value, effect name or effect parameter.
    """
    layout = layout_for(n_risk_factors)
    market = Market(key_tenors(layout.n_tenors), layout.n_equities, correlation=correlation)
    problem = ALMProblem(market, layout, EFFECTS.scene(effects, without=without),
                         config or ALMConfig(), horizon_months)
    values = check_factors(default_factors(layout, market) if factors is None else factors, layout)
    reported, fixed = split_reported({k: jnp.asarray(v) for k, v in values.items()}, layout)
    return Study(problem, reported, fixed)


def scenarios(study: Study, n_paths: int, key) -> jax.Array:
    """Correlated shocks for `n_paths` paths over the study's horizon (common random numbers)."""
    check_count("paths", n_paths)
    return correlated_shocks(study.market, n_paths, study.problem.horizon_months, key)


def liability_duration(study: Study) -> float:
    """Macaulay duration [years] of the liabilities on the initial curve."""
    factors = {**study.fixed, **study.reported}
    profile = np.asarray(key_rate_profile(factors["liability_cash_flows"], study.market, 0)[0])
    tenors = study.market.tenors
    values = profile * np.exp(-np.asarray(factors["key_rates"]) * tenors)
    return float(np.sum(values * tenors) / np.sum(values))


def baselines(study: Study) -> dict[str, AbstractRebalancing]:
    """The fixed-mix policies the trained one is compared with."""
    return {"sixty_forty": sixty_forty(),
            "liability_matching": liability_matching(study.market, liability_duration(study))}


def train_policy(study: Study, *, steps: int, n_paths: int = 256, key=None,
                 learning_rate: float = 3e-3, progress: bool = True,
                 checkpoint_path=None) -> tuple[NeuralRebalancing, TrainResult]:
    """Train a `NeuralRebalancing` policy on the smooth objective, fresh paths every step.

    Returns the best policy and the `TrainResult` (its history has the loss, -J, per step).
    """
    check_count("train_steps", steps)
    check_count("train_paths", n_paths)
    key = jax.random.key(0) if key is None else key
    initial = NeuralRebalancing(study.market, key=jax.random.fold_in(key, 0))
    objective_fn = sensitivities.objective_of_reported(study.problem, study.fixed)
    reported = study.reported

    def loss(policy, step_key):
        value = objective_fn(reported, policy, scenarios(study, n_paths, step_key))
        return -value, {"value": value}

    result = snapo_ode.train(loss, initial, steps=steps, key=jax.random.fold_in(key, 1),
                             learning_rate=learning_rate, progress=progress,
                             checkpoint_path=checkpoint_path, description="alm policy")
    return result.params, result


def funding_ratio_statistics(funding_ratio) -> dict[str, float]:
    """Mean, 5/50/95% quantiles and the probability of underfunding (< 1) at the horizon."""
    values = np.asarray(funding_ratio)
    p05, p50, p95 = np.quantile(values, [0.05, 0.5, 0.95])
    return dict(mean=float(values.mean()), p05=float(p05), p50=float(p50), p95=float(p95),
                probability_below_1=float(np.mean(values < 1.0)))


@eqx.filter_jit
def _hard_and_smooth(problem: ALMProblem, policy: AbstractRebalancing, factors: dict, shocks):
    return (simulate(problem, policy, factors, shocks, smooth_constraints=False),
            simulate(problem, policy, factors, shocks, smooth_constraints=True))


def evaluate(study: Study, policy: AbstractRebalancing, shocks) -> dict:
    """The objective with exact constraints (`objective`), with the smooth surrogates
    (`objective_smooth`) and their `smoothing_gap`, and the funding-ratio statistics (exact).

    **Raises:** `FloatingPointError` if any result is not finite.
    """
    hard, soft = _hard_and_smooth(study.problem, policy, {**study.fixed, **study.reported}, shocks)
    result = dict(objective=float(jnp.mean(hard.utility)),
                  objective_smooth=float(jnp.mean(soft.utility)),
                  funding_ratio=funding_ratio_statistics(hard.funding_ratio),
                  mean_surplus=float(jnp.mean(hard.surplus)))
    result["smoothing_gap"] = result["objective_smooth"] - result["objective"]
    if not np.all(np.isfinite([result["objective"], result["objective_smooth"]])):
        raise FloatingPointError(f"the ALM objective is not finite: {result}; check the inputs.")
    return result


def measure_sensitivities(study: Study, policy: AbstractRebalancing, shocks, *,
                          baselines: bool = True, repeats: int = 3,
                          baseline_repeats: int | None = None) -> dict:
    """Sensitivities of the smooth objective to every reported factor by one reverse pass, and,
    with `baselines`, by batched central bump-and-revalue and batched forward mode on the same
    paths, timed side by side in this call (medians after an ahead-of-time compile).

    **Returns:** a dict with `value`, `gradient` (pytree), `sensitivities` (name -> value),
    `adjoint_seconds`, `bump_seconds`, `forward_mode_seconds`, `speedup` (bump / adjoint),
    `forward_mode_speedup`, `max_rel_diff` (adjoint vs bump), `max_rel_diff_forward_mode`, and
    `compile_seconds` per method; baseline entries are None without `baselines`.
    """
    n = study.layout.n_risk_factors
    n_paths = shocks.shape[1]
    fn = sensitivities.objective_of_reported(study.problem, study.fixed)
    args = (study.reported, policy, shocks)
    timing, (value, gradient) = sensitivities.time_compiled(sensitivities.adjoint(fn), *args,
                                                            repeats=repeats)
    out = dict(value=float(value), gradient=gradient,
               sensitivities=named_sensitivities(gradient, study.layout, study.market),
               adjoint_seconds=timing.median_seconds, bump_seconds=None,
               forward_mode_seconds=None, speedup=None, forward_mode_speedup=None,
               max_rel_diff=None, max_rel_diff_forward_mode=None,
               compile_seconds=dict(adjoint=timing.compile_seconds, bump=None, forward_mode=None))
    if not np.isfinite(out["value"]) or not all(np.isfinite(v) for v in out["sensitivities"].values()):
        raise FloatingPointError("the ALM objective or a sensitivity is not finite; check the inputs.")
    if not baselines:
        return out
    repeats_b = repeats if baseline_repeats is None else baseline_repeats
    for label, method in (("bump", sensitivities.bump(fn, n, n_paths)),
                          ("forward_mode", sensitivities.forward(fn, n, n_paths))):
        timing, (_, reference) = sensitivities.time_compiled(method, *args, repeats=repeats_b)
        out[f"{label}_seconds"] = timing.median_seconds
        out["compile_seconds"][label] = timing.compile_seconds
        suffix = "" if label == "bump" else "_forward_mode"
        out[f"max_rel_diff{suffix}"] = max_relative_difference(gradient, reference)
    out["speedup"] = out["bump_seconds"] / out["adjoint_seconds"]
    out["forward_mode_speedup"] = out["forward_mode_seconds"] / out["adjoint_seconds"]
    return out


def run_alm(n_risk_factors: int = 100, *, n_paths: int = 1000, horizon_months: int = 120,
            bump: bool = False, train_steps: int = 0, train_paths: int = 256, seed: int = 0,
            progress: bool = True) -> dict:
    """The `snapo alm` study; returns the JSON payload (see docs/alm.md for every key)."""
    check_count("paths", n_paths)
    check_count("train_steps", train_steps, low=0)
    study = build_study(n_risk_factors, horizon_months=horizon_months)
    key = jax.random.key(seed)
    shocks = scenarios(study, n_paths, jax.random.fold_in(key, 2))
    if train_steps:
        policy, result = train_policy(study, steps=train_steps, n_paths=train_paths,
                                      key=jax.random.fold_in(key, 1), progress=progress)
        train_seconds, train_compile = result.seconds, result.compile_seconds
    else:
        policy = NeuralRebalancing(study.market, key=jax.random.fold_in(jax.random.fold_in(key, 1), 0))
        train_seconds = train_compile = 0.0
    measured = measure_sensitivities(study, policy, shocks, baselines=bump)
    evaluation = evaluate(study, policy, shocks)
    payload = dict(
        n_risk_factors=study.layout.n_risk_factors,
        layout=study.layout._asdict(),
        paths=n_paths,
        horizon_months=horizon_months,
        effects=sorted(study.problem.scene.active),
        trained=bool(train_steps),
        **evaluation,
        baselines={name: evaluate(study, mix, shocks) for name, mix in baselines(study).items()},
        train_seconds=train_seconds,
    )
    payload.update({k: v for k, v in measured.items() if k not in ("value", "gradient")})
    payload["compile_seconds"]["train"] = train_compile
    return payload
