"""The numbers the docs and the mechanism's own description give for the pharma network are the
mechanism's, as Cantera computes them (issue 35: the docs gave the A <=> X rate constants as ~2e3
and 2e4 1/s where the mechanism has 19.9 and 214.8, and the YAML comment K = 0.1 for 0.0926)."""

import pathlib
import re

import cantera
import pytest

from chemistry import MECHANISMS

ROOT = pathlib.Path(__file__).resolve().parents[1]
T = 313.15


@pytest.fixture(scope="module")
def constants():
    """k(A => X) and k(X => A) [1/s] at 313.15 K, from Cantera."""
    phase = cantera.Solution(str(MECHANISMS / "pharma.yaml"))
    phase.TP = T, cantera.one_atm
    equations = phase.reaction_equations()
    k = phase.forward_rate_constants
    return k[equations.index("A => X")], k[equations.index("X => A")]


def _number(pattern: str, text: str) -> list[float]:
    match = re.search(pattern, text)
    assert match, pattern
    return [float(group) for group in match.groups()]


def test_the_docs_rate_constants_and_equilibrium_are_the_mechanisms(constants):
    forward, backward = constants
    docs = (ROOT / "docs" / "pharma.md").read_text() + (ROOT / "docs" / "dev" / "pharma_notes.md").read_text()
    stated = _number(r"rate constants \(([\d.]+) and ([\d.]+) 1/s at 313\.15 K", docs)
    assert stated == pytest.approx([forward, backward], rel=5e-3)
    equilibrium, relaxation = _number(r"K = ([\d.]+) at 313 K, relaxation time ~(\d+) ms", docs)
    assert equilibrium == pytest.approx(forward / backward, abs=0.005)
    assert relaxation == pytest.approx(1e3 / (forward + backward), abs=0.5)


def test_the_mechanisms_own_description_states_its_equilibrium(constants):
    forward, backward = constants
    description = (MECHANISMS / "pharma.yaml").read_text()
    (equilibrium,) = _number(r"K = k\(A=>X\) / k\(X=>A\) = ([\d.]+) at 313 K", description)
    assert equilibrium == pytest.approx(forward / backward, abs=5e-4)


def test_the_docs_tables_of_cpps_and_cqas_are_the_process_file_s():
    """docs/pharma.md's CPP and CQA tables against the built-in process file, row by row."""
    from chemistry.pharma import BUILT_IN_PROCESS, read_process_file

    spec = read_process_file(BUILT_IN_PROCESS)
    docs = (ROOT / "docs" / "pharma.md").read_text()
    for cpp in spec.cpps:
        row = _number(rf"\| {cpp.name} \| [^|]+ \| ([\d.]+) \| ([\d.]+)-([\d.]+) \| ([\d.]+)-([\d.]+) \|", docs)
        assert row == pytest.approx([cpp.nominal, *cpp.nor, *cpp.par]), cpp.name
    for cqa in spec.cqas:
        cell = re.search(rf"\| {cqa.name}[^|]* \| [^|]+ \| ([^|]+) \|", docs)
        assert cell, cqa.name
        stated = [limit for limit in (cqa.low, cqa.high) if abs(limit) != float("inf")]
        assert [float(x) for x in re.findall(r"[\d.]+", cell.group(1))[:len(stated)]] == pytest.approx(stated), cqa.name
