"""`snapo pharma sensitivities`: the JSON keys of the issue, consistent with the API, and errors
on bad input before any compile."""

import json

import pytest

from snapo_ode.cli import main

from chemistry.pharma import CPP_NAMES, CQA_NAMES


def test_sensitivities_json_has_the_issue_keys(tmp_path, capsys):
    out = tmp_path / "sens.json"
    # The tolerances of tests/test_pharma_sensitivities.py, so one process compiles once.
    assert main(["pharma", "sensitivities", "--rtol", "1e-10", "--atol", "1e-12", "--repeats", "1",
                 "--json", str(out)]) == 0
    study = json.loads(out.read_text())
    for key in ("cqas", "matrix", "normalized", "parameter_sensitivities", "seconds_median", "compile_seconds",
                "max_rel_diff_fd", "reference_rel_error", "mode"):
        assert key in study, key
    assert list(study["cqas"]) == list(CQA_NAMES)
    assert all(list(study["matrix"][cqa]) == list(CPP_NAMES) for cqa in CQA_NAMES)
    assert study["mode"] == "reverse" and study["passes"] == 5
    assert study["max_rel_diff_fd"] <= 1e-5 and study["max_rel_diff_fd_parameters"] <= 1e-5
    assert study["reference_rel_error"] <= 1e-6
    assert len(study["parameter_sensitivities"]["impurity"]) == 43
    assert "impurity" in capsys.readouterr().out


@pytest.mark.parametrize(("argv", "field"), [
    (["--r1-residence-time", "-3"], "r1_residence_time"),
    (["--dryer-temperature", "100"], "dryer_temperature"),
    (["--rtol", "0"], "rtol"),
    (["--without", "cristallization"], "cristallization"),
    (["--mode", "sideways"], "mode"),
])
def test_bad_input_is_an_error_naming_the_field(argv, field, capsys):
    assert main(["pharma", "sensitivities", "--json", "/dev/null", *argv]) == 2
    assert field in capsys.readouterr().err
