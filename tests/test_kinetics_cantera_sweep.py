"""Every ideal-gas phase of the YAML files shipped with Cantera 3.2 is read and matches Cantera's rates
of progress and net production rates to 1e-10 relative at random states (T 500-2500 K, P 0.01-100
atm, random compositions), and its species thermo to 1e-12, or is refused with an `InputError` that
names the feature. The phase-selection rules the shipped files rely on (species and reactions from
another file, undeclared elements and third bodies) are refused where Cantera refuses them."""

import json
import re
import textwrap

import cantera
import pytest

from chemistry import Mechanism, compare_rates
from chemistry.kinetics._sweep import cantera_data_directory, ideal_gas_phases, sweep_phase
from snapo_ode import InputError
from snapo_ode.cli import main

DIRECTORY = cantera_data_directory()
PHASES = ideal_gas_phases(sorted(DIRECTORY.rglob("*.yaml")))
REFUSED = {
    ("example_data/ammonia-CO-H2-Alzueta-2023.yaml", "linear-Burke"): "reaction type 'linear-Burke'",
}
"""The phases we refuse, with the feature their message must name."""


def test_the_sweep_finds_the_shipped_phases():
    found = {(str(path.relative_to(DIRECTORY)), phase) for path, phase in PHASES}
    assert set(REFUSED) <= found
    assert {("gri30.yaml", "gri30"), ("h2o2.yaml", "ohmech"), ("ohn.yaml", "gas"),
            ("example_data/n-hexane-NUIG-2015.yaml", "gas")} <= found
    assert len(found) == len(PHASES) >= 19


@pytest.mark.parametrize(("path", "phase"), PHASES, ids=[f"{path.name}:{phase}" for path, phase in PHASES])
def test_phase_matches_cantera_or_is_refused_naming_the_feature(path, phase):
    result = sweep_phase(path, phase, n_states=4)
    feature = REFUSED.get((result.file, phase))
    if feature is not None:
        assert result.refused is not None and feature in result.refused, result
        return
    assert result.refused is None, result.refused
    assert result.thermo <= 1e-12, result
    assert result.max_error <= 1e-10, result
    if result.n_reactions:
        assert result.rates.n_compared > 0, result


HEADER = textwrap.dedent("""\
    units: {length: cm, quantity: mol, activation-energy: cal/mol}
    phases:
    - name: gas
      thermo: ideal-gas
      elements: [O, H]
      species: [{h2o2.yaml/species: [H2, H, O2, O, OH, HO2, H2O, H2O2]}]
      kinetics: gas
      reactions: [%s]
    %s
    extra:
    - equation: H + O2 (+AR) <=> HO2 (+AR)
      type: falloff
      high-P-rate-constant: {A: 1.0e+12, b: 0, Ea: 0}
      low-P-rate-constant: {A: 1.0e+18, b: 0, Ea: 0}
    - equation: H + O2 (+M) <=> HO2 (+M)
      type: falloff
      high-P-rate-constant: {A: 1.0e+12, b: 0, Ea: 0}
      low-P-rate-constant: {A: 1.0e+18, b: 0, Ea: 0}
      efficiencies: {AR: 0.5, H2O: 3.0}
    """)


@pytest.mark.parametrize(("reactions", "flag", "message"), [
    ("extra", "", "third body 'AR' is not in the phase"),
    ("{h2o2.yaml/reactions: declared-species}", "", "efficiency for 'AR'"),
    ("extra", "skip-undeclared-third-bodies: true", None),
    ("h2o2.yaml/reactions", "skip-undeclared-third-bodies: true", None),
], ids=["collider", "efficiency", "skipped", "skipped-collider-written-as-species"])
def test_undeclared_third_bodies_are_refused_or_skipped_as_cantera_does(tmp_path, reactions, flag, message):
    path = tmp_path / "phase.yaml"
    path.write_text(HEADER % (reactions, textwrap.indent(flag, "  ")))
    if message is not None:
        with pytest.raises(cantera.CanteraError):
            cantera.Solution(str(path))
        with pytest.raises(InputError, match=message):
            Mechanism.from_yaml(path)
        return
    # Cantera leaves out a reaction with an undeclared collider, (+AR) or H + O2 + AR <=> HO2 + AR,
    # and ignores AR's efficiencies.
    gas = cantera.Solution(str(path))
    mechanism = Mechanism.from_yaml(path)
    assert mechanism.n_reactions == gas.n_reactions == (1 if reactions == "extra" else 27)
    rates = compare_rates(mechanism, path, n_states=4)
    assert max(rates.rates_of_progress, rates.net_production) <= 1e-10, rates


def test_undeclared_elements_are_refused_unless_skipped(tmp_path):
    path = tmp_path / "phase.yaml"
    text = "phases:\n- name: gas\n  thermo: ideal-gas\n  elements: [O, H]\n  species: [{h2o2.yaml/species: all}]\n"
    path.write_text(text)
    with pytest.raises(cantera.CanteraError):
        cantera.Solution(str(path))
    with pytest.raises(InputError, match="species 'AR' contains element 'Ar'.*skip-undeclared-elements"):
        Mechanism.from_yaml(path)
    path.write_text(text + "  skip-undeclared-elements: true\n")
    assert Mechanism.from_yaml(path).species_names == tuple(cantera.Solution(str(path)).species_names)


def test_a_missing_included_file_is_named(tmp_path):
    path = tmp_path / "phase.yaml"
    path.write_text("phases:\n- name: gas\n  thermo: ideal-gas\n  species: [{no-such-file.yaml/species: all}]\n")
    with pytest.raises(InputError, match="'no-such-file.yaml'"):
        Mechanism.from_yaml(path)


def test_sweep_command_tables_the_phases_of_the_files_given_and_writes_its_json(capsys, tmp_path):
    files = [str(DIRECTORY / "air.yaml"), str(DIRECTORY / "airNASA9.yaml")]
    assert main(["kinetics", "sweep", "--states", "2", "--out", str(tmp_path), *files]) == 0
    rows = [line for line in capsys.readouterr().out.splitlines() if line.startswith("| air")]
    assert rows[0].startswith("| air.yaml | air | 8 | 8 | loaded: rates ")
    assert re.fullmatch(r"\| airNASA9.yaml \| airNASA9 \| 11 \| 0 \| loaded \(no kinetics\); thermo \d\.\de-\d\d \|", rows[1])
    assert len(rows) == 2
    written = json.loads((tmp_path / "kinetics-sweep.json").read_text())
    assert written["states"] == 2 and [(p["phase"], p["n_species"], p["n_reactions"]) for p in written["phases"]] == [
        ("air", 8, 8), ("airNASA9", 11, 0)]
    air = written["phases"][0]
    assert air["refused"] is None and air["rates"]["n_states"] == 2 and air["rates"]["rates_of_progress"] < 1e-10
