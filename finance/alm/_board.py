"""The figures a pension fund's board reads: the funding-ratio fan chart, the probability of
underfunding at chosen dates, surplus at risk and expected shortfall, the hedge ratio and the
key-rate durations of assets, liabilities and surplus.

Path figures come from one exact (hard-constraint) run of the policy that records the fund at
every month-end (`simulate(..., trajectory=True)`); the hedge ratio and durations are the
initial balance sheet's key-rate derivatives by forward-mode AD (`initial_values`).
"""

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np

from snapo_ode import InputError, Settings, check_range, to_host

from ._model import initial_values, simulate

PERCENTILES = (5, 25, 50, 75, 95)
BASIS_POINT = 1e-4


class BoardSettings(Settings):
    """What the board's figures are taken at.

    **Arguments:**
    - `required_funding_ratio`: the level the regulator requires (`p_underfunded` reports the
      probability of ending a date below it, beside below 1).
    - `months`: the dates [month-ends] of `p_underfunded` and `surplus_at_risk` (those within a
      study's horizon); None: every 12 months and the horizon.
    - `confidence`: of surplus at risk and expected shortfall, in (0.5, 1).
    """

    required_funding_ratio: float = eqx.field(static=True, default=1.25)
    months: tuple[int, ...] | None = eqx.field(static=True, default=None)
    confidence: float = eqx.field(static=True, default=0.95)

    def __check_init__(self):
        check_range("required_funding_ratio", self.required_funding_ratio, 0.0, 10.0, low_open=True)
        check_range("confidence", self.confidence, 0.5, 1.0, low_open=True, high_open=True)
        if self.months is not None and (not self.months or min(self.months) < 1):
            raise InputError(f"board months = {list(self.months)}; allowed: one or more month-ends >= 1.")

    def dates(self, horizon: int) -> list[int]:
        """The month-ends the date figures are taken at: `months` within the horizon (a study run
        over a shorter horizon than its fund file's keeps those it reaches; the horizon where it
        reaches none), or every 12 months and the horizon."""
        if self.months is None:
            return sorted({*range(12, horizon + 1, 12), horizon})
        return sorted({m for m in self.months if m <= horizon} or {horizon})


@eqx.filter_jit
def _trajectory(problem, policy, factors, shocks):
    return simulate(problem, policy, factors, shocks, smooth_constraints=False, trajectory=True).trajectory


def path_figures(study, policy, shocks, settings: BoardSettings = BoardSettings()) -> dict:
    """`funding_ratio_percentiles` (the fan chart: each of `PERCENTILES` at every month-end),
    `p_underfunded` (P(FR < 1) and P(FR < required) at `settings.dates`) and `surplus_at_risk`
    (at the same dates and `confidence`: the initial surplus less the (1 - confidence) quantile
    of the surplus discounted by the bank account, and the expected shortfall, the initial
    surplus less the mean discounted surplus beyond that quantile; million) of `policy` on
    `shocks`, exactly (hard constraints)."""
    factors = {**study.fixed, **study.reported}
    path = jax.tree.map(to_host, _trajectory(study.problem, policy, factors, shocks))
    funding = path.assets / path.liabilities
    months = np.arange(funding.shape[0])
    dates = settings.dates(study.problem.horizon_months)
    surplus = (path.assets - path.liabilities) * np.exp(-path.log_bank)
    initial = float(surplus[0].mean())
    tail = 1.0 - settings.confidence
    quantiles = [float(np.quantile(surplus[m], tail)) for m in dates]
    shortfall = [float(surplus[m][surplus[m] <= q].mean()) for m, q in zip(dates, quantiles)]
    return dict(
        funding_ratio_percentiles={"months": months.tolist(), **{
            f"p{p:02d}": np.percentile(funding, p, axis=1).tolist() for p in PERCENTILES}},
        p_underfunded={"months": dates, "required_funding_ratio": settings.required_funding_ratio,
                       "below_1": [float(np.mean(funding[m] < 1.0)) for m in dates],
                       "below_required": [float(np.mean(funding[m] < settings.required_funding_ratio)) for m in dates]},
        surplus_at_risk={"months": dates, "confidence": settings.confidence, "initial_surplus": initial,
                         "surplus_at_risk": [initial - q for q in quantiles],
                         "expected_shortfall": [initial - e for e in shortfall]},
    )


def balance_sheet_figures(study) -> dict:
    """`hedge_ratio` (the assets' DV01 over the liabilities' for a parallel shift of the key
    rates) and `key_rate_durations` at the start: per key tenor, -dV/dr_k / V [years] of the
    assets and the liabilities, the surplus's -d(A - L)/dr_k per unit of liabilities [years],
    and each one's DV01 [million per basis point]; forward-mode AD over the key rates."""
    factors = {**study.fixed, **study.reported}

    def values(key_rates):
        return jnp.stack(initial_values(study.problem, {**factors, "key_rates": key_rates}))

    level = np.asarray(values(jnp.asarray(factors["key_rates"])))
    slopes = np.asarray(jax.jacfwd(values)(jnp.asarray(factors["key_rates"])))  # (2, tenors)
    assets, liabilities = level
    surplus_slope = slopes[0] - slopes[1]
    return dict(
        hedge_ratio=float(slopes[0].sum() / slopes[1].sum()),
        key_rate_durations={
            "tenors": [float(t) for t in study.market.tenors],
            "assets": (-slopes[0] / assets).tolist(), "liabilities": (-slopes[1] / liabilities).tolist(),
            "surplus": (-surplus_slope / liabilities).tolist(),
            "dv01": {"assets": (-slopes[0] * BASIS_POINT).tolist(), "liabilities": (-slopes[1] * BASIS_POINT).tolist(),
                     "surplus": (-surplus_slope * BASIS_POINT).tolist()}},
    )


def board_figures(study, policy, shocks, settings: BoardSettings = BoardSettings()) -> dict:
    """Every board figure (`path_figures` and `balance_sheet_figures`), the JSON fields of
    `snapo alm` and `snapo report alm`."""
    return {**path_figures(study, policy, shocks, settings), **balance_sheet_figures(study)}
