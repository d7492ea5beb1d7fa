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


def alm_balance_sheet(study, key_rates=None) -> tuple[float, float]:
    """(assets, liabilities) [million] of an ALM study at the start, written from docs/alm.md in
    NumPy (on `key_rates` instead of the study's, when given): each monthly benefit mapped
    linearly onto its two key tenors, discounted at the key rates, the indexed share grown at the
    initial inflation; each bond class at exp(-y tau) with y interpolated (plus the spread for
    credit), inflation-linked ones at the real yield; cash at 1; equities at their levels."""
    factors = {k: np.asarray(v, float) for k, v in {**study.fixed, **study.reported}.items()}
    market, config = study.market, study.problem.config
    tenors = market.tenors
    rates = factors["key_rates"] if key_rates is None else np.asarray(key_rates, float)
    monthly = np.asarray(study.problem.schedule.monthly(factors["liability_cash_flows"]))
    maturities = np.arange(1, monthly.size + 1) / 12.0
    profile = np.zeros(tenors.size)
    for flow, tau in zip(monthly, np.clip(maturities, tenors[0], tenors[-1])):
        right = min(max(np.searchsorted(tenors, tau, side="right"), 1), tenors.size - 1)
        share = (tau - tenors[right - 1]) / (tenors[right] - tenors[right - 1])
        profile[right - 1] += flow * (1 - share)
        profile[right] += flow * share
    f = config.indexation if study.problem.scene.has("inflation_indexation") else 0.0
    liability = np.sum(profile * np.exp(-rates * tenors) * (1 - f + f * np.exp(factors["inflation"] * tenors)))

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
