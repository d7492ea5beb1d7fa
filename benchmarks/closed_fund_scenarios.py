"""The closed fund's external scenario set (`finance/data/closed_fund/scenarios.parquet`): 2,000
scenarios at annual steps over 10 years from a small economic scenario generator written here,
independent of the library's own (so that the set exercises the reader's annual fill-in and the
tenor interpolation, not a round trip): a Vasicek short rate with its closed-form zero curve at
1-50 years, two correlated GBM total-return indices and a Vasicek inflation rate accruing the
price index. Run `.venv/bin/python benchmarks/closed_fund_scenarios.py` to write it again (the
same numbers: seed 2026)."""

import pathlib

import numpy as np
import pandas as pd

TENORS = (1, 2, 5, 10, 20, 30, 50)
SCENARIOS, YEARS, SEED = 2_000, 10, 2026
RATE = dict(speed=0.15, mean=0.025, vol=0.01, start=0.02)
INFLATION = dict(speed=0.4, mean=0.02, vol=0.008, start=0.022)
EQUITIES = dict(developed=0.16, emerging=0.24)
EQUITY_PREMIUM, EQUITY_CORRELATION = 0.035, 0.75


def vasicek_zero_rates(short_rate, tenors, speed, mean, vol):
    """Zero rates [1/year, continuously compounded] of the Vasicek model at `tenors` [years]."""
    tenors = np.asarray(tenors, float)
    b = (1 - np.exp(-speed * tenors)) / speed
    log_a = (mean - vol**2 / (2 * speed**2)) * (b - tenors) - vol**2 * b**2 / (4 * speed)
    return (b * short_rate[..., None] - log_a) / tenors


def exact_step(x, speed, mean, vol, normal):
    """One year of an Ornstein-Uhlenbeck process, exactly."""
    decay = np.exp(-speed)
    return mean + (x - mean) * decay + vol * np.sqrt((1 - decay**2) / (2 * speed)) * normal


def scenarios() -> pd.DataFrame:
    rng = np.random.default_rng(SEED)
    short = np.full(SCENARIOS, RATE["start"])
    inflation = np.full(SCENARIOS, INFLATION["start"])
    cpi = np.ones(SCENARIOS)
    indices = {name: np.ones(SCENARIOS) for name in EQUITIES}
    rows = []

    def record(year):
        curve = vasicek_zero_rates(short, TENORS, RATE["speed"], RATE["mean"], RATE["vol"])
        values = {**{f"zero_rate_{t}": curve[:, k] for k, t in enumerate(TENORS)},
                  **{f"equity_{name}": level for name, level in indices.items()}, "cpi": cpi, "inflation": inflation}
        for name, value in values.items():
            rows.append(pd.DataFrame({"scenario": np.arange(SCENARIOS), "time": float(year), "variable": name,
                                      "value": value}))

    record(0)
    for year in range(1, YEARS + 1):
        z = rng.standard_normal((4, SCENARIOS))
        equity_shocks = (z[0], EQUITY_CORRELATION * z[0] + np.sqrt(1 - EQUITY_CORRELATION**2) * z[1])
        for (name, vol), shock in zip(EQUITIES.items(), equity_shocks):
            indices[name] = indices[name] * np.exp(short + EQUITY_PREMIUM - vol**2 / 2 + vol * shock)
        cpi = cpi * np.exp(inflation)
        short = exact_step(short, RATE["speed"], RATE["mean"], RATE["vol"], z[2])
        inflation = exact_step(inflation, INFLATION["speed"], INFLATION["mean"], INFLATION["vol"], z[3])
        record(year)
    return pd.concat(rows, ignore_index=True)


if __name__ == "__main__":
    path = pathlib.Path(__file__).resolve().parents[1] / "finance" / "data" / "closed_fund" / "scenarios.parquet"
    scenarios().to_parquet(path, index=False, compression="zstd")
    print(f"written: {path} ({path.stat().st_size:,} bytes)")
