"""A fund in files (`load_fund`, `snapo alm --fund`): the shipped file gives the built-in fund
exactly, liability rows of every kind expand to the right months in the model's unit, a file
fund's sensitivities match central bumps, and bad files fail naming the file, line and field."""

import json
import pathlib

import jax
import numpy as np
import pytest

from finance import alm
from finance.alm._cli import register_alm
from snapo_ode import InputError, bump_and_revalue, max_relative_difference, value_and_sensitivities
from snapo_ode.cli import main
from references import alm_funding_ratio

SAMPLE = alm.sample_fund_path()


def _gradient(study, n_paths=16):
    shocks = alm.scenarios(study, n_paths, jax.random.key(3))
    policy = alm.NeuralRebalancing(study.market, key=jax.random.key(4))
    fn = alm.objective_of_reported(study.problem, study.fixed)
    value, gradient = jax.jit(lambda r: value_and_sensitivities(fn, r, policy, shocks))(study.reported)
    return fn, policy, shocks, float(value), gradient


def test_the_shipped_fund_file_is_the_built_in_fund():
    built_in = alm.build_study(100, horizon_months=12)
    from_files = alm.build_fund_study(alm.load_fund(SAMPLE), horizon_months=12)
    *_, value, gradient = _gradient(built_in)
    *_, file_value, file_gradient = _gradient(from_files)
    assert file_value == pytest.approx(value, rel=1e-12)
    named = alm.named_sensitivities(gradient, built_in.layout, built_in.market)
    file_named = alm.named_sensitivities(file_gradient, from_files.layout, from_files.market, from_files.problem.schedule)
    assert list(file_named) == list(named) and len(named) == 100
    assert max(abs(file_named[k] - named[k]) / max(abs(named[k]), 1e-300) for k in named) <= 1e-10


def _fund(tmp_path, liabilities: str, **changes) -> pathlib.Path:
    """A copy of the shipped fund with `liabilities` as its CSV and top-level sections changed by
    `changes` (YAML text replacing a line that starts with the key)."""
    text = SAMPLE.read_text().replace("file: alm_liabilities.csv", "file: liabilities.csv")
    for key, line in changes.items():
        lines = text.splitlines()
        index = next(i for i, old in enumerate(lines) if old.strip().startswith(f"{key}:"))
        lines[index] = line
        text = "\n".join(lines) + "\n"
    (tmp_path / "liabilities.csv").write_text(liabilities)
    path = tmp_path / "fund.yaml"
    path.write_text(text)
    return path


def test_liability_rows_pay_in_their_months_in_the_models_unit(tmp_path):
    rows = {
        "month,cash_flow\n1,2\n3,4\n": {1: 2.0, 3: 4.0},
        "year,cash_flow\n2,12\n": {m: 1.0 for m in range(13, 25)},
        "first_month,last_month,cash_flow\n2,4,3\n5,5,1\n": {2: 3.0, 3: 3.0, 4: 3.0, 5: 1.0},
        "date,cash_flow\n2027-01-15,5\n2027-03-31,6\n": {1: 5.0, 3: 6.0},
    }
    for text, expected in rows.items():
        unit = "million EUR / year" if text.startswith("year") else "million / month"
        path = _fund(tmp_path, text, cash_flow_unit=f"  cash_flow_unit: {unit}\n  valuation_date: 2026-12-31")
        fund = alm.load_fund(path)
        monthly = np.asarray(fund.schedule.monthly(fund.factors["liability_cash_flows"]))
        reference = np.zeros(fund.schedule.run_off_months)
        for month, flow in expected.items():
            reference[month - 1] = flow
        np.testing.assert_allclose(monthly, reference, rtol=1e-15, err_msg=text)


def test_cohorts_overlap_and_sum(tmp_path):
    text = "cohort,first_month,last_month,cash_flow\nactive,1,24,1\nretired,1,12,2\nretired,13,24,0.5\n"
    fund = alm.load_fund(_fund(tmp_path, text))
    monthly = np.asarray(fund.schedule.monthly(fund.factors["liability_cash_flows"]))
    np.testing.assert_array_equal(monthly, np.r_[np.full(12, 3.0), np.full(12, 1.5)])
    assert fund.schedule.names == ("month_1_cohort_active", "month_1_cohort_retired", "month_13_cohort_retired")


