"""Malformed inputs end in `InputError` (naming what is wrong) or in a correct load, never in
another exception: random truncations, type swaps and extreme values fed to the facility JSON,
forward-curve CSV, mechanism YAML and checkpoint loaders."""

import json

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import snapo_ode
from chemistry import MECHANISMS, Mechanism
from finance import gas_storage as gs
from fuzzing import loads_or_input_error, mutated_yaml_lines

FACILITY = gs.sample_facility()
CURVE_TEXT = "day,price\n" + "".join(f"{d},{p!r}\n" for d, p in enumerate(gs.sample_curve()[:40]))
MECHANISM_TEXT = (MECHANISMS / "reaction_types.yaml").read_text()
ODD_VALUES = st.sampled_from([None, "abc", "", [], [1.0, 2.0], {"a": 1}, True, -1.0, 0.0, 1e308, -1e308, 1e-308,
                              float("inf"), [[0.0, 1.0]], [[0.0, 1.0], [0.5]], [[1.0, 1.0], [0.0, 1.0]]])
FUZZ = settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])


@FUZZ
@given(field=st.sampled_from(sorted(FACILITY)), value=ODD_VALUES, drop=st.booleans())
def test_facility_fields_of_any_type(field, value, drop):
    facility = {k: v for k, v in FACILITY.items() if not (drop and k == field)} if drop else {**FACILITY, field: value}
    inputs = loads_or_input_error(lambda: gs.make_inputs(facility, gs.sample_curve()))
    if inputs is not None:  # a value that happens to be valid loads as it should
        assert float(inputs.capacity) > 0 and np.all(np.isfinite(np.asarray(inputs.forward_curve)))


@FUZZ
@given(cut=st.integers(0, len(json.dumps(FACILITY))), junk=st.text(max_size=5))
def test_truncated_facility_json(tmp_path, cut, junk):
    path = tmp_path / "facility.json"
    path.write_text(json.dumps(FACILITY)[:cut] + junk)
    facility = loads_or_input_error(lambda: gs.load_facility(path))
    if facility is not None:
        loads_or_input_error(lambda: gs.make_inputs(facility, gs.sample_curve()))


@FUZZ
@given(cut=st.integers(0, len(CURVE_TEXT)), junk=st.text(max_size=8),
       extreme=st.sampled_from(["nan", "inf", "-1e308", "1e400", "0x10", "", "3,4"]))
def test_truncated_or_odd_curve_csv(tmp_path, cut, junk, extreme):
    path = tmp_path / "curve.csv"
    text = CURVE_TEXT[:cut] + junk
    path.write_text(text.replace(",3.", f",{extreme}", 1) if extreme else text)
    curve = loads_or_input_error(lambda: gs.load_curve(path))
    if curve is not None:
        loads_or_input_error(lambda: gs.make_inputs(FACILITY, curve))


@pytest.fixture(scope="module")
def mechanism_lines():
    return MECHANISM_TEXT.splitlines(keepends=True)


@FUZZ
@given(data=st.data())
def test_mutated_mechanism_yaml(tmp_path, mechanism_lines, data):
    lines = mutated_yaml_lines(data, mechanism_lines, ["[]", "{}", "abc", "-1", "1e400", "null", "[1, 2, 3]", "{A: x}"])
    path = tmp_path / "mechanism.yaml"
    path.write_text("".join(lines))
    mechanism = loads_or_input_error(lambda: Mechanism.from_yaml(path))
    if mechanism is not None:
        assert mechanism.n_species > 0


def test_a_curve_with_a_carriage_return_in_a_field_loads_or_is_refused_in_one_line(tmp_path):
    # Found by the fuzz above: a lone "\r" inside a field was csv's traceback, not an InputError.
    path = tmp_path / "curve.csv"
    path.write_text("day,price\n0,3.1\r0\n1,3.2\n", newline="")
    with pytest.raises(snapo_ode.InputError, match=r"curve.csv, line 3: expected 'day,price'; got '0'"):
        gs.load_curve(path)
    path.write_bytes(b"day,price\r0,3.1\r1,3.2\r")  # a file of carriage returns only
    np.testing.assert_array_equal(gs.load_curve(path), [3.1, 3.2])


def test_a_mechanism_cut_before_its_species_is_refused_naming_the_phase(tmp_path, mechanism_lines):
    # Found by the fuzz above: a file that ends inside its phase (no species list, no section)
    # loaded as a mechanism of no species.
    path = tmp_path / "mechanism.yaml"
    path.write_text("".join(mechanism_lines[:mechanism_lines.index("  thermo: ideal-gas\n") + 1]))
    with pytest.raises(snapo_ode.InputError, match=r"mechanism.yaml:\d+: phase 'gas': no species"):
        Mechanism.from_yaml(path)


@pytest.mark.filterwarnings("error::RuntimeWarning")
def test_rates_at_the_magnitude_bound_load_without_an_overflow_warning_and_beyond_it_are_refused():
    inputs = gs.make_inputs({**FACILITY, "max_injection": gs.MAX_QUANTITY}, gs.sample_curve())
    assert float(inputs.max_injection) == gs.MAX_QUANTITY
    with pytest.raises(snapo_ode.InputError, match="max_injection = 1e[+]308 is outside the allowed range"):
        gs.make_inputs({**FACILITY, "max_injection": 1e308}, gs.sample_curve())


CHECKPOINT_HEADER = {"next_step": 2, "steps": 5, "history": {"loss": [1.0, 0.5]}, "best_loss": 0.5, "since_best": 0,
                     "stopped_early": False, "fingerprint": {}}


@FUZZ
@given(field=st.sampled_from(sorted(CHECKPOINT_HEADER)), value=ODD_VALUES, cut=st.integers(0, 400),
       junk=st.binary(max_size=8))
def test_checkpoints_with_odd_headers_or_bodies(tmp_path, field, value, cut, junk):
    """A checkpoint is read like any input: an odd header or a cut body is an InputError."""
    like = {"x": np.zeros(2)}
    path = tmp_path / "run.ckpt"
    snapo_ode.save_checkpoint(path, like, CHECKPOINT_HEADER, (like, like))
    header, body = path.read_bytes().split(b"\n", 1)
    odd = json.dumps({**CHECKPOINT_HEADER, field: value}).encode()
    path.write_bytes(odd + b"\n" + body[:cut] + junk)
    loaded = loads_or_input_error(lambda: snapo_ode.load_checkpoint(path, like, (like, like)))
    if loaded is not None:
        assert loaded[1] == snapo_ode.CheckpointInfo.model_validate(loaded[1]).model_dump()
