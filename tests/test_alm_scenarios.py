"""Scenarios from outside (`load_scenarios`, `snapo alm --scenarios`): the built-in generator's
scenarios written in each format and read back give the generated study's objective; a given
set's sensitivities equal central bumps and mean shifts of every scenario; annual sets are filled
in monthly; bad files fail naming the file, line, variable and value."""

import json

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from finance import alm
from finance.alm._cli import register_alm
from finance.alm._scenario_file import ScenarioSet, load_scenarios, variable_names, write_scenarios
from finance.alm._scenarios import generated_scenarios
from snapo_ode import InputError, bump_and_revalue, max_relative_difference, value_and_sensitivities
from snapo_ode.cli import main

HORIZON = 12


@pytest.fixture(scope="module")
def fund():
    return alm.load_fund(alm.sample_fund_path())


@pytest.fixture(scope="module")
def generated(fund):
    study = alm.build_fund_study(fund, horizon_months=HORIZON)
    return study, generated_scenarios(study, 16, jax.random.key(5))


def _objective(study, values, policy_key=4):
    policy = alm.NeuralRebalancing(study.market, key=jax.random.key(policy_key))
    fn = alm.objective_of_reported(study.problem, study.fixed)
    return fn, policy, jnp.asarray(values)


@pytest.mark.parametrize("suffix", [".npz", ".csv", ".parquet"])
def test_written_generated_scenarios_give_the_generated_objective(tmp_path, fund, generated, suffix):
    study, scenarios = generated
    path = write_scenarios(tmp_path / f"set{suffix}", scenarios, study.market)
    back = load_scenarios(path, fund.market, HORIZON, spread=float(fund.factors["spread"]))
    np.testing.assert_array_equal(back.values, scenarios.values)
    given = alm.build_fund_study(fund, horizon_months=HORIZON, scenario_set=back)
    fn, policy, values = _objective(given, back.values)
    shocks = alm.scenarios(study, 16, jax.random.key(5))
    reference_fn, _, _ = _objective(study, shocks)
    assert float(fn(given.reported, policy, values)) == pytest.approx(
        float(reference_fn(study.reported, policy, shocks)), rel=1e-12, abs=1e-14)


def test_sensitivities_on_a_given_set_equal_central_bumps_and_mean_shifting_every_scenario(fund, generated):
    _, scenarios = generated
    study = alm.build_fund_study(fund, horizon_months=HORIZON, scenario_set=scenarios)
    assert set(study.layout.reported) == {"key_rates", "equity_levels", "inflation", "spread",
                                          "liability_cash_flows", "holdings"}
    fn, policy, values = _objective(study, scenarios.values)
    value, gradient = jax.jit(lambda r: value_and_sensitivities(fn, r, policy, values))(study.reported)
    reference = bump_and_revalue(fn, study.reported, policy, values, relative_step=1e-6)
    assert max_relative_difference(gradient, reference) <= 1e-6
    # A parallel shift of every scenario's curve (the file's rates + h at every time and tenor),
    # the holdings kept, moves the objective by the sum of the key-rate sensitivities.
    h, k = 1e-5, study.market.n_tenors

    def shifted(sign):
        moved = scenarios.values.copy()
        moved[..., :k] += sign * h
        other = alm.build_fund_study(fund, horizon_months=HORIZON, scenario_set=ScenarioSet(moved, "shifted"))
        factors = {**other.reported, "holdings": study.reported["holdings"]}
        return float(fn(factors, policy, jnp.asarray(moved)))

    assert (shifted(1) - shifted(-1)) / (2 * h) == pytest.approx(float(jnp.sum(gradient["key_rates"])), rel=1e-6)


def _long_csv(path, rows):
    path.write_text("scenario,time,variable,value\n" + "".join(f"{s},{t},{v},{x}\n" for s, t, v, x in rows))
    return path


def _annual_rows(fund, scenarios=("a", "b"), years=2, variables=None):
    names = variables or ["zero_rate_1", "zero_rate_10", *(f"equity_{n}" for n in fund.market.equity_names), "cpi"]
    rows = []
    for s, scenario in enumerate(scenarios):
        for year in range(years + 1):
            for name in names:
                value = {"zero_rate_1": 0.02 + 0.001 * year * s, "zero_rate_10": 0.03,
                         "cpi": 1.02 ** year}.get(name, 1.1 ** year)
                rows.append((scenario, year, name, value))
    return rows


