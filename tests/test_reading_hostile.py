"""Hostile documents, generated for each user-file loader from its own schema (tests/
reading_hostile.py: every field given the wrong type, an edge number, a YAML tag, deep nesting or
a huge size; cells, rows and headers of tables; the headers of archives), are refused with one
`InputError` line and no JAX compile, or load as valid values: never another exception.

Two profiles of the same checks: a bounded one in `make test` (BOUNDED examples per loader) and
a long one under `@pytest.mark.slow` (`make test-slow`: LONG examples per loader). The count
each ran: `pytest --hypothesis-show-statistics -k hostile`.
"""

import functools
import json
import pathlib
import warnings

import jax.monitoring
import numpy as np
import pandas as pd
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import snapo_ode
from chemistry import MECHANISMS, Mechanism
from chemistry.pharma._process_file import BUILT_IN_PROCESS, read_process_file
from chemistry.pharma._process_schema import ProcessFile
from finance import alm
from finance import gas_storage as gs
from finance.alm._fund_schema import FundFile
from finance.alm._liability_file import load_liabilities
from finance.alm._scenario_file import ScenarioSet, load_scenarios, variable_names, write_scenarios
from reading_hostile import hostile_csv, hostile_document, hostile_json_document, hostile_npz

BOUNDED, LONG = 50, 1000
_PROFILE = dict(deadline=None, derandomize=False, database=None,
                suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow,
                                       HealthCheck.data_too_large, HealthCheck.large_base_example])

_COMPILES: list[str] = []
jax.monitoring.register_event_duration_secs_listener(
    lambda event, seconds, **kwargs: _COMPILES.append(event) if "compile" in event else None)


def refused_in_one_line_or_loaded(load):
    """`load()`; a refusal must be one `InputError` line with no compile before it. Returns the
    loaded value, or None where refused (any other exception fails the test)."""
    del _COMPILES[:]
    try:
        return load()
    except snapo_ode.InputError as error:
        message = str(error)
        assert message and "\n" not in message and "Traceback" not in message, message
        assert not _COMPILES, f"compiled {_COMPILES} before refusing: {message}"
        return None


FUND = alm.sample_fund_path()
FUND_SAMPLE = snapo_ode.read_yaml(FUND.read_text(), "fund")
PROCESS_SAMPLE = snapo_ode.read_yaml(BUILT_IN_PROCESS.read_text(), "process")
PROCESS_SAMPLE["mechanism"]["file"] = str((BUILT_IN_PROCESS.parent / PROCESS_SAMPLE["mechanism"]["file"]).resolve())
MECHANISM_SAMPLE = snapo_ode.read_yaml((MECHANISMS / "pharma.yaml").read_text(), "mechanism")
LIABILITIES = (FUND.parent / "alm_liabilities.csv").read_text()
CURVE = "day,price\n" + "".join(f"{d},{p!r}\n" for d, p in enumerate(gs.sample_curve()[:40]))
FACILITY = json.loads((pathlib.Path(gs.__file__).parent.parent / "data" / "sample_facility.json").read_text())


class _Mechanism:
    """A stand-in schema for a Cantera mechanism (Cantera has none in pydantic): its sample's
    own fields are the paths generated."""

    model_fields: dict = {}


@functools.cache
def _scenario_set():
    """(fund, a valid scenario set of 3 scenarios over 4 months, in every format), built with
    NumPy only."""
    fund = alm.load_fund(FUND)
    names = variable_names(fund.market)
    months, count = 5, 3
    values = np.empty((months, count, len(names)))
    values[..., :fund.market.n_tenors] = 0.02
    growth = np.exp(0.005 * np.arange(months))[:, None]
    values[..., fund.market.n_tenors:-3] = growth[..., None]
    values[..., -3], values[..., -2], values[..., -1] = growth, 0.02, 0.01
    return fund, ScenarioSet(values, "generated")


def _write_fund(tmp: pathlib.Path, text: str) -> pathlib.Path:
    (tmp / "alm_liabilities.csv").write_text(LIABILITIES)
    (tmp / "fund.yaml").write_text(text)
    return tmp / "fund.yaml"


def check_fund(tmp, data):
    path = _write_fund(tmp, data.draw(hostile_document(FUND_SAMPLE, FundFile)))
    fund = refused_in_one_line_or_loaded(lambda: alm.load_fund(path))
    if fund is not None:
        assert all(np.all(np.isfinite(np.asarray(v, float))) for v in fund.factors.values())


