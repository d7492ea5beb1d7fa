"""Where a study's scenarios come from when they are given: the built-in generator's market
paths in the scenario-file layout (`generated_scenarios`, for `--write-scenarios`), the initial
market a scenario set starts from, and how a set's scenarios are split between training and
evaluation."""

import jax
import jax.numpy as jnp
import numpy as np

from snapo_ode import SAMPLES, InputError, check_divisible

from ._assets import MarketState, index_growth
from ._market import RATE_DRIVERS, correlated_shocks
from ._market_step import next_market
from ._scenario_file import ScenarioSet, variable_names


def generated_scenarios(study, n_paths: int, key) -> ScenarioSet:
    """The built-in generator's market on `n_paths` paths over the study's horizon, as a scenario
    set (monthly; the key rates at the fund's key tenors, each equity index's total return from
    1, the price index from 1, inflation, spread): what `snapo alm --write-scenarios` writes.
    Run on such a set, the study gives the generated study's objective to round-off (test)."""
    factors = {**study.fixed, **study.reported}
    market, horizon, credit = study.market, study.problem.horizon_months, study.problem.scene.has("credit")
    shocks = correlated_shocks(market, n_paths, horizon, key)
    n_rate, n_equity = len(RATE_DRIVERS), market.n_equities
    ones = jnp.ones(n_paths)
    start = MarketState(jnp.broadcast_to(jnp.asarray(factors["key_rates"]), (n_paths, market.n_tenors)),
                        factors["inflation"] * ones, ones, factors["spread"] * ones)

    def row(state, indices):
        return jnp.concatenate([state.key_rates, indices, jnp.stack([state.cpi, state.inflation, state.spread], 1)], 1)

    def month(carry, shock):
        state, indices = carry
        growth = index_growth(state, shock[:, n_rate:n_rate + n_equity], factors["equity_vols"], market)
        after = next_market(state, shock, factors, market, credit)
        return (after, indices * growth), row(after, indices * growth)

    indices = jnp.ones((n_paths, n_equity))
    _, rows = jax.lax.scan(month, (start, indices), shocks)
    values = jnp.concatenate([row(start, indices)[None], rows])
    return ScenarioSet(np.asarray(values), f"generated ({n_paths} paths, {horizon} months)")


def scenario_start(scenarios: ScenarioSet, market) -> dict:
    """The initial key rates, inflation and spread the set starts from (every scenario's month 0,
    which must agree): the factors a study on it shifts.

    **Raises:** `InputError` naming the variable where the scenarios start apart."""
    origin = scenarios.values[0]
    names = variable_names(market)
    spread = np.abs(origin - origin.mean(axis=0)).max(axis=0)
    index_columns = range(market.n_tenors, market.n_tenors + market.n_equities + 1)
    for column in np.flatnonzero(spread > 1e-9):
        if column not in index_columns:  # index levels may differ: only their returns are used
            raise InputError(f"scenario file {scenarios.source}: {names[column]} differs between scenarios at time 0 "
                             f"(by up to {spread[column]:.3g}); every scenario starts from the same market.")
    mean = origin.mean(axis=0)
    k = market.n_tenors
    return dict(key_rates=mean[:k], inflation=np.array(mean[-2]), spread=np.array(mean[-1]))


def split_for_training(scenarios: ScenarioSet, train_steps: int) -> tuple[jax.Array, jax.Array | None]:
    """(evaluation, training) values: without training, every scenario evaluates; with it, the
    first half trains (batches drawn from it) and the second half evaluates, so that evaluation
    scenarios are never training scenarios.

    **Raises:** `InputError` for fewer than 2 scenarios to split."""
    values = jnp.asarray(scenarios.values)
    if not train_steps:
        return values, None
    half = scenarios.n_scenarios // 2
    if half < 1:
        raise InputError(f"scenario file {scenarios.source}: {scenarios.n_scenarios} scenario; training needs at "
                         "least 2 (half train, half evaluate).")
    return values[:, half:], values[:, :half]


def on_devices(values: jax.Array, mesh) -> jax.Array:
    """`values` (months + 1, scenarios, variables) split over `mesh`'s devices along the
    scenarios (as generated paths are), or as they are without a mesh."""
    if mesh is None:
        return values
    check_divisible("scenarios", values.shape[1], mesh)
    return jax.device_put(values, jax.sharding.NamedSharding(mesh, jax.sharding.PartitionSpec(None, SAMPLES)))


def batch_drawer(training: jax.Array, n_paths: int):
    """A function key -> `n_paths` scenarios drawn with replacement from `training` (months + 1,
    scenarios, variables): a training step's batch."""
    def draw(key):
        return training[:, jax.random.randint(key, (n_paths,), 0, training.shape[1])]
    return draw