def test_an_annual_set_is_filled_in_monthly_on_the_funds_key_tenors(tmp_path, fund):
    path = _long_csv(tmp_path / "annual.csv", _annual_rows(fund))
    loaded = load_scenarios(path, fund.market, 24, spread=0.01)
    assert loaded.values.shape == (25, 2, fund.market.n_tenors + fund.market.n_equities + 3)
    names = variable_names(fund.market)
    tenors = fund.market.tenors
    month = 18  # halfway through year 2, scenario b: rate at 1y 0.021 -> 0.022
    expected_1y = 0.0215
    expected = np.interp(tenors, [1.0, 10.0], [expected_1y, 0.03])  # flat beyond both ends
    np.testing.assert_allclose(loaded.values[month, 1, :len(tenors)], expected, rtol=1e-13)
    np.testing.assert_allclose(loaded.values[month, 1, names.index("cpi")], 1.02 ** 1.5, rtol=1e-13)
    np.testing.assert_allclose(loaded.values[month, 1, names.index("inflation")], np.log(1.02), rtol=1e-12)
    np.testing.assert_allclose(loaded.values[month, 1, names.index("spread")], 0.01)


@pytest.mark.parametrize("edit, message", [
    (lambda rows: rows + [("a", 0, "zero_rate_1", 0.02)], "line 26: scenario 'a', time 0, zero_rate_1 is given twice"),
    (lambda rows: rows[1:], "scenario 'a' has no zero_rate_1 at time 0"),
    (lambda rows: [r if r[2] != "cpi" else (r[0], r[1], "cpi", -1.0) for r in rows], "cpi = -1; allowed: an index > 0"),
    (lambda rows: [(r[0], r[1], "oil", r[3]) if r[2] == "cpi" else r for r in rows], "unknown variable 'oil'"),
    (lambda rows: [r for r in rows if not r[2].startswith("equity")], "no 'equity_equity_0'"),
    (lambda rows: [(r[0], r[1] * 0.5, r[2], r[3]) for r in rows], "allowed: from 0 in steps of one month"),
    (lambda rows: [r if r != ("a", 1, "zero_rate_1", 0.02) else ("a", 1, "zero_rate_1", "x") for r in rows],
     "line 6: value = 'x'; allowed: a finite number"),
])
def test_bad_scenario_files_name_the_file_line_and_variable(tmp_path, fund, edit, message):
    path = _long_csv(tmp_path / "bad.csv", edit(_annual_rows(fund)))
    with pytest.raises(InputError) as raised:
        load_scenarios(path, fund.market, 12, spread=0.01)
    assert message in str(raised.value), str(raised.value)


def test_a_set_too_short_or_starting_apart_is_refused(tmp_path, fund):
    path = _long_csv(tmp_path / "short.csv", _annual_rows(fund, years=1))
    with pytest.raises(InputError, match="the scenarios end at 1 years; the study's horizon is 24 months"):
        load_scenarios(path, fund.market, 24, spread=0.01)
    rows = [(s, t, v, x + 0.01 if (s, t, v) == ("b", 0, "zero_rate_10") else x) for s, t, v, x in _annual_rows(fund)]
    # The file's variable, not the fund's key tenor it is interpolated onto.
    with pytest.raises(InputError, match="zero_rate_10 differs between scenarios at the first time: 0.03 in scenario "
                                         "'a', 0.04 in scenario 'b'"):
        load_scenarios(_long_csv(tmp_path / "apart.csv", rows), fund.market, 12, spread=0.01)


@pytest.mark.parametrize("cell, message", [
    ("nan", "line 6: value = 'nan'; allowed: a finite number"), ("inf", "line 6: value = 'inf'"),
    ("0.7", "scenario 'a', time 1: zero_rate_1 = 0.7; allowed: (-0.5, 0.5)")])
def test_bad_cells_are_named_by_their_text_and_the_files_variable(tmp_path, fund, cell, message):
    rows = [r if r != ("a", 1, "zero_rate_1", 0.02) else ("a", 1, "zero_rate_1", cell) for r in _annual_rows(fund)]
    with pytest.raises(InputError) as raised:
        load_scenarios(_long_csv(tmp_path / "bad.csv", rows), fund.market, 12, spread=0.01)
    assert message in str(raised.value) and "np.float64" not in str(raised.value), str(raised.value)


