"""The pension fund: monthly market scenarios, rebalancing, benefits and contributions, and the
objective, assembled from named effects.

Each month on every path: value the liabilities on the simulated curve, give the policy the
funding ratio and the market state, rebalance to its weights (paying transaction costs on the
turnover), earn the month's asset returns, pay the benefits (partly indexed to inflation) and
receive contributions. The monthly step is `jax.checkpoint`ed inside `lax.scan`, so a reverse
pass stores only the per-month state of each path, not the step's intermediates.

Objective (maximised; training minimises its negative), documented in docs/alm.md:

    J = mean_paths[ (1 - exp(-gamma * S)) / gamma ] - mean_paths[ sum_t lambda * dt * shortfall_t^p ]

with S = (A_T - L_T) / (B_T * L_0) the terminal surplus discounted by the bank account B_T
and expressed per unit of the initial liability value L_0, gamma the risk aversion, and
shortfall_t = max(floor - funding_ratio_t, 0) (smooth when training, exact when reporting), p = 2
(`shortfall_measure="squared"`, the default) or 1 ("linear": the expected shortfall per month).
"""

from typing import NamedTuple

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np

from snapo_ode import EffectCatalogue, InputError, Scene, Settings, check_choice, check_range, smooth

from ._assets import MarketState, gross_returns, initial_prices, scenario_returns, zero_rate
from ._factors import FactorLayout
from ._liabilities import (
    LiabilitySchedule, bucket_schedule, liability_value_at_dates, outstanding_cash_flows, starting_liability_value)
from ._market import MONTH, RATE_DRIVERS, Market
from ._market_step import next_market, scenario_state
from ._policy import AbstractRebalancing

EFFECTS = EffectCatalogue(
    "finance.alm",
    effects=dict(
        transaction_costs="proportional cost on the turnover of every monthly rebalancing",
        inflation_indexation="a share of the benefits grows with the price index",
        contributions="the sponsor pays a fixed contribution every month",
        funding_floor="a penalty on the (squared or linear) shortfall of the funding ratio below a floor",
        credit="the credit bucket earns a stochastic spread and loses part of it to defaults",
    ),
)
MAX_HORIZON_MONTHS = 600
SHORTFALL_MEASURES = ("squared", "linear")


class ALMConfig(Settings):
    """Parameters of the effects and of the objective.

    **Arguments:**
    - `transaction_cost` [per unit of turnover]: cost = rate * assets * sum|w_new - w_held|.
    - `indexation`: share of the benefits indexed to inflation, in [0, 1].
    - `contribution` [million/month].
    - `funding_floor`: the funding ratio below which the shortfall is penalised.
    - `floor_penalty` [1/year]: weight of the shortfall, per year below the floor.
    - `shortfall_measure`: "squared" (the shortfall squared, the default) or "linear" (the
      shortfall itself: penalises every shortfall in proportion, small ones more than squared).
    - `max_turnover` [per month]: at most this sum |w_new - w_held| is traded in a month, the
      policy's target approached along the straight line (`limited_weights`); None: no limit,
      not computed.
    - `risk_aversion` gamma of the exponential utility of the surplus, > 0.
    - `turnover_sharpness`, `floor_sharpness`: sharpness of the smooth |.| and max(., 0) used
      when training [1/unit of weight, 1/unit of funding ratio].

    Neutral values make an effect's presence irrelevant (the tests check the full model then
    equals the one without it): `transaction_cost`, `indexation`, `contribution` or
    `floor_penalty` at 0; for `credit`, the factors `spread` and `spread_vol` at 0.
    """

    transaction_cost: float = eqx.field(static=True, default=0.002)
    indexation: float = eqx.field(static=True, default=0.5)
    contribution: float = eqx.field(static=True, default=1.0)
    funding_floor: float = eqx.field(static=True, default=1.0)
    floor_penalty: float = eqx.field(static=True, default=2.0)
    risk_aversion: float = eqx.field(static=True, default=3.0)
    shortfall_measure: str = eqx.field(static=True, default="squared")
    max_turnover: float | None = eqx.field(static=True, default=None)
    turnover_sharpness: float = eqx.field(static=True, default=200.0)
    floor_sharpness: float = eqx.field(static=True, default=50.0)

    def __check_init__(self):
        check_range("transaction_cost", self.transaction_cost, 0.0, 0.1)
        check_range("indexation", self.indexation, 0.0, 1.0)
        check_range("contribution", self.contribution, 0.0)
        check_range("funding_floor", self.funding_floor, 0.0, 10.0)
        check_range("floor_penalty", self.floor_penalty, 0.0)
        check_range("risk_aversion", self.risk_aversion, 0.0, 100.0, low_open=True)
        check_range("turnover_sharpness", self.turnover_sharpness, 0.0, low_open=True)
        check_choice("shortfall_measure", self.shortfall_measure, SHORTFALL_MEASURES)
        if self.max_turnover is not None:
            check_range("max_turnover", self.max_turnover, 0.0, 2.0, low_open=True)
        check_range("floor_sharpness", self.floor_sharpness, 0.0, low_open=True)


