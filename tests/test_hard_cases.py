"""Hard cases fail loudly or give correct finite numbers, never a NaN with exit code 0: a result
with a non-finite number is refused naming the field; h2o2 ignition sensitivities from a hot
start are taken in the induction (not at the built-in case's time, after the front, where every
d ln T / d ln A is ~0 and both codes report noise) and match Cantera; where our reverse pass
meets its limit near a fast front it stops with exit code 3 and writes nothing."""

import dataclasses
import json
import math

import cantera
import numpy as np
import pytest

import snapo_ode
from snapo_ode.cli import main

H2O2 = f"{cantera.__file__.rsplit('/', 1)[0]}/data/h2o2.yaml"


@dataclasses.dataclass(frozen=True)
class Toy(snapo_ode.Result):
    value: float
    curve: list


def test_a_non_finite_result_is_refused_naming_the_field(tmp_path):
    with pytest.raises(snapo_ode.SolverFailed, match=r"curve\[1\] is not finite"):
        Toy(1.0, [0.0, math.nan]).write_json(tmp_path / "toy.json")
    with pytest.raises(snapo_ode.SolverFailed, match="value is not finite"):
        Toy(math.inf, []).publish(tmp_path / "toy.json")
    assert not list(tmp_path.iterdir())
    assert json.loads(Toy(1.0, [2.0]).write_json(tmp_path / "toy.json").read_text()) == {"value": 1.0, "curve": [2.0]}


def test_h2o2_sensitivities_from_1800_K_are_finite_and_match_cantera(tmp_path):
    out = tmp_path / "check.json"
    assert main(["kinetics", "check", H2O2, "--temperature", "1800", "--states", "5", "--json", str(out),
                 "--no-progress"]) == 0
    sensitivities = json.loads(out.read_text())["sensitivities"]
    assert not sensitivities["after_ignition"]  # 0.9 x the 0.0117 ms delay, not the 1000 K case's 0.27 ms
    assert sensitivities["max_relative_difference"] < 1e-3 and sensitivities["same_ranking"]
    assert np.all(np.isfinite([row["ours"] for row in sensitivities["top"]]))


def test_h2o2_from_2500_K_late_in_the_induction_fails_loudly(tmp_path, capsys):
    out = tmp_path / "check.json"
    assert main(["kinetics", "check", H2O2, "--temperature", "2500", "--states", "5", "--json", str(out),
                 "--no-progress"]) == 3
    assert "non-finite" in capsys.readouterr().err and not out.exists()
