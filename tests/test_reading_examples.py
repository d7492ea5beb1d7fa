"""The cases of a probe of careless and hostile input, each now refused with one line (exit 2)
naming the file, the line, the field and the value's text, before anything is compiled or handed
to Cantera; or, for a result that is not finite after a computation, exit 3. The classes behind
them are generated for every loader in tests/test_reading_hostile.py."""

import io
import json
import shutil
import zipfile

import numpy as np
import pytest

import snapo_ode
from chemistry import MECHANISMS, Mechanism
from chemistry.pharma._process import molar_masses
from chemistry.pharma._process_file import BUILT_IN_PROCESS, read_process_file
from finance import alm
from finance import gas_storage as gs
from finance.alm import _scenario_file
from finance.alm._liability_file import load_liabilities
from finance.alm._scenario_file import ScenarioSet, load_scenarios, variable_names, write_scenarios
from reading_hostile import npy_bytes
from snapo_ode.cli import main

FUND = alm.sample_fund_path()
FUND_TEXT = FUND.read_text()
DIGITS = "9" * 5000


def error_of(argv, capsys, code=2) -> str:
    assert main(argv) == code
    err = capsys.readouterr().err
    assert err.startswith("snapo: error: ") and err.count("\n") == 1 and "Traceback" not in err, err
    return err


def fund_file(tmp_path, old: str, new: str):
    assert old in FUND_TEXT
    shutil.copy(FUND.parent / "alm_liabilities.csv", tmp_path / "alm_liabilities.csv")
    path = tmp_path / "fund.yaml"
    path.write_text(FUND_TEXT.replace(old, new, 1))
    return path


def refused(load, *fragments: str) -> str:
    with pytest.raises(snapo_ode.InputError) as caught:
        load()
    message = str(caught.value)
    assert "\n" not in message and all(fragment in message for fragment in fragments), message
    return message


@pytest.mark.parametrize("text", ["0.02_5", "6_0", "0.4_5", "1_000"])
def test_yaml_underscores_are_text_so_a_number_field_refuses_them(tmp_path, text):
    # YAML 1.1 read 0.02_5 as 0.025 (a wrong result, exit 0); YAML 1.2's core schema reads text.
    assert snapo_ode.read_yaml(f"a: {text}", "f") == {"a": text}
    path = fund_file(tmp_path, "  inflation: 0.02\n", f"  inflation: {text}\n")
    refused(lambda: alm.load_fund(path), f"{path}, line 14: market.inflation = '{text}'", "valid number")


def test_a_fund_with_underscores_exits_2_from_the_command_line(tmp_path, capsys):
    path = fund_file(tmp_path, "horizon_months: 120", "horizon_months: 6_0")
    err = error_of(["alm", "--fund", str(path), "--out", str(tmp_path / "out")], capsys)
    assert f"{path}, line 8: horizon_months = '6_0'" in err


@pytest.mark.parametrize("date", ["2026-02-30", "2026-13-01"])
def test_dates_that_are_no_day_are_refused_naming_the_field(tmp_path, date):
    # The YAML reader raised "day is out of range for month" before the schema saw the field.
    path = fund_file(tmp_path, "  cash_flow_unit: million / month\n",
                     f"  cash_flow_unit: million / month\n  valuation_date: {date}\n")
    refused(lambda: alm.load_fund(path), "liabilities.valuation_date", date, "not a date of the calendar")
    path = fund_file(tmp_path, "horizon_months: 120", f"horizon_months: {date}")
    refused(lambda: alm.load_fund(path), f"horizon_months = '{date}'")
    process = tmp_path / "process.yaml"
    process.write_text(_process_text().replace("growth_order: 1.5", f"growth_order: {date}"))
    refused(lambda: read_process_file(process), "growth_order", date)


def test_a_real_valuation_date_still_reads():
    spec = alm._fund_schema.LiabilitiesSection.model_validate(dict(file="x.csv", valuation_date="2026-12-31"))
    assert str(spec.valuation_date) == "2026-12-31"