def test_snapo_alm_writes_and_reads_a_scenario_set(tmp_path, capsys):
    written, out = tmp_path / "set.npz", tmp_path / "given.json"
    run = ["alm", "--horizon-months", "3", "--no-progress"]
    assert main([*run, "--paths", "8", "--write-scenarios", str(written), "--json", str(tmp_path / "gen.json")],
                plugins=[register_alm]) == 0
    assert main([*run, "--scenarios", str(written), "--json", str(out)], plugins=[register_alm]) == 0
    payload, generated_run = json.loads(out.read_text()), json.loads((tmp_path / "gen.json").read_text())
    assert payload["scenarios"] == str(written) and payload["paths"] == 8
    assert payload["objective"] == pytest.approx(generated_run["objective"], rel=1e-12)
    assert payload["initial_funding_ratio"] == pytest.approx(1.1, rel=1e-12)
    assert main([*run, "--scenarios", str(written), "--paths", "4"], plugins=[register_alm]) == 2
    assert "give one of the two" in capsys.readouterr().err


def test_a_random_price_index_without_inflation_starts_alike_and_grows_ahead(tmp_path, fund):
    rows = [(s, t, v, x * (1.01 + 0.01 * i) ** t if v == "cpi" else x)
            for s, t, v, x in _annual_rows(fund, scenarios=("a", "b", "c"))
            for i in [("a", "b", "c").index(s)]]
    loaded = load_scenarios(_long_csv(tmp_path / "random_cpi.csv", rows), fund.market, 24, spread=0.01)
    names = variable_names(fund.market)
    inflation = loaded.values[:, :, names.index("inflation")]
    cpi_growth = np.log([1.02 * 1.01, 1.02 * 1.02, 1.02 * 1.03])  # each scenario's yearly growth
    np.testing.assert_allclose(inflation[0], cpi_growth.mean(), rtol=1e-12)  # time 0: the set's mean
    np.testing.assert_allclose(inflation[12], cpi_growth, rtol=1e-12)  # a year on: the year ahead's
    alm.build_fund_study(fund, horizon_months=24, scenario_set=loaded)  # starts alike: accepted


def test_a_tenor_given_twice_and_blank_lines(tmp_path, fund):
    rows = _annual_rows(fund) + [(s, t, "zero_rate_1.0", 0.02) for s in "ab" for t in range(3)]
    with pytest.raises(InputError, match="zero_rate_1 and zero_rate_1.0 are the same tenor"):
        load_scenarios(_long_csv(tmp_path / "twice.csv", rows), fund.market, 12, spread=0.01)
    path = _long_csv(tmp_path / "blank.csv", _annual_rows(fund))
    text = path.read_text().splitlines(keepends=True)
    text[2] = "\n" + text[2].replace("zero_rate_10,0.03", "zero_rate_10,x")  # a blank line 3, the row on 4
    path.write_text("".join(text))
    with pytest.raises(InputError, match=r"line 4: value = 'x'"):
        load_scenarios(path, fund.market, 12, spread=0.01)


def test_a_parquet_or_npz_nan_is_named_by_scenario_time_and_variable(tmp_path, fund):
    import pandas as pd

    rows = [r if r != ("b", 2, "cpi", 1.02 ** 2) else ("b", 2, "cpi", float("nan")) for r in _annual_rows(fund)]
    table = pd.DataFrame(rows, columns=["scenario", "time", "variable", "value"])
    table.to_parquet(tmp_path / "bad.parquet")
    with pytest.raises(InputError, match=r"bad.parquet, row \d+: value = 'nan'; allowed: a finite number"):
        load_scenarios(tmp_path / "bad.parquet", fund.market, 12, spread=0.01)
    names = sorted(set(table["variable"]))
    values = np.ones((2, 3, len(names)))
    values[1, 2, names.index("cpi")] = np.nan
    np.savez(tmp_path / "bad.npz", values=values, times=np.arange(3.0), variables=np.array(names))
    with pytest.raises(InputError, match=r"bad.npz: scenario '1', time 2: cpi = nan; allowed: a finite number"):
        load_scenarios(tmp_path / "bad.npz", fund.market, 12, spread=0.01)
