"""`snapo report alm` and `snapo report gas` at small sizes: every number in the HTML is the JSON's
and so is every number in the PDF (printed from the HTML by headless Chromium), under the same
sections; the ladders add up; the gas report reads the LSMC comparison's optional fields only
when present."""

import csv

import pytest

import snapo_ode
from snapo_ode.cli import main

from report_checks import check_html, check_pdf, check_reader

HAS_CHROMIUM = snapo_ode.find_chromium() is not None


@pytest.fixture(scope="module")
def alm_dir(tmp_path_factory):
    out = tmp_path_factory.mktemp("alm") / "report"
    assert main(["report", "alm", "--out", str(out), "--risk-factors", "20", "--paths", "64", "--horizon-months", "24",
                 "--train-steps", "5", "--train-paths", "32", "--bump-sample", "8", "--no-progress"]) == 0
    return out


@pytest.fixture(scope="module")
def gas_dir(tmp_path_factory):
    out = tmp_path_factory.mktemp("gas") / "report"
    assert main(["report", "gas", "--out", str(out), "--train-steps", "30", "--no-progress"]) == 0
    return out


def test_alm_report(alm_dir):
    doc, page = check_html(alm_dir)
    assert doc["report"]["sections"] == ["Summary", "Funding ratio and objective", "For the board", "Sensitivity ladder",
                                         "Policy behaviour", "Methods", "Appendix: settings and timings", "Provenance"]
    text = check_reader(page)
    assert "million EUR" in text and doc["currency"] == "EUR"  # the built-in fund's, a fund file's default
    assert doc["p_underfunded"]["months"] == [12, 24] and len(doc["funding_ratio_percentiles"]["p50"]) == 25
    board = list(csv.reader((alm_dir / "board.csv").open()))
    assert len(board) == 3 and float(board[2][1]) == doc["p_underfunded"]["below_1"][1]
    assert set(doc["ladder"]) == {"key_rates", "inflation", "spread", "equity_levels"}
    for group in doc["ladder"].values():
        assert group["total_objective"] == pytest.approx(sum(r["objective"] for r in group["rows"]))
    key_rates = doc["ladder"]["key_rates"]["rows"]
    assert key_rates[0]["objective"] == pytest.approx(doc["sensitivities"][key_rates[0]["factor"]] * 1e-4)
    # The adjoint against central bumps on a sample: 8 of 20, the two largest always among them.
    assert doc["max_rel_diff"] <= 1e-5 and doc["bump_checked"] == 8 and doc["bump_total"] == 20
    largest = sorted(doc["sensitivities"], key=lambda name: -abs(doc["sensitivities"][name]))[:2]
    assert set(largest) <= set(doc["checked"])
    for name, row in doc["checked"].items():
        assert row["adjoint"] == pytest.approx(doc["sensitivities"][name], rel=1e-12)
    start = doc["starting_position"]
    assert start["funding_ratio"] == pytest.approx(doc["initial_funding_ratio"], rel=1e-12)
    assert start["liabilities"] == pytest.approx(doc["initial_liability_value"], rel=1e-12)
    assert sum(start["mix"].values()) == pytest.approx(1.0)
    buckets = doc["ladder"]["key_rates"]["buckets"]  # the split onto market buckets keeps the total
    assert sum(buckets["funding_ratio_pp"]) == pytest.approx(doc["ladder"]["key_rates"]["total_funding_ratio_pp"])
    assert doc["ladder"]["key_rates"]["total_funding_ratio_pp"] == pytest.approx(
        100 * 0.01 * sum(doc["funding_ratio_sensitivities"][r["factor"]] for r in key_rates))
    assert set(doc["baselines"]) == {"sixty_forty", "liability_matching"} and len(doc["policy_names"]) == 3
    assert doc["strategic_mix"] is None  # the built-in fund names none: said, not invented
    # Every policy's board figures side by side: the studied policy's are the page's own.
    compared = list(csv.DictReader((alm_dir / "board_policies.csv").open()))
    assert [row["policy"] for row in compared] == [name for name in doc["policy_names"] for _ in range(2)]
    assert float(compared[1]["P(funding ratio below one)"]) == doc["p_underfunded"]["below_1"][1]
    assert float(compared[3]["surplus at risk [million EUR]"]) == doc["baselines"]["sixty_forty"]["board"][
        "surplus_at_risk"]["surplus_at_risk"][1]
    rows = list(csv.reader((alm_dir / "sensitivities.csv").open()))
    assert len(rows) == 1 + doc["n_risk_factors"]
    assert not (alm_dir.parent / "report.checkpoint.eqx").is_dir()
    if HAS_CHROMIUM:
        check_pdf(alm_dir, doc, page)


def test_key_rates_split_onto_market_buckets_by_distance():
    from finance.alm._report import bucket_weights

    weights = bucket_weights([0.46, 1.5, 17.8])
    assert weights.shape == (8, 3)  # buckets 1y to 20y: the longest tenor's upper neighbour is the last
    assert weights[:, 0].tolist() == [1.0] + [0.0] * 7
    assert weights[0, 1] == weights[1, 1] == 0.5
    assert weights[6, 2] == pytest.approx(0.44) and weights[7, 2] == pytest.approx(0.56)
    assert weights.sum(axis=0) == pytest.approx(1.0)