def test_a_file_funds_sensitivities_equal_central_bumps(tmp_path):
    text = "cohort,year,cash_flow\na,1,24\na,2,30\nb,1,12\nb,3,40\n"
    path = _fund(tmp_path, text, cash_flow_unit="  cash_flow_unit: million / year",
                 initial_funding_ratio="  initial_funding_ratio: 1.25")
    study = alm.build_fund_study(alm.load_fund(path), horizon_months=12)
    fn, policy, shocks, value, gradient = _gradient(study)
    reference = bump_and_revalue(fn, study.reported, policy, shocks, relative_step=1e-6)
    assert max_relative_difference(gradient, reference) <= 1e-6
    names = alm.named_sensitivities(gradient, study.layout, study.market, study.problem.schedule)
    assert {"liability_cash_flow_month_1_cohort_a", "liability_cash_flow_month_25_cohort_b"} <= set(names)
    assert all(np.asarray(gradient["liability_cash_flows"]) < 0)  # more benefits, a lower objective


def test_holdings_in_money_are_the_funds_starting_assets(tmp_path):
    holdings = "  holdings: {cash: 100, bond_short: 200, bond_long: 300, inflation_linked: 50, credit: 25, equity_0: 325}"
    path = _fund(tmp_path, "year,cash_flow\n1,12\n", initial_funding_ratio=holdings, mix="  holdings_unit: thousand")
    fund = alm.load_fund(path)
    study = alm.build_fund_study(fund)
    factors = {**study.fixed, **study.reported}
    from finance.alm._assets import initial_prices

    values = np.asarray(factors["holdings"]) * np.asarray(initial_prices(factors, study.market, credit=True))
    np.testing.assert_allclose(values, np.array([100, 200, 300, 50, 25, 325]) / 1000, rtol=1e-14)


@pytest.mark.parametrize("liabilities, change, message", [
    ("month,cash_flow\n1,-2\n", {}, "liabilities.csv, line 2: cash_flow = '-2'"),
    ("month,cash_flow\n1,abc\n", {}, "liabilities.csv, line 2: cash_flow = 'abc'"),
    ("month,cash_flow\n0,2\n", {}, "line 2: month = '0'; allowed: a whole number >= 1"),
    ("month,amount\n1,2\n", {}, "liabilities.csv, line 1: header ['month', 'amount']"),
    ("year,cash_flow\n1,2\n1,3\n", {}, "line 3: the row pays from month 1, which the row on line 2"),
    ("date,cash_flow\n2027-01-01,2\n", {}, "needs the fund file's liabilities.valuation_date"),
    ("month,cash_flow\n1,2\n", {"cash_flow_unit": "  cash_flow_unit: kg / month"}, "is not money per time"),
    ("month,cash_flow\n1,2\n", {"key_rates": "  key_rates: [0.02, abc]"}, "line 11: market.key_rates.1 = 'abc'"),
    ("month,cash_flow\n1,2\n", {"key_rates": "  key_rates: [0.02]"}, "market.key_rates has 1 entries; expected one"),
    ("month,cash_flow\n1,2\n", {"mix": "  mix: {cash: 1.0}"}, "assets.mix has no ['bond_short'"),
    ("month,cash_flow\n1,2\n", {"risk_aversion": "  risk_aversion: -1"}, "risk_aversion = -1"),
    ("month,cash_flow\n1,2\n", {"horizon_months": "horizon_months: 0"}, "line 8: horizon_months = 0"),
    ("month,cash_flow\n1,2\n", {"inflation": "  inflation: .nan"}, "market.inflation = nan"),
])
def test_bad_files_name_the_file_line_field_and_value(tmp_path, liabilities, change, message):
    path = _fund(tmp_path, liabilities, **change)
    with pytest.raises(InputError, match=None) as raised:
        alm.load_fund(path)
    assert message in str(raised.value), str(raised.value)


STRATEGIC = "{cash: 0.1, bond_short: 0.2, bond_long: 0.35, inflation_linked: 0.05, credit: 0.05, equity: 0.25}"
MIX = "  mix: {cash: 0.05, bond_short: 0.15, bond_long: 0.3, inflation_linked: 0.1, credit: 0.1, equity: 0.3}"


