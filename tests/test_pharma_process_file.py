"""A process described in a file: the built-in chain from `processes/api_chain.yaml` gives the
numbers recorded before the file existed (`benchmarks/pharma_golden.py`), a study runs on the
user's inputs (none rebuilt from defaults behind them), `--set` names CPPs and parameters, and
bad files get one-line errors naming the file, the line and the field, before any compile."""

import json
import pathlib
import sys
from importlib.resources import files

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import snapo_ode
from chemistry import MECHANISMS
from chemistry.pharma import BUILT_IN_PROCESS, BUMP_SOLVER, PharmaChain, read_process_file, sensitivities
from chemistry.pharma._settings import settings_values
from fuzzing import loads_or_input_error, mutated_yaml_lines

sys.path.insert(0, str(pathlib.Path(__file__).resolve().parents[1] / "benchmarks"))
from pharma_golden import GOLDEN, RENAMED  # noqa: E402

TEXT = BUILT_IN_PROCESS.read_text().replace("../../mechanisms/pharma.yaml", str(MECHANISMS / "pharma.yaml"))


BALANCE_FIXES = {"assay": 9.2754e-07, "impurity": -9.9604e-04, "degradant": -2.3784e-05, "mean_crystal_size": 7.7212e-05,
                 "residual_solvent": -4.8728e-04}
"""How the two balance fixes moved the CQAs at the nominal point, relative: the crystals' growth now
holds the impurity and degradant they take (before, their mass left the liquor but not into the
crystals' API: the impurity read high), and the cake's liquid is cake_liquor per kg of crystals
with its solutes in it (before, the solutes came on top: the residual solvent read high). The
file reproduced the numbers recorded before it to 0.0 before the fixes (commit 66309fd,
benchmarks/pharma_golden.py --check)."""


def test_the_built_in_file_gives_the_recorded_numbers_moved_by_the_balance_fixes(tmp_path):
    (tmp_path / "copy.yaml").write_text(TEXT)  # the file, moved: its mechanism by an absolute path
    chain = PharmaChain(solver=BUMP_SOLVER, process=tmp_path / "copy.yaml")
    jac, _ = sensitivities(chain, chain.inputs(chain.cpps()), repeats=1)
    golden = json.loads(GOLDEN.read_text())["bump_solver/nominal"]
    assert [RENAMED.get(name, name) for name in golden["jacobian"]["assay"]] == list(jac.input_names)
    for name, value in zip(jac.output_names, np.asarray(jac.values), strict=True):
        assert value / golden["cqas"][name] - 1 == pytest.approx(BALANCE_FIXES[name], rel=1e-4), name


def test_a_study_runs_on_the_inputs_it_is_given():
    from chemistry.pharma import sensitivity_study

    chain = PharmaChain(solver=BUMP_SOLVER)
    inputs = chain.inputs(chain.cpps(), physical=chain.physical(**{"filter.cake_liquor": 0.45}))
    study = sensitivity_study(chain, inputs, repeats=1, check_bumps=False, reference=None)
    nominal = sensitivity_study(chain, chain.cpps(), repeats=1, check_bumps=False, reference=None)
    assert float(study.inputs.physical["filter.cake_liquor"]) == 0.45
    assert study.cqas["residual_solvent"] > 1.2 * nominal.cqas["residual_solvent"]  # more liquor, more solvent


def test_set_names_a_cpp_by_name_or_target_and_a_parameter_with_its_unit():
    process = read_process_file(BUILT_IN_PROCESS)
    cpps, physical = settings_values(process, {"cooling_rate": 0.4},
                                     ["r1.temperature=315", "r1_residence_time=0.5 h", "r2.time=2 h",
                                      "feed.A=330 mol/m^3"])
    assert cpps == {"cooling_rate": 0.4, "r1_temperature": 315.0, "r1_residence_time": 30.0}
    assert physical == {"r2.time": 7200.0, "feed.A": pytest.approx(0.33, rel=1e-15)}
    for bad, message in ((["r1.pressure=2"], "no CPP"), (["r1.temperature"], "NAME=VALUE"),
                         (["r1.temperature=1 kg"], "does not convert"),
                         (["r1_temperature=315", "r1.temperature=316"], "set twice")):
        with pytest.raises(snapo_ode.InputError, match=message):
            settings_values(process, {}, bad)


