"""The second shipped fund (`finance/data/closed_fund`): a closed fund with 60 years of annual
cash flows, five asset classes of its own and a 2,000-scenario external set at annual steps runs
through `snapo alm`, `snapo report alm` and `snapo bench alm`, starting at the funding ratio its
file states (against the NumPy balance sheet of `references.py`)."""

import csv
import json
from importlib.resources import files

import pytest

from finance import alm
from finance.alm._cli import register_alm
from references import alm_funding_ratio, alm_liability_value
from snapo_ode.cli import main

FOLDER = files("finance") / "data" / "closed_fund"
FUND, SCENARIOS = str(FOLDER / "fund.yaml"), str(FOLDER / "scenarios.parquet")


def test_the_closed_fund_starts_at_its_stated_funding_ratio_on_its_scenarios():
    fund = alm.load_fund(FUND)
    assert fund.market.asset_names == ("money_market", "govt_10y", "strips_25y", "linkers_15y", "global_equity")
    assert fund.schedule.n_rows == 60 and fund.schedule.run_off_months == 720
    scenarios = alm.load_scenarios(SCENARIOS, fund.market, 120, spread=float(fund.factors["spread"]))
    assert scenarios.n_scenarios == 2_000 and scenarios.months == 120
    study = alm.build_fund_study(fund, scenario_set=scenarios)
    assert study.layout.n_risk_factors == 7 + 2 + 2 + 4 + 2 + 60
    assert alm_funding_ratio(study) == pytest.approx(1.05, rel=1e-12)
    on_its_own_market = alm.build_fund_study(fund)
    assert alm_funding_ratio(on_its_own_market) == pytest.approx(1.05, rel=1e-12)


def test_alm_report_and_bench_run_the_closed_fund(tmp_path):
    common = ["--fund", FUND, "--scenarios", SCENARIOS, "--horizon-months", "12", "--no-progress"]
    out = tmp_path / "closed.json"
    assert main(["alm", *common, "--json", str(out)], plugins=[register_alm]) == 0
    payload = json.loads(out.read_text())
    assert payload["fund"] == "closed example fund" and payload["paths"] == 2_000
    assert payload["initial_funding_ratio"] == pytest.approx(1.05, rel=1e-12)
    assert payload["p_underfunded"]["months"] == [12]  # the file's board months within the horizon
    assert list(payload["baselines"])[0] == "strategic_mix" and payload["strategic_mix"]["strips_25y"] == 0.3
    study = alm.build_fund_study(alm.load_fund(FUND), horizon_months=12,
                                 scenario_set=alm.load_scenarios(SCENARIOS, alm.load_fund(FUND).market, 12, spread=0.01))
    assert payload["initial_liability_value"] == pytest.approx(alm_liability_value(study), rel=1e-12)
    assert payload["liability_duration"] == pytest.approx(sum(payload["key_rate_durations"]["liabilities"]), rel=1e-12)
    assert main(["report", "alm", *common, "--train-steps", "2", "--train-paths", "16", "--no-bump", "--no-pdf",
                 "--out", str(tmp_path / "report")], plugins=[register_alm]) == 0
    report = json.loads((tmp_path / "report" / "report.json").read_text())
    assert report["asset_classes"][-1] == "global_equity" and report["paths"] == 1_000  # half trains
    assert report["policy_names"][1] == "strategic_mix" and "board" in report["baselines"]["strategic_mix"]
    assert main(["bench", "alm", *common, "--repeats", "1", "--out", str(tmp_path / "bench")],
                plugins=[register_alm]) == 0
    rows = list(csv.DictReader((tmp_path / "bench" / "bench_alm.csv").open()))
    assert len(rows) == 1 and int(rows[0]["n_risk_factors"]) == 77 and float(rows[0]["max_rel_diff"]) <= 1e-6