def test_snapo_alm_runs_a_fund_file_and_refuses_a_count_beside_it(tmp_path, capsys):
    out = tmp_path / "fund.json"
    path = _fund(tmp_path, "cohort,year,cash_flow\na,1,24\nb,2,30\n", cash_flow_unit="  cash_flow_unit: million / year",
                 floor_sharpness="  floor_sharpness: 50.0\nboard: {required_funding_ratio: 1.3, months: [2, 3]}",
                 mix=f"{MIX}\n  strategic_mix: {STRATEGIC}")
    argv = ["alm", "--fund", str(path), "--paths", "8", "--horizon-months", "3", "--no-progress"]
    assert main([*argv, "--json", str(out)], plugins=[register_alm]) == 0
    payload = json.loads(out.read_text())
    assert payload["fund"] == "built-in example fund" and payload["n_risk_factors"] == 10 * 2 + 3 + 4 + 5 + 2
    assert "liability_cash_flow_month_13_cohort_b" in payload["sensitivities"]
    assert payload["p_underfunded"]["months"] == [2, 3] and payload["p_underfunded"]["required_funding_ratio"] == 1.3
    assert {"funding_ratio_percentiles", "surplus_at_risk", "hedge_ratio", "key_rate_durations"} <= set(payload)
    # The fund's strategic mix: the first baseline, with the policy's board figures.
    assert list(payload["baselines"]) == ["strategic_mix", "sixty_forty", "liability_matching"]
    strategic = payload["baselines"]["strategic_mix"]
    assert strategic["weights"] == payload["strategic_mix"] == dict(
        cash=0.1, bond_short=0.2, bond_long=0.35, inflation_linked=0.05, credit=0.05, equity=0.25)
    for baseline in payload["baselines"].values():
        assert set(baseline["board"]) == {key for key in payload if key in baseline["board"]} == {
            "funding_ratio_percentiles", "p_underfunded", "surplus_at_risk", "hedge_ratio", "key_rate_durations"}
        # The fan chart's last month (a trajectory run) agrees with the evaluation (a run without one).
        assert baseline["board"]["p_underfunded"]["below_1"][-1] == baseline["funding_ratio"]["probability_below_1"]
        assert baseline["board"]["funding_ratio_percentiles"]["p50"][-1] == pytest.approx(baseline["funding_ratio"]["p50"],
                                                                                           rel=1e-12)
    assert main([*argv, "--risk-factors", "40"], plugins=[register_alm]) == 2
    assert "give one of the two" in capsys.readouterr().err


def test_a_ragged_row_and_blank_lines_keep_their_line_numbers(tmp_path):
    with pytest.raises(InputError, match=r"line 4: cash_flow = 'x'"):
        alm.load_fund(_fund(tmp_path, "month,cash_flow\n1,2\n\n2,x\n"))
    with pytest.raises(InputError, match="not a CSV table"):
        alm.load_fund(_fund(tmp_path, "month,cash_flow\n1,2,3,4\n"))
    with pytest.raises(InputError, match=r"line 3: cash_flow = ''"):
        alm.load_fund(_fund(tmp_path, "month,cash_flow\n1,2\n7\n"))


@pytest.mark.parametrize("without", [(), ("inflation_indexation",), ("credit",)])
def test_every_fund_starts_at_the_funding_ratio_its_file_states(tmp_path, without):
    effects = [name for name in alm.EFFECTS.effects if name not in without]
    path = _fund(tmp_path, "cohort,year,cash_flow\na,1,24\na,2,30\nb,1,12\nb,30,40\n",
                 cash_flow_unit="  cash_flow_unit: million / year", initial_funding_ratio="  initial_funding_ratio: 0.93",
                 horizon_months=f"horizon_months: 12\neffects: {effects}")
    study = alm.build_fund_study(alm.load_fund(path))
    assert alm_funding_ratio(study) == pytest.approx(0.93, rel=1e-12)
    assert alm.initial_funding_ratio(study.problem, {**study.fixed, **study.reported}) == pytest.approx(0.93, rel=1e-12)
    built_in = alm.build_study(40, horizon_months=12, without=without)
    assert alm_funding_ratio(built_in) == pytest.approx(1.1, rel=1e-12)