@pytest.mark.parametrize("tagged", ["!!omap [a: 1]", "!!set {a, b}", "!!binary aGk=", "!!timestamp 2026-01-01",
                                    "!!python/object/apply:os.system ['true']", "!local 3"])
def test_yaml_tags_beyond_the_core_schema_are_refused_with_the_line(tmp_path, tagged):
    path = fund_file(tmp_path, "  inflation: 0.02\n", f"  inflation: {tagged}\n")
    refused(lambda: alm.load_fund(path), f"{path}, line 14: the YAML tag {tagged.split()[0]}", "is not read")


def test_hexadecimal_and_octal_integers_read_one_way_for_every_field(tmp_path):
    assert snapo_ode.read_yaml("a: 0x10\nb: 0o17\nc: 0b11\nd: 010", "f") == {"a": 16, "b": 15, "c": "0b11", "d": 10}
    fund = alm.load_fund(fund_file(tmp_path, "horizon_months: 120", "horizon_months: 0x10"))
    assert fund.horizon_months == 16
    # A float field reads 0x10 as 16.0 too; the market's range then refuses it in one line.
    path = fund_file(tmp_path, "  inflation: 0.02\n", "  inflation: 0x10\n")
    refused(lambda: alm.load_fund(path), "inflation")


def test_five_thousand_digit_integers_are_refused_in_every_loader(tmp_path):
    path = fund_file(tmp_path, "horizon_months: 120", f"horizon_months: {DIGITS}")
    refused(lambda: alm.load_fund(path), f"{path}, line 8: a number written with 5,000 characters")
    facility = tmp_path / "facility.json"
    facility.write_text(json.dumps({**gs.sample_facility(), "capacity": 1.0}).replace("1.0", DIGITS, 1))
    refused(lambda: gs.load_facility(facility), "a number written with 5,000 characters")
    liabilities = tmp_path / "liabilities.csv"
    liabilities.write_text(f"first_month,last_month,cash_flow\n1,{DIGITS},1.0\n")
    refused(lambda: load_liabilities(liabilities), "line 2: last_month", "allowed: a whole number >= 1")
    liabilities.write_text(f"month,cash_flow\n1,{DIGITS}\n")
    refused(lambda: load_liabilities(liabilities), "line 2: cash_flow is written with 5,000 characters")
    process = tmp_path / "process.yaml"
    process.write_text(_process_text().replace("growth_order: 1.5", f"growth_order: {DIGITS}"))
    refused(lambda: read_process_file(process), "a number written with 5,000 characters")


def _process_text() -> str:
    mechanism = (BUILT_IN_PROCESS.parent / "../../mechanisms/pharma.yaml").resolve()
    return BUILT_IN_PROCESS.read_text().replace("file: ../../mechanisms/pharma.yaml", f"file: {mechanism}")


RECURSIVE = "junk: &r [1, *r]\n"


def test_a_recursive_alias_never_reaches_cantera(tmp_path, capsys):
    # Cantera expanded `&r [1, *r]` into a segfault (exit 139).
    mechanism = tmp_path / "mechanism.yaml"
    mechanism.write_text(RECURSIVE + (MECHANISMS / "pharma.yaml").read_text())
    err = error_of(["kinetics", "check", str(mechanism), "--out", str(tmp_path / "k")], capsys)
    assert f"mechanism file {mechanism}, line 1: the YAML alias *r lies inside the node it names" in err
    process = tmp_path / "process.yaml"
    process.write_text(_process_text().replace(f"file: {(MECHANISMS / 'pharma.yaml').resolve()}", f"file: {mechanism}"))
    refused(lambda: molar_masses(read_process_file(process)), "the YAML alias *r lies inside the node it names")


