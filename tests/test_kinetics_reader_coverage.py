"""What the mechanism reader reads beyond NASA7 and the basic reaction types, each against
Cantera: NASA9 thermo (alone and mixed with NASA7) and Shomate thermo, bare file names found on
Cantera's data path, and constant-volume species given by density or molar density; and what it
refuses (a surface phase, malformed YAML, a condensed species without a volume), naming the file
and line. Reaction forms are in test_kinetics_reaction_forms.py."""

import re
import textwrap

import cantera
import jax
import numpy as np
import pytest

import snapo_ode
from chemistry import MECHANISMS, Mechanism, compare_rates
from chemistry.kinetics._crosscheck import compare_thermo
from chemistry.kinetics._sweep import cantera_data_directory
from snapo_ode import InputError

snapo_ode.configure()
DATA = cantera_data_directory()

MIXED = textwrap.dedent("""\
    phases:
    - name: gas
      thermo: ideal-gas
      species: [{airNASA9.yaml/species: [O, O2, N, NO, N2]}, {air.yaml/species: [NO2, N2O, AR]}]
      kinetics: gas
      reactions: [{air.yaml/reactions: declared-species}]
    """)
"""NASA9 species (airNASA9) with NASA7 ones (air), and air.yaml's eight reactions among them."""


def _write(tmp_path, text, name="phase.yaml"):
    path = tmp_path / name
    path.write_text(text)
    return path


def _standard_state(solution, temperature):
    solution.TP = temperature, solution.reference_pressure
    return solution.standard_cp_R, solution.standard_enthalpies_RT, solution.standard_entropies_R


@pytest.mark.parametrize("file", ["airNASA9.yaml", "mixed"])
def test_nasa9_thermo_matches_cantera_in_every_range_and_at_the_boundaries(tmp_path, file):
    path = DATA / file if file != "mixed" else _write(tmp_path, MIXED)
    mechanism = Mechanism.from_yaml(path)
    solution = cantera.Solution(str(path))
    assert mechanism.species_names == tuple(solution.species_names)
    # airNASA9's ranges are 200-1000-6000-20000 K: below, at and either side of each boundary,
    # inside each range and above the last (Cantera extrapolates the last range).
    temperatures = [150.0, 200.0, 700.0, 1000.0 * (1 - 1e-12), 1000.0, 1000.0 * (1 + 1e-12), 3000.0,
                    6000.0, 6000.0 * (1 + 1e-12), 12000.0, 20000.0, 25000.0]
    thermo = mechanism.thermo
    for temperature in temperatures:
        ours = (thermo.cp_r(temperature), thermo.h_rt(temperature), thermo.s_r(temperature))
        for value, reference in zip(ours, _standard_state(solution, temperature)):
            np.testing.assert_allclose(np.asarray(value), reference, rtol=1e-12, atol=0, err_msg=f"T = {temperature}")
    assert compare_thermo(mechanism, path, n_states=50, temperature=(200.0, 20000.0)) <= 1e-12


SHOMATE = textwrap.dedent("""\
    phases:
    - name: gas
      thermo: ideal-gas
      species: [{species: [CO2, H2O]}, {h2o2.yaml/species: [H2, O2]}]
    species:
    - name: CO2  # NIST's Shomate coefficients, two ranges
      composition: {C: 1, O: 2}
      thermo:
        model: Shomate
        temperature-ranges: [298.0, 1200.0, 6000.0]
        data:
        - [24.99735, 55.18696, -33.69137, 7.948387, -0.136638, -403.6075, 228.2431]
        - [58.16639, 2.720074, -0.4922289, 0.03883844, -6.447293, -425.9186, 263.6125]
    - name: H2O  # one range
      composition: {H: 2, O: 1}
      thermo:
        model: Shomate
        temperature-ranges: [500.0, 1700.0]
        data:
        - [30.092, 6.832514, 6.793435, -2.53448, 0.082139, -250.881, 223.3967]
    """)


def test_shomate_thermo_matches_cantera_on_either_side_of_its_midpoint(tmp_path):
    path = _write(tmp_path, SHOMATE)
    thermo = Mechanism.from_yaml(path).thermo
    solution = cantera.Solution(str(path))
    # Cantera takes Shomate's low range at T <= T_mid (1200 K), NASA9's high one at its boundary.
    for temperature in [250.0, 298.0, 700.0, np.nextafter(1200.0, 0.0), 1200.0, np.nextafter(1200.0, 2e3), 1700.0,
                        4000.0, 8000.0]:
        ours = (thermo.cp_r(temperature), thermo.h_rt(temperature), thermo.s_r(temperature))
        for value, reference in zip(ours, _standard_state(solution, temperature)):
            error = np.abs(np.asarray(value) - reference) / np.maximum(np.abs(reference), 1.0)
            assert error.max() <= 1e-12, (temperature, error)


@pytest.mark.parametrize("file", ["h2o2.yaml", "gri30.yaml", "airNASA9.yaml", "mixed", "shomate"])
def test_the_hottest_thermo_fit_is_cantera_s(tmp_path, file):
    # The reactors reject trial states far above it (chemistry.kinetics._reactor.TRIAL_TEMPERATURE_CEILING).
    path = {"mixed": lambda: _write(tmp_path, MIXED), "shomate": lambda: _write(tmp_path, SHOMATE)}.get(
        file, lambda: DATA / file)()
    expected = max(species.thermo.max_temp for species in cantera.Solution(str(path)).species())
    assert Mechanism.from_yaml(path).thermo.max_temperature == expected