def check_process(tmp, data):
    path = tmp / "process.yaml"
    path.write_text(data.draw(hostile_document(PROCESS_SAMPLE, ProcessFile)))
    spec = refused_in_one_line_or_loaded(lambda: read_process_file(path))
    if spec is not None:
        assert all(np.isfinite(float(v)) for v in spec.feed.values())


def check_mechanism(tmp, data):
    path = tmp / "mechanism.yaml"
    path.write_text(data.draw(hostile_document(MECHANISM_SAMPLE, _Mechanism)))
    mechanism = refused_in_one_line_or_loaded(lambda: Mechanism.from_yaml(path, "liquid"))
    if mechanism is not None:
        assert mechanism.n_species > 0


def check_facility(tmp, data):
    path = tmp / "facility.json"
    path.write_text(data.draw(hostile_json_document(FACILITY)))
    inputs = refused_in_one_line_or_loaded(lambda: gs.make_inputs(gs.load_facility(path), gs.sample_curve()))
    if inputs is not None:
        assert float(inputs.capacity) > 0


def check_curve(tmp, data):
    path = tmp / "curve.csv"
    path.write_text(data.draw(hostile_csv(CURVE)))
    inputs = refused_in_one_line_or_loaded(lambda: gs.make_inputs(FACILITY, gs.load_curve(path)))
    if inputs is not None:
        assert np.all(np.isfinite(np.asarray(inputs.forward_curve)))


def check_liabilities(tmp, data):
    path = tmp / "alm_liabilities.csv"
    path.write_text(data.draw(hostile_csv(LIABILITIES)))
    loaded = refused_in_one_line_or_loaded(lambda: load_liabilities(path))
    if loaded is not None:
        assert np.all(np.isfinite(loaded.cash_flows)) and np.all(loaded.cash_flows >= 0)


def _check_scenarios(path, fund):
    loaded = refused_in_one_line_or_loaded(lambda: load_scenarios(path, fund.market, 4, spread=0.01))
    if loaded is not None:
        assert np.all(np.isfinite(loaded.values))


def check_scenario_csv(tmp, data):
    fund, scenarios = _scenario_set()
    text = write_scenarios(tmp / "valid.csv", scenarios, fund.market).read_text()
    (tmp / "set.csv").write_text(data.draw(hostile_csv(text)))
    _check_scenarios(tmp / "set.csv", fund)


def check_scenario_parquet(tmp, data):
    fund, scenarios = _scenario_set()
    text = write_scenarios(tmp / "valid.csv", scenarios, fund.market).read_text()
    (tmp / "hostile.csv").write_text(data.draw(hostile_csv(text)))
    try:  # the hostile table as pandas infers its columns' types (strings, numbers, booleans)
        with warnings.catch_warnings():  # a row wider than the header is cut, not made an index
            warnings.simplefilter("ignore")
            table = pd.read_csv(tmp / "hostile.csv", index_col=False)
        table.to_parquet(tmp / "set.parquet")
    except Exception:  # a table pandas cannot write is no Parquet file: write its bytes as one
        (tmp / "set.parquet").write_bytes((tmp / "hostile.csv").read_bytes())
    _check_scenarios(tmp / "set.parquet", fund)


def check_scenario_npz(tmp, data):
    fund, scenarios = _scenario_set()
    names = variable_names(fund.market)
    arrays = dict(values=np.transpose(scenarios.values, (1, 0, 2)), times=np.arange(5) / 12, variables=np.array(names))
    (tmp / "set.npz").write_bytes(data.draw(hostile_npz(arrays)))
    _check_scenarios(tmp / "set.npz", fund)


LOADERS = dict(fund=check_fund, process=check_process, mechanism=check_mechanism, facility=check_facility,
               curve=check_curve, liabilities=check_liabilities, scenario_csv=check_scenario_csv,
               scenario_parquet=check_scenario_parquet, scenario_npz=check_scenario_npz)


@pytest.mark.parametrize("loader", sorted(LOADERS))
@settings(max_examples=BOUNDED, **_PROFILE)
@given(data=st.data())
def test_hostile_documents_are_refused_in_one_line_before_any_compile(tmp_path, loader, data):
    LOADERS[loader](tmp_path, data)


@pytest.mark.slow
@pytest.mark.parametrize("loader", sorted(LOADERS))
@settings(max_examples=LONG, **_PROFILE)
@given(data=st.data())
def test_hostile_documents_long_profile(tmp_path, loader, data):
    LOADERS[loader](tmp_path, data)