def test_an_aliased_string_is_refused_not_expanded(tmp_path):
    # 200 KB aliased 30,000 times grew to 4.6 GB: the old bound counted nodes, not bytes.
    text = f"big: &s '{'x' * 99_000}'\nmany: [{', '.join(['*s'] * 30_000)}]\n"
    mechanism = tmp_path / "mechanism.yaml"
    mechanism.write_text(text + (MECHANISMS / "pharma.yaml").read_text())
    refused(lambda: snapo_ode.check_cantera_yaml(mechanism.read_text(), "mechanism"), "line 2: its YAML aliases (*name) "
            "expand it past 10 times its own size")
    path = fund_file(tmp_path, "currency: EUR\n", "currency: EUR\n" + text)
    refused(lambda: alm.load_fund(path), "a YAML alias (*s)")


def test_a_huge_scalar_in_a_cantera_file_is_refused_before_cantera(tmp_path):
    for extra, message in ((f"note: '{'x' * 200_000}'\n", "a value of 200,000 characters"),
                           (f"note: {DIGITS}\n", "a number written with 5,000 characters")):
        mechanism = tmp_path / "mechanism.yaml"
        mechanism.write_text(extra + (MECHANISMS / "pharma.yaml").read_text())
        refused(lambda: Mechanism.from_yaml(mechanism, "liquid"), message)


def test_deep_nesting_and_an_oversized_settings_file_are_refused_at_once(tmp_path):
    # 3,000 brackets took 44-151 s; a 6 MB fund file gave no answer in 600 s.
    path = fund_file(tmp_path, "  inflation: 0.02\n", f"  inflation: {'[' * 3000}{']' * 3000}\n")
    refused(lambda: alm.load_fund(path), f"{path}, line 14: nested more than 64 levels deep")
    path = fund_file(tmp_path, "currency: EUR\n", "currency: EUR\nnote: [" + "0.5, " * 1_200_000 + "0]\n")
    refused(lambda: alm.load_fund(path), "larger than 262,144 bytes")
    facility = tmp_path / "facility.json"
    facility.write_text("[" * 100_000 + "]" * 100_000)
    refused(lambda: gs.load_facility(facility), "nested")


@pytest.fixture(scope="module")
def market():
    return alm.load_fund(FUND).market


def _scenario_values(market):
    names = variable_names(market)
    values = np.empty((5, 2, len(names)))
    values[..., :market.n_tenors] = 0.02
    values[..., market.n_tenors:-3] = 1.0
    values[..., -3], values[..., -2], values[..., -1] = 1.0, 0.02, 0.01
    return values


def test_an_npz_whose_headers_declare_gigabytes_is_refused_before_it_is_unpacked(tmp_path, market, monkeypatch):
    # An 11 MB NPZ unpacked to 11.6 GB and stopped only at the ulimit.
    path = tmp_path / "bomb.npz"
    with zipfile.ZipFile(path, "w", zipfile.ZIP_DEFLATED) as archive:
        archive.writestr("values.npy", npy_bytes((1_450_000_000,)))
        archive.writestr("times.npy", npy_bytes((5,), data=np.zeros(5).tobytes()))
    refused(lambda: load_scenarios(path, market, 4, spread=0.01), "declare more than 134,217,728 values")
    # A real deflate bomb at a small scale: refused from its headers, np.load never called.
    with zipfile.ZipFile(path, "w", zipfile.ZIP_DEFLATED) as archive:
        buffer = io.BytesIO()
        np.save(buffer, np.zeros((1000, 5, 14)))
        archive.writestr("values.npy", buffer.getvalue())
    monkeypatch.setattr(_scenario_file, "MAX_SCENARIO_VALUES", 1000)
    monkeypatch.setattr(np, "load", lambda *a, **k: pytest.fail("np.load ran"))
    refused(lambda: load_scenarios(path, market, 4, spread=0.01), "declare more than 1,000 values", "(1000, 5, 14)")


def test_a_pickled_npz_is_refused(tmp_path, market):
    path = tmp_path / "pickle.npz"
    buffer = io.BytesIO()
    np.save(buffer, np.array([{"a": 1}], dtype=object), allow_pickle=True)
    with zipfile.ZipFile(path, "w") as archive:
        archive.writestr("values.npy", buffer.getvalue())
    refused(lambda: load_scenarios(path, market, 4, spread=0.01), "holds Python objects (a pickle)")


