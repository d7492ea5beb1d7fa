"""Reliability II (issue 33): no wrong result from a stale checkpoint or a shared cache, no input
that exhausts memory, every failure a one-line exit 2 (user), 3 (solve) or 4 (environment)."""

import json
import re


from finance import gas_storage as gs
from snapo_ode.cli import main


def error_of(argv, capsys, code=2) -> str:
    assert main(argv) == code
    err = capsys.readouterr().err
    assert err.startswith("snapo: error: ") and err.count("\n") == 1, err
    return err


def test_resume_refuses_the_checkpoint_of_another_facility_or_seed(tmp_path, capsys):
    gas = ["gas", "--train-steps", "3", "--no-progress", "--out", str(tmp_path / "gas")]
    assert main(gas) == 0
    other = dict(gs.sample_facility(), capacity=2_000_000.0, terminal_inventory_min=0.0)
    (tmp_path / "other.json").write_text(json.dumps(other))
    err = error_of([*gas, "--facility", str(tmp_path / "other.json"), "--resume"], capsys)
    assert re.search("is of another run: its [a-z ,]*inputs[a-z ,]* differ", err), err
    assert main([*gas, "--resume"]) == 0  # its own run resumes
    alm = ["alm", "--risk-factors", "10", "--paths", "8", "--horizon-months", "3", "--train-steps", "3",
           "--train-paths", "8", "--no-progress", "--out", str(tmp_path / "alm")]
    assert main(alm) == 0
    assert re.search("its [a-z ,]*key[a-z ,]* differ", error_of([*alm, "--seed", "1", "--resume"], capsys))