def test_mixed_nasa9_and_nasa7_rates_match_cantera(tmp_path):
    path = _write(tmp_path, MIXED)
    mechanism = Mechanism.from_yaml(path)
    assert mechanism.n_reactions == cantera.Solution(str(path)).n_reactions == 8
    # 300-6000 K spans NASA7's and NASA9's range boundaries (1000 K) and NASA9's second range.
    rates = compare_rates(mechanism, path, n_states=40, temperature=(300.0, 6000.0), pressure=(1e3, 1e7))
    assert max(rates.rates_of_progress, rates.net_production) <= 1e-10, rates
    assert rates.n_compared > 0


def test_a_mechanism_without_nasa9_species_traces_no_nasa9_code(tmp_path):
    nasa7 = Mechanism.from_yaml(DATA / "h2o2.yaml")
    mixed = Mechanism.from_yaml(_write(tmp_path, MIXED))
    assert nasa7.thermo.nasa9 is None and mixed.thermo.nasa9 is not None

    def traced(mechanism):
        return str(jax.make_jaxpr(lambda t: mechanism.thermo.g_rt(t) + mechanism.thermo.cp_r(t))(1500.0))

    # NASA9 evaluation picks each species' range with a gather and writes its species with a
    # scatter: neither is in a NASA7 mechanism's thermo.
    assert "gather" in traced(mixed) and "scatter" in traced(mixed)
    assert "gather" not in traced(nasa7) and "scatter" not in traced(nasa7)


@pytest.mark.parametrize("name", ["gri30.yaml", "ohn.yaml", "example_data/co2-thermo.yaml"])
def test_a_bare_file_name_is_found_where_cantera_finds_it(name):
    mechanism = Mechanism.from_yaml(name)
    solution = cantera.Solution(name)
    assert mechanism.species_names == tuple(solution.species_names)
    assert mechanism.n_reactions == solution.n_reactions


def test_a_local_file_wins_over_cantera_data_and_a_missing_one_is_named(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    _write(tmp_path, (DATA / "h2o2.yaml").read_text().replace("name: ohmech", "name: local"), "gri30.yaml")
    assert cantera.Solution("gri30.yaml").name == "local"
    assert Mechanism.from_yaml("gri30.yaml").n_species == 10
    with pytest.raises(InputError, match="'no-such-mechanism.yaml' is not a file, nor one in Cantera's data"):
        Mechanism.from_yaml("no-such-mechanism.yaml")


def test_a_surface_phase_is_refused_naming_the_file_and_phase():
    with pytest.raises(InputError, match=r"ptcombust.yaml:\d+: phase 'Pt_surf': a surface or edge phase "
                                         r"\(thermo 'ideal-surface'"):
        Mechanism.from_yaml("ptcombust.yaml", "Pt_surf")


def test_a_yaml_syntax_error_names_the_file(tmp_path):
    path = _write(tmp_path, "phases:\n- name: gas\n  thermo: [ideal-gas\n")
    with pytest.raises(InputError, match=rf"mechanism file {re.escape(str(path))}, line 4: not valid YAML"):
        Mechanism.from_yaml(path)


def test_a_malformed_species_names_its_file_line_and_name(tmp_path):
    text = SHOMATE.replace("    temperature-ranges: [500.0, 1700.0]\n", "")
    with pytest.raises(cantera.CanteraError):
        cantera.Solution(str(_write(tmp_path, text)))
    with pytest.raises(InputError, match=r"phase.yaml:\d+: species 'H2O': malformed .*'temperature-ranges'"):
        Mechanism.from_yaml(_write(tmp_path, text))


def test_density_and_molar_density_give_cantera_molar_volumes_and_rates(tmp_path):
    # pharma.yaml with A by density (custom element Y, 50 kg/kmol), S (ethanol, C2H6O: Cantera's
    # atomic weights) by density in g/cm^3, P by molar density, and I by a list of models.
    text = (MECHANISMS / "pharma.yaml").read_text().splitlines(keepends=True)
    eos = {"A": "{model: constant-volume, density: 1500.0}",
           "S": "{model: constant-volume, density: 0.789 g/cm^3}",
           "P": "{model: constant-volume, molar-density: 12.5 mol/L}",
           "I": "[{model: constant-volume, molar-volume: 0.07}]"}
    species = None
    for i, line in enumerate(text):
        species = line.split("- name: ")[1].strip() if line.startswith("- name: ") else species
        if line.strip().startswith("equation-of-state:") and species in eos:
            text[i] = f"  equation-of-state: {eos[species]}\n"
    path = _write(tmp_path, "".join(text))
    mechanism = Mechanism.from_yaml(path)
    solution = cantera.Solution(str(path))
    np.testing.assert_allclose(np.asarray(mechanism.molar_volumes), solution.partial_molar_volumes, rtol=1e-14)
    assert len(set(np.round(solution.partial_molar_volumes, 6))) == 5  # four volumes changed
    rates = compare_rates(mechanism, path, n_states=20, temperature=(280.0, 400.0))
    assert max(rates.rates_of_progress, rates.net_production) <= 1e-10, rates


def test_a_condensed_species_without_a_volume_is_refused_naming_it(tmp_path):
    text = (MECHANISMS / "pharma.yaml").read_text().replace(
        "equation-of-state: {model: constant-volume, molar-volume: 0.0584 m^3/kmol}\n- name: B",
        "equation-of-state: {model: constant-volume}\n- name: B", 1)
    with pytest.raises(InputError, match=r"phase.yaml:\d+: species 'A' needs an equation-of-state"):
        Mechanism.from_yaml(_write(tmp_path, text))
