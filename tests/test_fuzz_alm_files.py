"""Malformed fund files end in `InputError` (naming what is wrong) or in a correct load, never in
another exception: random line mutations of the fund YAML, truncations and odd values in the
liability CSV, and truncated or corrupted scenario files (CSV and NPZ)."""

import shutil

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from finance import alm
from finance.alm._scenario_file import load_scenarios, write_scenarios
from finance.alm._scenarios import generated_scenarios
from fuzzing import loads_or_input_error, mutated_yaml_lines

SAMPLE = alm.sample_fund_path()
FUND_LINES = SAMPLE.read_text().splitlines(keepends=True)
LIABILITIES = (SAMPLE.parent / "alm_liabilities.csv").read_text()
FUZZ = settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
ODD = ["[]", "{}", "abc", "-1", "0", "1e400", ".nan", "null", "[1, 2, 3]", "{a: x}", "true", "'1.0'", "2026-01-01"]


@FUZZ
@given(data=st.data())
def test_mutated_fund_yaml(tmp_path, data):
    lines = mutated_yaml_lines(data, FUND_LINES, ODD)
    (tmp_path / "fund.yaml").write_text("".join(lines))
    shutil.copy(SAMPLE.parent / "alm_liabilities.csv", tmp_path / "alm_liabilities.csv")
    fund = loads_or_input_error(lambda: alm.load_fund(tmp_path / "fund.yaml"))
    if fund is not None:
        study = loads_or_input_error(lambda: alm.build_fund_study(fund, horizon_months=2))
        if study is not None:
            assert np.isfinite(alm.initial_funding_ratio(study.problem, {**study.fixed, **study.reported}))


@FUZZ
@given(cut=st.integers(0, len(LIABILITIES)), junk=st.text(max_size=8),
       odd=st.sampled_from(["nan", "inf", "-1", "1e400", "0x10", "", "3,4", "1;2", '"7"']))
def test_truncated_or_odd_liability_csv(tmp_path, cut, junk, odd):
    text = LIABILITIES[:cut] + junk
    (tmp_path / "alm_liabilities.csv").write_text(text.replace(",4.", f",{odd}", 1))
    shutil.copy(SAMPLE, tmp_path / "fund.yaml")
    fund = loads_or_input_error(lambda: alm.load_fund(tmp_path / "fund.yaml"))
    if fund is not None:
        assert np.all(np.isfinite(fund.factors["liability_cash_flows"]))
        assert np.all(fund.factors["liability_cash_flows"] >= 0)


@pytest.fixture(scope="module")
def scenario_files(tmp_path_factory):
    fund = alm.load_fund(SAMPLE)
    study = alm.build_fund_study(fund, horizon_months=3)
    import jax

    generated = generated_scenarios(study, 3, jax.random.key(0))
    folder = tmp_path_factory.mktemp("scenarios")
    return fund, {suffix: write_scenarios(folder / f"set{suffix}", generated, study.market).read_bytes()
                  for suffix in (".csv", ".npz")}


@FUZZ
@given(data=st.data())
def test_truncated_or_corrupted_scenario_files(tmp_path, scenario_files, data):
    fund, files = scenario_files
    suffix = data.draw(st.sampled_from(sorted(files)))
    content = files[suffix]
    if suffix == ".csv" and data.draw(st.booleans()):
        text = content.decode()
        lines = text.splitlines(keepends=True)
        row = data.draw(st.integers(1, len(lines) - 1))
        cells = lines[row].rstrip("\n").split(",")
        cells[data.draw(st.integers(0, 3))] = data.draw(st.sampled_from(["", "nan", "x", "-1", "1e400", "0.5"]))
        lines[row] = ",".join(cells) + "\n"
        content = "".join(lines).encode()
    else:
        cut = data.draw(st.integers(0, len(content)))
        content = content[:cut] + data.draw(st.binary(max_size=8))
    path = tmp_path / f"fuzzed{suffix}"
    path.write_bytes(content)
    loaded = loads_or_input_error(lambda: load_scenarios(path, fund.market, 3, spread=0.01))
    if loaded is not None:
        assert np.all(np.isfinite(loaded.values))
        loads_or_input_error(lambda: alm.build_fund_study(fund, horizon_months=3, scenario_set=loaded))