class ALMProblem(eqx.Module):
    """Everything fixed about one study: market structure, factor layout, active effects,
    effect parameters, horizon, the liability rows' `liabilities` schedule (None: the built-in
    fund's buckets, `bucket_schedule(layout.n_liability)`) and where the scenarios come from:
    generated from correlated shocks, or given (`external_scenarios`: `simulate`'s `shocks` are
    then a scenario set's values, `_scenario_file.ScenarioSet.values`).

    **Raises:** `InputError` for `horizon_months` outside [1, 600].
    """

    market: Market
    layout: FactorLayout = eqx.field(static=True)
    scene: Scene
    config: ALMConfig
    horizon_months: int = eqx.field(static=True)
    liabilities: LiabilitySchedule | None = eqx.field(static=True, default=None)
    external_scenarios: bool = eqx.field(static=True, default=False)

    @property
    def schedule(self) -> LiabilitySchedule:
        """Which liability row pays in which month."""
        return bucket_schedule(self.layout.n_liability) if self.liabilities is None else self.liabilities

    def __check_init__(self):
        if self.liabilities is not None and self.liabilities.n_rows != self.layout.n_liability:
            raise InputError(f"the liability schedule has {self.liabilities.n_rows} rows but the layout "
                             f"{self.layout.n_liability} liability factors.")
        if not isinstance(self.horizon_months, (int, np.integer)) or not (
                1 <= self.horizon_months <= MAX_HORIZON_MONTHS):
            raise InputError(f"horizon_months = {self.horizon_months!r}; allowed: an integer in "
                             f"[1, {MAX_HORIZON_MONTHS}].")


def limited_weights(held, target, max_turnover: float, sharpness: float | None):
    """The weights traded to when at most `max_turnover` (sum of |change|) may trade: `held` +
    (`target` - `held`) x L / (L + relu(turnover - L)), so the whole move where it is within the
    limit and exactly the limit beyond it (with the exact relu; `sharpness` for the smooth |.|
    and relu). Both ends on the simplex, so the result is too. Shapes (paths, classes)."""
    move = target - held
    turnover = jnp.sum(smooth.abs(move, sharpness), axis=1)
    excess = smooth.relu(turnover - max_turnover, sharpness)
    return held + move * (max_turnover / (max_turnover + excess))[:, None]


def indexed_share(config: ALMConfig, scene: Scene) -> float | None:
    """The share of the benefits indexed to inflation, or None when the indexation effect is off."""
    return config.indexation if scene.has("inflation_indexation") else None


def initial_values(problem: ALMProblem, factors: dict) -> tuple[jax.Array, jax.Array]:
    """(assets, liabilities) [million] at the start, valued as `simulate` values them (the
    credit bucket at its spread when the credit effect is on, the indexed share of the benefits
    growing at the initial inflation when indexation is); traceable, so their key-rate
    derivatives are one `jax.jacfwd` away."""
    market = problem.market
    assets = jnp.sum(jnp.asarray(factors["holdings"]) * initial_prices(factors, market, credit=problem.scene.has("credit")))
    return assets, starting_liability_value(factors, market, problem.schedule,
                                            indexed_share(problem.config, problem.scene))


