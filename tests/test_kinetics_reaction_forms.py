"""Reaction forms Cantera 3.2 reads, against Cantera: rate constants written as lists, its other
type names, a reaction's own units, a third body written as a species on both sides, Blowers-Masel
reactions with a third body; and the forms refused, naming the file, line, reaction and feature
(malformed lists, surface and edge features, a three-body reaction without one third body)."""

import re
import textwrap

import cantera
import pytest

import snapo_ode
from chemistry import Mechanism, compare_rates
from snapo_ode import InputError

snapo_ode.configure()


def _write(tmp_path, text, name="phase.yaml"):
    path = tmp_path / name
    path.write_text(text)
    return path


LISTS = textwrap.dedent("""\
    units: {length: cm, quantity: mol, activation-energy: cal/mol}
    phases:
    - name: gas
      thermo: ideal-gas
      species: [{h2o2.yaml/species: [H2, H, O2, O, OH, HO2, H2O, H2O2, AR]}]
      kinetics: gas
      reactions: all
    reactions:
    - equation: H + O2 <=> O + OH
      rate-constant: [3.52e+16, -0.7, 17069.79]
    - equation: O + H2 <=> H + OH
      rate-constant: [5.06e+04, 2.67, 26.3 kJ/mol]
    - equation: H2 + OH <=> H2O + H
      rate-constant: [2.16e+08, 1.51]
    - equation: HO2 + OH <=> H2O + O2
      rate-constant: [1.0e+10 m^3/kmol/s, 0.0, 500 K]
    - equation: 2 O + M <=> O2 + M
      type: three-body
      rate-constant: [6.165e+15, -0.5, 0.0]
      efficiencies: {H2: 2.5, H2O: 12.0, AR: 0.83}
    - equation: H + O2 (+M) <=> HO2 (+M)
      type: falloff
      high-P-rate-constant: [4.65e+12, 0.44, 0.0]
      low-P-rate-constant: [5.75e+19, -1.4, 0.0]
      Troe: {A: 0.5, T3: 1.0e-30, T1: 1.0e+30}
    - equation: 2 OH (+M) <=> H2O2 (+M)
      type: chemically-activated
      high-P-rate-constant: [7.4e+13, -0.37, 0.0]
      low-P-rate-constant: [2.3e+18, -0.9, -1700.0]
    - equation: H2O2 + H <=> H2O + OH
      type: Blowers-Masel
      rate-constant: [2.41e+13, 0.0, 3970.0, 1.0e+05]
    """)


def test_rate_constants_written_as_lists_match_cantera(tmp_path):
    path = _write(tmp_path, LISTS)
    mechanism = Mechanism.from_yaml(path)
    assert mechanism.n_reactions == cantera.Solution(str(path)).n_reactions == 8
    rates = compare_rates(mechanism, path, n_states=40)
    assert max(rates.rates_of_progress, rates.net_production) <= 1e-10, rates