def test_gas_report(gas_dir):
    doc, page = check_html(gas_dir)
    assert doc["report"]["sections"] == ["Summary", "Value", "Monthly delta ladder", "Schedule",
                                         "Facility sensitivities", "Methods", "Provenance"]
    ladder = doc["monthly_ladder"]
    assert len(ladder) == 12 and ladder[0]["first_day"] == 0 and ladder[-1]["last_day"] == 364
    # The sample's calendar (1 April, an illustrative year) and units, the desk's names for the inputs.
    assert [ladder[0]["month_name"], ladder[-1]["month_name"]] == ["Apr 2025", "Mar 2026"]
    assert ladder[0]["last_day"] == 29 and ladder[-1]["first_day"] == 365 - 31
    text = check_reader(page)
    assert "This is the intrinsic value" in text and "USD/MMBtu" in text and "$" not in text
    names = {row["input"]: row["name"] for row in doc["facility_sensitivities"]}
    assert names["capacity"] == "working gas capacity"
    assert names["injection_ratchet[1][0]"] == "injection ratchet, point 2, fill level"
    assert all("[" not in name and "_" not in name for name in names.values())
    assert sum(r["delta"] for r in ladder) == pytest.approx(sum(doc["deltas"]))
    assert not doc["lsmc_run"] and not doc["has_dual_bound"]
    assert len(doc["facility_sensitivities"]) == len(doc["parameter_sensitivities"])
    if HAS_CHROMIUM:
        check_pdf(gas_dir, doc, page)


def test_gas_report_lsmc_on_a_grid_that_cannot_trade_is_refused_before_computing(capsys):
    """`--lsmc` without `--lsmc-nodes` takes the one-factor default of 101 levels, on which the
    sample facility's daily injection is less than a step: refused with the grid that trades."""
    assert main(["report", "gas", "--out", "unused", "--stochastic", "--lsmc", "--no-progress"]) == 2
    error = capsys.readouterr().err
    assert "lsmc_nodes = 101" in error and "--lsmc-nodes 106" in error


@pytest.mark.parametrize("flag", ["--price-model", "--train-paths-file", "--value-paths-file"])
def test_gas_report_refuses_a_price_model_or_paths_file_it_would_not_use(capsys, flag):
    """The report values the built-in one-factor model: a desk's model or paths are refused, not ignored."""
    assert main(["report", "gas", "--out", "unused", flag, "desk.file"]) == 2
    error = capsys.readouterr().err
    assert f"{flag} desk.file" in error and f"snapo gas {flag}" in error


def test_gas_report_refuses_a_unit_that_is_not_one(capsys):
    assert main(["report", "gas", "--out", "unused", "--currency", "U S D"]) == 2
    assert "--currency = 'U S D' is not a unit" in capsys.readouterr().err


def test_gas_report_reads_the_optional_lsmc_fields_when_present():
    """The report's content over an LSMC comparison with the dual bound (fields another change adds)."""
    import datetime

    from finance.gas_storage._report import ladder, months
    from finance.gas_storage._report_content import sections

    assert months(365, datetime.date(2005, 7, 1))[0] == {"month": "2005-07", "month_name": "Jul 2005", "first_day": 0,
                                                         "last_day": 30}
    assert months(40, None)[1] == {"month": "month 2 (days 31-39)", "month_name": "month 2", "first_day": 31, "last_day": 39}
    data = {"deltas": [1.0] * 59, "lp_envelope_deltas": [2.0] * 59, "lsmc_pathwise_deltas": [3.0] * 59,
            "schedule": {"injection": [0.0] * 59, "withdrawal": [1.0] * 59, "inventory": [5.0] * 60}}
    rows = ladder(data, None)
    assert [r["lsmc_delta"] for r in rows] == [93.0, 84.0] and rows[1]["withdrawal"] == 28.0
    titles = [s.title for s in sections({**_gas_stub(), "monthly_ladder": rows})]
    assert "Value" in titles


def _gas_stub() -> dict:
    stub = {key: 1.0 for key in ("value_hard", "value_smooth", "smoothing_gap", "intrinsic_lp", "hard_to_lp_ratio",
                                 "max_constraint_violation", "lsmc_out_of_sample", "lsmc_se", "dual_upper_bound",
                                 "dual_upper_bound_se", "snapo_gap", "lsmc_gap", "snapo_gap_se", "lsmc_gap_se",
                                 "snapo_value_control_variate", "snapo_value_control_variate_se",
                                 "lsmc_value_control_variate", "lsmc_value_control_variate_se")}
    stub.update(lsmc_run=True, has_dual_bound=True, largest_month={"month": "m", "month_name": "m", "delta": 1.0},
                currency="EUR", energy_unit="MWh", price_unit="EUR/MWh", mode="stochastic", forward_curve=[1.0] * 59,
                schedule={"inventory": [1.0] * 60}, lp_schedule={"inventory": [1.0] * 60}, facility_sensitivities=[])
    return stub
