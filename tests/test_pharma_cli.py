"""`snapo pharma sensitivities`: the JSON keys of the issue, consistent with the API, and errors
on bad input before any compile."""

import json

import pytest

from snapo_ode.cli import main

from chemistry.pharma import CPP_NAMES, CQA_NAMES


def test_sensitivities_json_has_the_issue_keys(tmp_path, capsys):
    out = tmp_path / "sens.json"
    # The tolerances of tests/test_pharma_sensitivities.py, so one process compiles once.
    # A program of the study that could not be kept on disk would fail this run: its warning is an
    # error in the tests (pyproject.toml).
    assert main(["pharma", "sensitivities", "--rtol", "1e-10", "--atol", "1e-12", "--repeats", "1",
                 "--json", str(out)]) == 0
    study = json.loads(out.read_text())
    for key in ("cqas", "matrix", "normalized", "parameter_sensitivities", "seconds_median", "compile_seconds",
                "max_rel_diff_fd", "reference_rel_error", "mode"):
        assert key in study, key
    assert list(study["cqas"]) == list(CQA_NAMES)
    assert all(list(study["matrix"][cqa]) == list(CPP_NAMES) for cqa in CQA_NAMES)
    assert study["mode"] == "reverse" and study["passes"] == 5
    assert study["reference_solver"]["differentiation"] == "forward"  # the other mode: it checks the adjoint too
    assert study["max_rel_diff_fd"] <= 1e-5 and study["max_rel_diff_fd_parameters"] <= 1e-5
    assert study["reference_rel_error"] <= 1e-6
    assert len(study["parameter_sensitivities"]["impurity"]) == 43
    assert "impurity" in capsys.readouterr().out
    assert not [w for w in study["warnings"] if w.startswith("solver error")]  # 1e-10 is accurate enough


def test_a_loose_tolerance_warns_and_strict_refuses(tmp_path, capsys):
    # Before: an assay of 90.4% and 95,116 ppm of solvent (nominal 99.85%, 126 ppm) with no warning.
    out = tmp_path / "loose.json"
    loose = ["pharma", "sensitivities", "--rtol", "0.5", "--atol", "0.005", "--no-bumps", "--repeats", "1",
             "--no-progress"]
    assert main([*loose, "--json", str(out)]) == 0
    warnings = [w for w in json.loads(out.read_text())["warnings"] if w.startswith("solver error")]
    assert len(warnings) == 3 and "tighten --rtol" in warnings[0]
    assert "snapo: warning: solver error" in capsys.readouterr().err
    strict = tmp_path / "strict.json"
    assert main([*loose, "--strict", "--json", str(strict)]) == 3
    assert "--strict" in capsys.readouterr().err and not strict.exists()


@pytest.mark.parametrize(("argv", "field"), [
    (["--r1-residence-time", "-3"], "r1_residence_time"),
    (["--dryer-temperature", "100"], "dryer_temperature"),
    (["--rtol", "0"], "rtol"),
    (["--without", "cristallization"], "cristallization"),
    (["--mode", "sideways"], "mode"),
])
def test_bad_input_is_an_error_naming_the_field(argv, field, capsys, tmp_path):
    assert main(["pharma", "sensitivities", "--json", str(tmp_path / "s.json"), *argv]) == 2
    assert field in capsys.readouterr().err


def test_the_report_refuses_a_loose_tolerance_under_strict_before_the_design_space(tmp_path, capsys):
    out = tmp_path / "report"
    code = main(["report", "pharma", "--rtol", "0.5", "--atol", "0.005", "--strict", "--repeats", "1", "--no-pdf",
                 "--no-progress", "--out", str(out)])
    assert code == 3
    err = capsys.readouterr().err
    assert "snapo: warning: solver error" in err and "--strict" in err
    assert not out.exists()


def test_the_help_follows_the_process_not_the_built_in_chain(capsys):
    for verb in ("sensitivities", "train", "design-space"):
        assert main(["pharma", verb, "--help"]) == 0
        text = " ".join(capsys.readouterr().out.split())
        assert "its units, CPPs and CQAs are the file's" in text and "another process's CPPs: --set" in text
        assert "api_chain's CPP r1_temperature" in text and "the stiff units R1 and R2" not in text