ALIASES = LISTS.split("reactions:\n-")[0] + textwrap.dedent("""\
    reactions:
    - equation: H + O2 <=> O + OH  # its own units
      units: {length: m, quantity: kmol, activation-energy: kJ/mol}
      rate-constant: {A: 1.0e+10, b: 0, Ea: 10}
    - equation: H + O2 + AR <=> HO2 + AR  # AR is the third body, not a reactant
      type: three-body
      rate-constant: {A: 1.0e+17, b: -0.8, Ea: 0}
    - equation: 2 O + M <=> O2 + M
      type: Arrhenius
      rate-constant: {A: 6.0e+15, b: -0.5, Ea: 0}
      efficiencies: {AR: 0.3, H2O: 5.0}
    - equation: 2 H + M <=> H2 + M
      type: three-body-Arrhenius
      rate-constant: {A: 1.0e+18, b: -1.0, Ea: 0}
    - equation: H + OH (+M) <=> H2O (+M)
      type: Lindemann  # Cantera ignores the Troe parameters
      high-P-rate-constant: &high {A: 1.0e+13, b: 0, Ea: 0}
      low-P-rate-constant: &low {A: 1.0e+20, b: -1.0, Ea: 0}
      Troe: &troe {A: 0.5, T3: 100, T1: 1000}
    - {equation: H + HO2 (+M) <=> H2O2 (+M), type: Troe, high-P-rate-constant: *high, low-P-rate-constant: *low,
       Troe: *troe}
    - {equation: O + OH (+M) <=> HO2 (+M), type: SRI, high-P-rate-constant: *high, low-P-rate-constant: *low,
       SRI: {A: 1.1, B: 700, C: 1234}}
    - {equation: O + H2O (+M) <=> H2O2 (+M), type: Tsang, high-P-rate-constant: *high, low-P-rate-constant: *low,
       Tsang: {A: 0.5, B: 1.0e-04}}
    - equation: O + H + M <=> OH + M
      type: Blowers-Masel
      rate-constant: {A: 5.0e+17, b: -1.0, Ea0: 1000, w: 1.0e+05}
      efficiencies: {H2O: 4.0}
    - equation: 2 OH + AR <=> H2O2 + AR
      type: three-body-Blowers-Masel
      rate-constant: {A: 1.0e+17, b: -1.0, Ea0: 1000, w: 1.0e+05}
    - equation: H2 + O2 + M <=> H2O2 + M  # Cantera ignores a Chebyshev reaction's M
      type: Chebyshev
      temperature-range: [300.0, 2500.0]
      pressure-range: [0.01 bar, 100 bar]
      data: [[8.0, 0.1], [-0.5, 0.1]]
    """)


def test_cantera_type_aliases_local_units_and_explicit_third_bodies_match_cantera(tmp_path):
    path = _write(tmp_path, ALIASES)
    mechanism = Mechanism.from_yaml(path)
    assert mechanism.n_reactions == cantera.Solution(str(path)).n_reactions == 11
    rates = compare_rates(mechanism, path, n_states=40, temperature=(300.0, 3000.0))
    assert max(rates.rates_of_progress, rates.net_production) <= 1e-10, rates


def test_a_blowers_masel_third_body_in_parentheses_is_refused(tmp_path):
    # Cantera 3.2 reads it but multiplies by no third-body concentration, unlike '+ M'.
    path = _write(tmp_path, _reaction("type: Blowers-Masel\nrate-constant: {A: 1.0e+13, b: 0, Ea0: 0, w: 1.0e+05}\n")
                  .replace("H + O2 <=> O + OH", "H + O2 (+M) <=> HO2 (+M)"))
    with pytest.raises(InputError, match=r"reaction 0 .*third body written '\(\+M\)' is not supported; write it '\+ M'"):
        Mechanism.from_yaml(path)


def test_a_three_body_reaction_without_one_third_body_is_refused(tmp_path):
    for equation, got in [("H + O2 <=> HO2", "none"), ("H + O2 + AR + H2 <=> HO2 + AR + H2", "AR, H2")]:
        path = _write(tmp_path, LISTS.split("reactions:\n-")[0] + f"reactions:\n- equation: {equation}\n"
                      "  type: three-body\n  rate-constant: {A: 1.0e+13, b: 0, Ea: 0}\n")
        with pytest.raises(cantera.CanteraError):
            cantera.Solution(str(path))
        with pytest.raises(InputError, match=rf"reaction 0 .*exactly one species on both sides as its third body; "
                                             rf"got {got}"):
            Mechanism.from_yaml(path)


def _reaction(body: str) -> str:
    return LISTS.split("reactions:\n-")[0] + "reactions:\n- equation: H + O2 <=> O + OH\n" + textwrap.indent(
        textwrap.dedent(body), "  ")