def test_a_parquet_of_too_many_rows_is_refused_from_its_footer(tmp_path, market, monkeypatch):
    # A 6 MB Parquet of 400 M rows stopped only at the ulimit.
    import pyarrow.parquet

    path = write_scenarios(tmp_path / "set.parquet", ScenarioSet(_scenario_values(market), "x"), market)
    rows = pyarrow.parquet.ParquetFile(path).metadata.num_rows
    monkeypatch.setattr(_scenario_file, "MAX_SCENARIO_VALUES", rows - 1)
    monkeypatch.setattr(pyarrow.parquet, "read_table", lambda *a, **k: pytest.fail("the table was read"))
    refused(lambda: load_scenarios(path, market, 4, spread=0.01), f"{rows:,} rows", f"at most {rows - 1:,} rows")


@pytest.mark.parametrize("variable, value, fragment", [
    ("cpi", 1e-300, "cpi = 1e-300; allowed: within a factor of 1000 of the scenario's value at time 0"),
    ("inflation", 1e6, "inflation = 1e+06; allowed: [-1, 1] per year"),
    ("spread", -3.0, "spread = -3; allowed: [-1, 1] per year"),
    ("equity_equity_0", 1e9, "equity_equity_0 = 1e+09; allowed: within a factor of 10000")])
def test_finite_but_extreme_scenario_values_are_refused_naming_the_variable_and_the_cell(
        tmp_path, market, variable, value, fragment):
    # A CPI of 1e-300 or inflation of 1e6 was a FloatingPointError traceback after the compile.
    values = _scenario_values(market)
    values[3, 1, variable_names(market).index(variable)] = value
    path = write_scenarios(tmp_path / "set.csv", ScenarioSet(values, "x"), market)
    refused(lambda: load_scenarios(path, market, 4, spread=0.01), fragment, "(scenario 2 in the file's order, time 0.25)")


@pytest.mark.parametrize("argv", [["gas", "--seed", str(2**64)], ["pharma", "train", "--seed", str(2**64)],
                                  ["gas", "--seed", "-1"], ["gas", "--seed", "1_0"]])
def test_a_seed_beyond_64_bits_is_refused_naming_the_flag_and_its_range(argv, capsys):
    err = error_of(argv, capsys)
    assert "argument --seed:" in err and ("allowed from 0 to 9223372036854775807" in err or "not a whole number" in err)


def test_a_list_flag_names_the_entry_that_is_no_number(capsys):
    err = error_of(["bench", "pharma", "--rtols", "abc"], capsys)
    assert "argument --rtols: entry 1: 'abc' is not a number" in err
    err = error_of(["bench", "pharma", "--rtols", "1e-6,2"], capsys)
    assert "argument --rtols: entry 2: 2 is out of range: allowed (0, 1)" in err


def test_a_non_finite_result_after_a_computation_is_exit_3(capsys):
    from snapo_ode._runtime.exits import EXIT_SOLVER_FAILED, ended

    def run():
        raise FloatingPointError("the ALM objective is not finite (nan, smooth nan); check the inputs.")

    assert ended(run) == EXIT_SOLVER_FAILED
    err = capsys.readouterr().err
    assert err == "snapo: error: the ALM objective is not finite (nan, smooth nan); check the inputs.\n"


def test_an_npz_of_complex_values_is_refused_not_cast(tmp_path, market):
    path = tmp_path / "complex.npz"
    np.savez(path, values=np.ones((2, 5, 14), complex), times=np.arange(5) / 12, variables=np.array(["cpi"] * 14))
    refused(lambda: load_scenarios(path, market, 4, spread=0.01), "the array 'values' holds complex128 values")


def test_a_ragged_correlation_is_refused_naming_the_field(tmp_path):
    # Found by the long hostile-document profile: a NumPy ValueError (an inhomogeneous shape).
    path = fund_file(tmp_path, "      volatility: 0.15\n", "      volatility: 0.15\n  correlation: [[1, 2], [3]]\n")
    refused(lambda: alm.load_fund(path), "market.correlation has rows of [1, 2] entries")
