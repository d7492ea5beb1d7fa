"""`snapo kinetics check` uses the case it is given. (`snapo bench kinetics` runs end to end, single
and batched, in test_kinetics_batch.py: one run of the bench serves both.)"""

import json

from snapo_ode.cli import main


def test_kinetics_check_applies_the_case_flags_without_a_mixture(tmp_path, capsys):
    # Before: --temperature acted only together with --mixture, and the built-in 1000 K case ran.
    import cantera

    h2o2 = f"{cantera.__file__.rsplit('/', 1)[0]}/data/h2o2.yaml"
    out = tmp_path / "check.json"
    assert main(["kinetics", "check", h2o2, "--temperature", "1100", "--end-time", "5e-4", "--states", "10",
                 "--no-sensitivities", "--json", str(out), "--no-progress"]) == 0
    result = json.loads(out.read_text())
    assert result["ignition"]["case"]["temperature"] == 1100.0 and result["ignition"]["case"]["end_time"] == 5e-4
    assert result["ignition"]["delay_relative_error"] < 1e-4
    assert "from 1100 K" in capsys.readouterr().out
    assert main(["kinetics", "check", h2o2, "--sensitivity-time", "1", "--json", str(out)]) == 2
