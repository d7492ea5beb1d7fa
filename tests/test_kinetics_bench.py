"""`snapo bench kinetics` runs end to end at a small size, and its two solvers agree on the
temperature they are timed to (the timings themselves live in the benchmark, not here); `snapo
kinetics check` uses the case it is given."""

import json

from snapo_ode.cli import main


def test_bench_kinetics_writes_a_row_with_both_solvers(tmp_path):
    assert main(["bench", "kinetics", "--out", str(tmp_path), "--mechanisms", "h2o2", "--repeats", "1"]) == 0
    (row,) = json.loads((tmp_path / "bench_kinetics.json").read_text())["rows"]
    assert row["mechanism"] == "h2o2" and row["parameters"] == 29
    # Equal tolerances, not equal errors: Cantera's atol 1e-14 is on mass fractions (ours on
    # amounts over the initial total): its T here is 2.7e-6 off its converged value (rtol 1e-12,
    # atol 1e-20: 1008.03118 K), ours 1.5e-7.
    assert abs(row["final_temperature_K"] / row["cantera_final_temperature_K"] - 1) < 1e-5
    assert all(row[key] > 0 for key in ("forward_s", "gradient_s", "cantera_forward_s", "cantera_sensitivities_s"))
    assert (tmp_path / "bench_kinetics.csv").read_text().count("\n") == 2


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
