"""The shipped funds' starting balance sheet as the library values it: the liability value, the
funding ratio, the liabilities' duration that liability matching hedges, and the baseline
mixes, for the built-in fund and the closed fund (on its own market and on its scenario set's).

Run at two commits to see what a change of the valuation moves (docs/decisions.md):

    PYTHONPATH=$PWD .venv/bin/python benchmarks/alm_valuation_figures.py > figures.json
"""

import json

from finance import alm
from finance.alm._fund_file import sample_fund_path
from snapo_ode import configure

configure()
CLOSED = sample_fund_path().parent / "closed_fund"


def figures(fund, scenario_set=None) -> dict:
    study = alm.build_fund_study(fund, scenario_set=scenario_set)
    factors = {**study.fixed, **study.reported}
    assets, liabilities = (float(v) for v in alm.initial_values(study.problem, factors))
    mixes = alm.baselines(study)
    return dict(liability_value=liabilities, asset_value=assets, funding_ratio=assets / liabilities,
                liability_duration=alm.liability_duration(study),
                liability_matching=[float(w) for w in mixes["liability_matching"].weights])


def main() -> None:
    built_in = alm.load_fund(sample_fund_path())
    closed = alm.load_fund(CLOSED / "fund.yaml")
    scenarios = alm.load_scenarios(CLOSED / "scenarios.parquet", closed.market, closed.horizon_months,
                                   spread=float(closed.factors["spread"]))
    print(json.dumps({"built-in fund": figures(built_in), "closed fund": figures(closed),
                      "closed fund on its scenarios": figures(closed, scenarios)}, indent=1))


if __name__ == "__main__":
    main()
