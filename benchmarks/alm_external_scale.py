"""The ALM reverse pass at scale on external scenarios (issue 36): a fund with N = 2,000 reported
factors (50 key tenors, 20 equity indices, 1,903 monthly liability rows in two cohorts) run on a
10,000-scenario x 120-month set read back from a file (the built-in generator's, written as NPZ),
one reverse pass for every sensitivity against the valuation alone, both medians after compile,
and the process's peak memory. Run: `.venv/bin/python benchmarks/alm_external_scale.py
[--scenarios 10000]`; prints one JSON line."""

import argparse
import json
import pathlib
import resource
import tempfile
import time

import jax
import numpy as np

import snapo_ode
from finance import alm

TENORS, EQUITIES, COHORT_MONTHS = 50, 20, (952, 951)


def write_fund(folder: pathlib.Path) -> pathlib.Path:
    """The N = 2,000 fund's files: the built-in fund's market at 50 tenors and 20 indices."""
    tenors = np.geomspace(0.25, 60.0, TENORS)
    rates = 0.025 + 0.015 * (1.0 - np.exp(-tenors / 7.0))
    rows = ["cohort,month,cash_flow"]
    for cohort, months in zip("ab", COHORT_MONTHS):
        rows += [f"{cohort},{m},{2.0 * np.exp(-m / 400.0):.6f}" for m in range(1, months + 1)]
    (folder / "liabilities.csv").write_text("\n".join(rows) + "\n")
    equities = "\n".join(f"    - {{name: index_{e}, volatility: {0.15 + 0.06 * e / (EQUITIES - 1):.4f}}}"
                         for e in range(EQUITIES))
    (folder / "fund.yaml").write_text(f"""name: scale fund
market:
  key_tenors: {[float(t) for t in tenors]}
  key_rates: {[float(r) for r in rates]}
  rate_vols: {[0.009 - 0.002 * float(t) / 60.0 for t in tenors]}
  inflation: 0.02
  inflation_vol: 0.01
  spread: 0.012
  spread_vol: 0.004
  equities:
{equities}
liabilities:
  file: liabilities.csv
assets:
  initial_funding_ratio: 1.1
""")
    return folder / "fund.yaml"


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("--scenarios", type=int, default=10_000)
    parser.add_argument("--months", type=int, default=120)
    args = parser.parse_args()
    snapo_ode.configure()
    with tempfile.TemporaryDirectory() as folder:
        fund = alm.load_fund(write_fund(pathlib.Path(folder)))
        generated = alm.generated_scenarios(alm.build_fund_study(fund, horizon_months=args.months),
                                            args.scenarios, jax.random.key(0))
        path = alm.write_scenarios(pathlib.Path(folder) / "set.npz", generated, fund.market)
        del generated
        start = time.perf_counter()
        scenarios = alm.load_scenarios(path, fund.market, args.months, spread=float(fund.factors["spread"]))
        read_seconds = time.perf_counter() - start
    study = alm.build_fund_study(fund, horizon_months=args.months, scenario_set=scenarios)
    policy = alm.NeuralRebalancing(study.market, key=jax.random.key(1))
    measured = alm.measure_sensitivities(study, policy, jax.numpy.asarray(scenarios.values), baselines=False, repeats=3)
    print(json.dumps(dict(
        n_risk_factors=study.layout.n_risk_factors, scenarios=scenarios.n_scenarios, months=args.months,
        scenario_file_read_seconds=read_seconds, value_seconds=measured.value_seconds,
        adjoint_seconds=measured.adjoint_seconds, gradient_forward_ratio=measured.gradient_forward_ratio,
        compile_seconds=measured.compile_seconds,
        peak_rss_gib=resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 2**20)))


if __name__ == "__main__":
    main()