def initial_funding_ratio(problem: ALMProblem, factors: dict) -> float:
    """The funding ratio at the start, assets over liabilities as `initial_values` values them."""
    assets, liabilities = initial_values(problem, factors)
    return float(assets / liabilities)


class Trajectory(NamedTuple):
    """The fund at every month-end 0..horizon on every path, each shape (months + 1, paths):
    `assets` and `liabilities` [million] (the funding ratio is their ratio) and `log_bank`, the
    log of the bank account (discounting by exp(-log_bank))."""

    assets: jax.Array
    liabilities: jax.Array
    log_bank: jax.Array


class Outcome(NamedTuple):
    """Per-path results, each shape (paths,): `funding_ratio` at the horizon; `surplus`, the
    discounted terminal surplus per unit of initial liability; `shortfall_penalty`; the
    objective's per-path `utility` (utility of the surplus minus the penalty); and, when asked
    for (`simulate(..., trajectory=True)`), the month-by-month `trajectory`."""

    funding_ratio: jax.Array
    surplus: jax.Array
    shortfall_penalty: jax.Array
    utility: jax.Array
    trajectory: Trajectory | None = None


class _Carry(NamedTuple):
    market: MarketState
    assets: jax.Array
    held: jax.Array
    log_bank: jax.Array
    penalty: jax.Array