def test_asset_classes_by_duration_and_their_errors(tmp_path):
    text = SAMPLE.read_text().replace("file: alm_liabilities.csv", "file: liabilities.csv")
    text = text[:text.index("assets:")] + """assets:
  classes: [{name: cash, kind: cash}, {name: long_bonds, kind: nominal, duration: 18}, {name: stocks, kind: equity}]
  weight_bounds: {cash: [0, 0.5], long_bonds: [0, 1], stocks: [0, 1]}
  initial_funding_ratio: 1.1
  mix: {cash: 0.1, long_bonds: 0.6, stocks: 0.3}
"""
    (tmp_path / "liabilities.csv").write_text("year,cash_flow\n1,12\n")
    path = tmp_path / "fund.yaml"
    path.write_text(text)
    fund = alm.load_fund(path)
    assert fund.market.asset_names == ("cash", "long_bonds", "stocks") and fund.market.bond_classes[0].maturity == 18
    assert alm_funding_ratio(alm.build_fund_study(fund)) == pytest.approx(1.1, rel=1e-12)
    path.write_text(text.replace("duration: 18", "duration: 18, maturity: 5"))
    with pytest.raises(InputError, match="give maturity or duration, not both"):
        alm.load_fund(path)
    path.write_text(text.replace("kind: equity", "kind: gold"))
    with pytest.raises(InputError, match="kind = 'gold'; allowed: cash, nominal"):
        alm.load_fund(path)


@pytest.mark.parametrize("change, message", [
    ({"cash_flow_unit": "  cash_flow_unit: million USD / month"}, "line 27: liabilities.cash_flow_unit = "
                                                                 "'million USD / month' names USD"),
    ({"cash_flow_unit": "  cash_flow_unit: million / (month"}, "is not a unit (TokenError"),
    ({"cash_flow_unit": "  cash_flow_unit: percent / month"}, "'percent' is no amount of money"),
    ({"risk_aversion": "  risk_aversion: -1"}, "line 48: objective.risk_aversion = -1"),
    ({"inflation_vol": "  inflation_vol: -0.01"}, "line 15: market.inflation_vol = -0.01"),
    ({"volatility": "      volatility: 3"}, "line 24: market.equity_vols"),
    ({"mix": "  mix: {cash: 0.05, bond_short: 0.15, bond_long: 0.3, inflation_linked: 0.1, credit: 0.1, equity: 0.2}"},
     "line 41: assets.mix = "),
    ({"mix": MIX + "\n  strategic_mix: {cash: 0.05, bond_short: 0.15, bond_long: 0.3, inflation_linked: 0.1, credit: 0.1, "
                   "equity: 0.2}"}, "line 42: assets.strategic_mix = {'cash': 0.05"),
    ({"mix": MIX + "\n  strategic_mix: {cash: -0.1, bond_short: 0.25, bond_long: 0.35, inflation_linked: 0.1, credit: 0.1, "
                   "equity: 0.3}"}, "(sum 1); allowed: a weight in [0, 1] per asset class, summing to 1"),
    ({"mix": MIX + "\n  strategic_mix: {cash: 0.5, equity: 0.5}"}, "line 42: assets.strategic_mix has no ['bond_short'"),
    ({"mix": MIX + "\n  strategic_mix: {cash: 0.5, equity: abc}"}, "assets.strategic_mix.equity = 'abc'"),
])
def test_errors_found_after_the_schema_name_the_line(tmp_path, change, message):
    path = _fund(tmp_path, "month,cash_flow\n1,2\n", **change)
    with pytest.raises(InputError) as raised:
        alm.load_fund(path)
    assert message in str(raised.value), str(raised.value)


def test_cohort_names_and_repeated_factor_names_are_refused(tmp_path):
    with pytest.raises(InputError, match=r"line 2: cohort = ''; allowed: a name of letters"):
        alm.load_fund(_fund(tmp_path, "cohort,month,cash_flow\n ,1,2\n"))
    path = _fund(tmp_path, "month,cash_flow\n1,2\n", name="name: x\nmarket:", market="",
                 key_tenors="  key_tenors: [0.25, 0.2501, 0.4596295312869421, 0.8450372241242164, 1.5536162529769293, "
                            "2.856351640622245, 5.2514542630795615, 9.654893846056297, 17.75069733235215, 60.0]")
    with pytest.raises(InputError, match="factor name 'key_rate_0.25y' is given to two factors"):
        alm.build_fund_study(alm.load_fund(path))
