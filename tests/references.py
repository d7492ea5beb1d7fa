"""Independent references shared by several test files."""

import numpy as np
from scipy.integrate import solve_ivp


def robertson_reference(rates, t1: float, *, rtol: float = 1e-12, atol: float = 1e-18) -> np.ndarray:
    """Robertson's kinetics y = (a, b, c) from (1, 0, 0) to `t1` by SciPy's Radau, written in NumPy
    with its exact Jacobian (a JAX call per evaluation would dominate SciPy's time): y(t1), (3,)."""
    k = np.asarray(rates, float)

    def field(t, y):
        a, b, c = y
        return np.array([-k[0] * a + k[1] * b * c, k[0] * a - k[1] * b * c - k[2] * b**2, k[2] * b**2])

    def jacobian(t, y):
        a, b, c = y
        return np.array([[-k[0], k[1] * c, k[1] * b], [k[0], -k[1] * c - 2 * k[2] * b, -k[1] * b],
                         [0.0, 2 * k[2] * b, 0.0]])

    solved = solve_ivp(field, (0.0, t1), [1.0, 0.0, 0.0], method="Radau", rtol=rtol, atol=atol, jac=jacobian)
    assert solved.success, solved.message
    return solved.y[:, -1]


def alm_liability_value(study, key_rates=None, *, month: int = 0, cpi: float = 1.0, inflation=None) -> float:
    """The liability value [million] of an ALM study after `month`, written from docs/alm.md in
    NumPy with a loop over the cash flows: each outstanding monthly benefit discounted at its own
    date tau = (m - month) / 12 at the zero rate interpolated linearly in maturity between the two
    key tenors around tau (flat beyond the ends); the indexed share (when the indexation effect
    is on) worth `cpi` exp(inflation tau) per unit (default inflation: the study's initial)."""
    factors = {k: np.asarray(v, float) for k, v in {**study.fixed, **study.reported}.items()}
    tenors = study.market.tenors
    rates = factors["key_rates"] if key_rates is None else np.asarray(key_rates, float)
    inflation = factors["inflation"] if inflation is None else inflation
    config = study.problem.config
    f = config.indexation if study.problem.scene.has("inflation_indexation") else 0.0
    monthly = np.asarray(study.problem.schedule.monthly(factors["liability_cash_flows"]))
    total = 0.0
    for m, flow in enumerate(monthly, start=1):
        if m <= month:
            continue
        tau = (m - month) / 12.0
        clipped = min(max(tau, tenors[0]), tenors[-1])
        if tenors.size == 1:
            rate = rates[0]
        else:
            right = min(max(np.searchsorted(tenors, clipped, side="right"), 1), tenors.size - 1)
            share = (clipped - tenors[right - 1]) / (tenors[right] - tenors[right - 1])
            rate = (1 - share) * rates[right - 1] + share * rates[right]
        total += flow * np.exp(-rate * tau) * (1 - f + f * cpi * np.exp(inflation * tau))
    return float(total)


def alm_balance_sheet(study, key_rates=None) -> tuple[float, float]:
    """(assets, liabilities) [million] of an ALM study at the start, written from docs/alm.md in
    NumPy (on `key_rates` instead of the study's, when given): the liabilities by
    `alm_liability_value`; each bond class at exp(-y tau) with y interpolated (plus the spread for
    credit), inflation-linked ones at the real yield; cash at 1; equities at their levels."""
    factors = {k: np.asarray(v, float) for k, v in {**study.fixed, **study.reported}.items()}
    market = study.market
    tenors = market.tenors
    rates = factors["key_rates"] if key_rates is None else np.asarray(key_rates, float)
    liability = alm_liability_value(study, rates)

    def y(tau):
        return np.interp(tau, tenors, rates)

    spread = factors["spread"] if study.problem.scene.has("credit") else 0.0
    extra = {"cash": None, "nominal": 0.0, "inflation_linked": -factors["inflation"], "credit": spread}
    prices = [1.0 if c.kind == "cash" else np.exp(-(y(c.maturity) + extra[c.kind]) * c.maturity)
              for c in market.asset_classes[:-1]]
    prices += list(factors["equity_levels"])
    return float(np.sum(factors["holdings"] * np.array(prices))), float(liability)


def alm_funding_ratio(study) -> float:
    """Assets over liabilities at the start (`alm_balance_sheet`)."""
    assets, liabilities = alm_balance_sheet(study)
    return assets / liabilities