def simulate(problem: ALMProblem, policy: AbstractRebalancing, factors: dict, shocks,
             *, smooth_constraints: bool = True, trajectory: bool = False) -> Outcome:
    """Run the fund over `problem.horizon_months` months on every path.

    **Arguments:**
    - `factors`: every factor group (see `_factors.GROUPS`), as arrays.
    - `shocks`: correlated standard normals, shape (months >= horizon, paths, n_drivers), from
      `correlated_shocks`; with `problem.external_scenarios`, a scenario set's values instead,
      shape (months + 1 >= horizon + 1, paths, n_tenors + n_equities + 3), month 0 the start.
    - `smooth_constraints`: True for the smooth surrogates (training, sensitivities), False for
      the exact |.| and max(., 0) (reporting).
    - `trajectory`: also return the fund at every month-end (`Outcome.trajectory`; for the
      board's figures, not in the objective's program).
    """
    market, scene, config = problem.market, problem.scene, problem.config
    horizon = problem.horizon_months
    n_paths = shocks.shape[1]
    credit = scene.has("credit")
    indexed = scene.has("inflation_indexation")
    turnover_sharpness = config.turnover_sharpness if smooth_constraints else None
    floor_sharpness = config.floor_sharpness if smooth_constraints else None
    tenors = market.tenors
    n_rate, n_equity, n_rate_keys = len(RATE_DRIVERS), market.n_equities, market.n_tenors
    origin = shocks[0] if problem.external_scenarios else None
    schedule = problem.schedule
    outstanding = outstanding_cash_flows(factors["liability_cash_flows"], horizon, schedule)
    benefits = schedule.monthly(factors["liability_cash_flows"])
    benefits = jnp.concatenate([benefits, jnp.zeros(horizon, benefits.dtype)])[:horizon]
    key_rates0 = jnp.asarray(factors["key_rates"])
    inflation0 = jnp.asarray(factors["inflation"])
    spread0 = jnp.asarray(factors["spread"])

    def liabilities(month, state: MarketState):
        indexation = (config.indexation, state.cpi, state.inflation) if indexed else None
        return liability_value_at_dates(outstanding[month], state.key_rates, tenors, indexation=indexation)

    ones = jnp.ones(n_paths)
    start = MarketState(jnp.broadcast_to(key_rates0, (n_paths, key_rates0.size)),
                        inflation0 * ones, ones, spread0 * ones)
    value0 = factors["holdings"] * initial_prices(factors, market, credit=credit)
    plain = len(market.asset_classes) - 1  # the classes before the equity sleeve
    held0 = jnp.concatenate([value0[:plain], jnp.sum(value0[plain:], keepdims=True)])
    assets0 = jnp.sum(value0)
    liability0 = liabilities(0, start)

    def step(carry: _Carry, inputs):
        month, shock = inputs
        state = carry.market
        liability_now = liabilities(month, state)
        funding_ratio = carry.assets / liability_now
        short_rate = zero_rate(state.key_rates, market, MONTH)
        features = jnp.stack([month / horizon * ones, funding_ratio, short_rate,
                              state.key_rates[:, -1], state.inflation, state.spread], axis=1)
        weights = policy(features)
        if config.max_turnover is not None:
            weights = limited_weights(carry.held, weights, config.max_turnover, turnover_sharpness)
        assets = carry.assets
        if scene.has("transaction_costs"):
            turnover = jnp.sum(smooth.abs(weights - carry.held, turnover_sharpness), axis=1)
            assets = assets * (1.0 - config.transaction_cost * turnover)
        penalty = carry.penalty
        if scene.has("funding_floor"):
            shortfall = smooth.relu(config.funding_floor - funding_ratio, floor_sharpness)
            if config.shortfall_measure == "squared":
                shortfall = shortfall**2
            penalty = penalty + config.floor_penalty * MONTH * shortfall
        if problem.external_scenarios:
            now, later = shock
            after = scenario_state(later, origin, factors, credit, (month + 1) * MONTH, n_rate_keys)
            index_ratio = later[:, n_rate_keys:-3] / now[:, n_rate_keys:-3]
            returns = scenario_returns(state, after, index_ratio, market, credit=credit)
        else:
            after = next_market(state, shock, factors, market, credit)
            returns = gross_returns(state, after, shock[:, n_rate:n_rate + n_equity],
                                    factors["equity_vols"], market, credit=credit)
        grown = weights * returns
        growth = jnp.sum(grown, axis=1)
        benefit = benefits[month]
        if indexed:
            benefit = benefit * (1.0 - config.indexation + config.indexation * after.cpi)
        assets = assets * growth - benefit
        if scene.has("contributions"):
            assets = assets + config.contribution
        log_bank = carry.log_bank + short_rate * MONTH
        month_start = (carry.assets, liability_now, carry.log_bank) if trajectory else None
        return _Carry(after, assets, grown / growth[:, None], log_bank, penalty), month_start

    carry0 = _Carry(start, assets0 * ones, jnp.broadcast_to(held0 / assets0, (n_paths, plain + 1)),
                    jnp.zeros(n_paths), jnp.zeros(n_paths))
    months = jnp.arange(horizon)
    steps = (shocks[:horizon], shocks[1:horizon + 1]) if problem.external_scenarios else shocks[:horizon]
    final, month_starts = jax.lax.scan(jax.checkpoint(step), carry0, (months, steps))
    liability_end = liabilities(horizon, final.market)
    surplus = (final.assets - liability_end) * jnp.exp(-final.log_bank) / liability0
    gamma = config.risk_aversion
    utility = -jnp.expm1(-gamma * surplus) / gamma - final.penalty
    path = None
    if trajectory:
        path = Trajectory(*(jnp.concatenate([series, end[None]]) for series, end in
                            zip(month_starts, (final.assets, liability_end, final.log_bank))))
    return Outcome(final.assets / liability_end, surplus, final.penalty, utility, path)


def objective(reported: dict, policy: AbstractRebalancing, shocks, problem: ALMProblem,
              fixed: dict, *, smooth_constraints: bool = True) -> jax.Array:
    """The objective J (a scalar, higher is better) as a function of the reported factors first,
    so that `value_and_sensitivities(objective, reported, ...)` differentiates exactly them."""
    outcome = simulate(problem, policy, {**fixed, **reported}, shocks,
                       smooth_constraints=smooth_constraints)
    return jnp.mean(outcome.utility)