def test_a_negative_order_needs_negative_orders_as_in_cantera(tmp_path):
    body = "rate-constant: {A: 1.0e+13, b: 0, Ea: 0}\norders: {H: 1.0, O2: -0.5}\n"
    path = _write(tmp_path, _reaction(body).replace("H + O2 <=> O + OH", "H + O2 => O + OH"))
    with pytest.raises(cantera.CanteraError):
        cantera.Solution(str(path))
    with pytest.raises(InputError, match=r"reaction 0 .*'O2' the negative order -0.5; allowed only with negative-orders"):
        Mechanism.from_yaml(path)
    path.write_text(path.read_text() + "  negative-orders: true\n")
    rates = compare_rates(Mechanism.from_yaml(path), path, n_states=10)
    assert max(rates.rates_of_progress, rates.net_production) <= 1e-10, rates


def test_a_malformed_reaction_names_its_file_line_and_reaction(tmp_path):
    path = _write(tmp_path, _reaction("type: falloff\nhigh-P-rate-constant: {A: 1.0e+13, b: 0, Ea: 0}\n"
                                      "low-P-rate-constant: {A: 1.0e+19, b: 0, Ea: 0}\nTroe: {T3: 100, T1: 1000}\n")
                  .replace("H + O2 <=> O + OH", "H + O2 (+M) <=> HO2 (+M)"))
    with pytest.raises(cantera.CanteraError):
        cantera.Solution(str(path))
    with pytest.raises(InputError, match=r"phase.yaml:9: reaction 0 \(H \+ O2 \(\+M\) <=> HO2 \(\+M\)\): malformed .*"
                                         r"KeyError: 'A'"):
        Mechanism.from_yaml(path)


@pytest.mark.parametrize(("body", "message"), [
    ("rate-constant: [1.0e+13]\n", r"rate constant written as a list is \[A, b, Ea\], the first 2 required"),
    ("rate-constant: [1.0e+13, 0.0, 0.0, 1.0, 2.0]\n", r"\[A, b, Ea\], the first 2 required"),
    ("type: pressure-dependent-Arrhenius\nrate-constants:\n- [1 atm, 1.0e+13, 0.0, 0.0]\n",
     r"each PLOG rate-constants entry is a mapping"),
    ("type: Blowers-Masel\nrate-constant: [1.0e+13, 0.0, 100.0]\n", r"\[A, b, Ea0, w\], the first 4 required"),
], ids=["one number", "five numbers", "PLOG entry", "Blowers-Masel without w"])
def test_malformed_rate_lists_are_refused_as_cantera_refuses_them(tmp_path, body, message):
    path = _write(tmp_path, _reaction(body))
    if "Blowers" not in body:  # Cantera reads a missing w as 0; we refuse, as for {A, b, Ea0}
        with pytest.raises(cantera.CanteraError):
            cantera.Solution(str(path))
    with pytest.raises(InputError, match=rf"phase.yaml:\d+: reaction 0 \(H \+ O2 <=> O \+ OH\): .*{message}"):
        Mechanism.from_yaml(path)


@pytest.mark.parametrize(("body", "feature"), [
    ("sticking-coefficient: {A: 0.1, b: 0, Ea: 0}\n", "field 'sticking-coefficient'"),
    ("rate-constant: {A: 1.0e+13, b: 0, Ea: 0}\ncoverage-dependencies: {O: {a: 0, m: 0, E: 1000}}\n",
     "field 'coverage-dependencies'"),
    ("type: interface-Arrhenius\nrate-constant: {A: 1.0e+13, b: 0, Ea: 0}\n", "type 'interface-Arrhenius'"),
    ("rate-constant: {A: 1.0e+13, b: 0, Ea: 0}\nbeta: 0.5\n", "field 'beta'"),
], ids=["sticking", "coverage", "interface type", "electrochemical"])
def test_surface_reaction_features_are_refused_by_name(tmp_path, body, feature):
    path = _write(tmp_path, _reaction(body))
    with pytest.raises(InputError, match=rf"phase.yaml:9: reaction 0 \(H \+ O2 <=> O \+ OH\): {re.escape(feature)} "
                                         "belongs to a surface or edge reaction"):
        Mechanism.from_yaml(path)