BAD_FILES = [
    ("type: cooling_crystallizer", "type: msmpr_crystallizer", r"line 38: units\[crystallizer\].type = 'msmpr"),
    ("  X: {role: byproduct}", "", "line 16: species 'X' of the mechanism has no role"),
    ("target: dryer.temperature", "target: dryer.pressure", r"line 75: cpps\[dryer_temperature\].target"),
    ("definition: {mass_fraction: I}", "definition: {mass_fraction: Q}", r"line 80: .*mass_fraction: Q"),
    ("definition: {mass_fraction: I}", "definition: {residual_solvent: I}",
     r"line 80: .*residual_solvent: I\}: the species has no role of solvent, antisolvent"),
    ("definition: {mass_fraction: I}", "definition: {mass_fraction: I, residual_solvent: S}",
     r"line 80: .*allowed: one of mass_fraction or residual_solvent"),
    ("nor: [0.4, 0.6]", "nor: [0.2, 0.6]", r"line 73: cpps\[cooling_rate\].*nor inside par"),
    ("growth_rate: 5.0e-8 m/s", "growth_rate: 5.0e-8 kg/s", r"line 43: .*crystallizer.growth_rate = '5.0e-8 kg/s' "
                                                              "does not convert to 'm/s'"),
    ("time: 3600 s", "time: 3600 parsec", "line 36: .*r2.time.*does not convert"),
    ("cake_liquor: 0.3", "cake_liquour: 0.3", "line 56: filter.cake_liquour is no parameter of a filter"),
]


@pytest.mark.parametrize(("old", "new", "message"), BAD_FILES, ids=[b[2].split(":")[0][:30] for b in BAD_FILES])
def test_a_bad_process_file_names_the_file_the_line_and_the_field(tmp_path, old, new, message):
    assert old in TEXT
    path = tmp_path / "process.yaml"
    path.write_text(TEXT.replace(old, new, 1))
    with pytest.raises(snapo_ode.InputError, match=message) as error:
        PharmaChain(process=path)
    assert str(path) in str(error.value) and "\n" not in str(error.value)


FUZZ = settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
ODD = ["[]", "{}", "abc", "-1", "0", "1e400", ".nan", "null", "[1, 2, 3]", "{a: x}", "true", "'1.0'", "3 parsec"]


@FUZZ
@given(data=st.data())
def test_mutated_process_files_load_or_raise_input_error(tmp_path, data):
    path = tmp_path / "process.yaml"
    path.write_text("".join(mutated_yaml_lines(data, TEXT.splitlines(keepends=True), ODD)))
    chain = loads_or_input_error(lambda: PharmaChain(process=path))
    if chain is not None:
        assert len(chain.cpp_names) >= 1 and all(np.isfinite(chain.physical().values))


def test_a_copied_shipped_process_file_finds_its_mechanism(tmp_path):
    shipped = pathlib.Path(str(files("chemistry.pharma") / "processes" / "antisolvent_route.yaml"))
    copy = tmp_path / "my_route.yaml"
    copy.write_text(shipped.read_text())
    spec = read_process_file(copy)
    assert pathlib.Path(spec.mechanism) == (shipped.parent / "antisolvent_route" / "mechanism.yaml").resolve()
    own = tmp_path / "antisolvent_route" / "mechanism.yaml"
    own.parent.mkdir()
    own.write_text((shipped.parent / "antisolvent_route" / "mechanism.yaml").read_text())
    assert pathlib.Path(read_process_file(copy).mechanism) == own.resolve()
