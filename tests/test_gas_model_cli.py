"""`snapo gas --price-model` and the paths-file flags: bad input is exit 2 with one line naming the
file, before any compile; a small two-factor run writes every method's figures."""

import json
import pathlib

import numpy as np
import pytest

from finance import gas_storage as gs


@pytest.fixture
def small_contract(tmp_path):
    facility = dict(gs.sample_facility(), capacity=10_000.0, initial_inventory=4_000.0,
                    terminal_inventory_min=4_000.0, max_injection=2_000.0, max_withdrawal=3_000.0)
    facility_file = tmp_path / "facility.json"
    facility_file.write_text(json.dumps(facility))
    curve_file = tmp_path / "curve.csv"
    curve_file.write_text("day,price\n" + "".join(f"{d},{3 + 0.2 * np.sin(d / 3):.4f}\n" for d in range(12)))
    return ["--facility", str(facility_file), "--curve", str(curve_file)]


@pytest.mark.parametrize("write, flags, message", [
    (lambda p: p.write_text("model: two-factor\nshort_mean_reversion: 3 /week\n"), ["--price-model"],
     "line 2: short_mean_reversion = '3 /week': unknown unit"),
    (lambda p: np.savez(p, spot=np.full((5, 11), 3.0)), ["--stochastic", "--value-paths-file"],
     "11 days of spot; the forward curve has 12"),
    (lambda p: np.savez(p, spot=np.full((5, 12), 3.0)), ["--price-model", "DATA", "--train-paths-file"],
     "the file gives no factors"),
])
def test_bad_model_and_paths_files_exit_2_before_compiling(tmp_path, capsys, small_contract, write, flags, message):
    from snapo_ode.cli import main
    from finance.gas_storage._price_model_file import files

    suffix = ".yaml" if flags[-1] == "--price-model" else ".npz"
    path = tmp_path / f"input{suffix}"
    write(path)
    flags = [str(files("finance") / "data" / "price_model_two_factor.yaml") if f == "DATA"
             else f for f in flags]
    assert main(["gas", *small_contract, *flags, str(path), "--json", str(tmp_path / "x.json")]) == 2
    error = capsys.readouterr().err.strip().splitlines()
    assert message in error[-1] and str(path) in error[-1]


def test_state_lsmc_degree_beyond_the_state_basis_exits_2_before_reading_the_model(tmp_path, capsys, small_contract):
    """The one-factor LSMC takes degrees to 12 in the spot; the state's monomials stop at 6."""
    from snapo_ode.cli import main

    assert main(["gas", *small_contract, "--price-model", str(tmp_path / "absent.yaml"), "--lsmc-degree", "7",
                 "--json", str(tmp_path / "x.json")]) == 2
    assert "--lsmc-degree = 7; allowed: a whole number in [1, 6]" in capsys.readouterr().err


def test_cli_two_factor_writes_every_method(tmp_path, small_contract, monkeypatch):
    from snapo_ode.cli import main
    from finance.gas_storage import _model_study
    from finance.gas_storage._price_model_file import files
    from finance.gas_storage._versus_lsmc import trading_nodes

    model = files("finance") / "data" / "price_model_two_factor.yaml"
    out = tmp_path / "gas.json"
    # Without --lsmc-nodes the grid is the price model's default: LEVELS_PER_FLOW steps to a day's
    # smaller full flow (raised here so that it exceeds the 101-level floor on this fast store).
    monkeypatch.setattr(_model_study, "LEVELS_PER_FLOW", 30)
    assert main(["gas", *small_contract, "--price-model", str(model), "--paths", "300", "--train-steps", "5",
                 "--train-paths", "64", "--lsmc-degree", "1", "--json", str(out), "--no-progress"]) == 0
    result = json.loads(out.read_text())
    facility = json.loads(pathlib.Path(small_contract[1]).read_text())
    curve = np.loadtxt(small_contract[3], delimiter=",", skiprows=1)[:, 1]
    assert result["lsmc_nodes"] == trading_nodes(gs.make_inputs(facility, curve), 101, 30) > 101
    assert result["lsmc_degree"] == 1  # --lsmc-degree reaches the state LSMC (default 2 there, 3 in the spot)
    for key in ("intrinsic_lp", "rolling_intrinsic", "lsmc_out_of_sample", "snapo_out_of_sample", "snapo_minus_lsmc",
                "dual_upper_bound", "snapo_gap", "deltas", "lsmc_pathwise_deltas", "warnings"):
        assert key in result
    assert len(result["deltas"]) == 12
    assert result["dual_upper_bound"] >= result["snapo_value_control_variate"]
    # The trained policy is saved beside the JSON and, loaded, values the run's evaluation paths as the run did.
    import jax

    from finance.gas_storage._model import stochastic_scene
    from finance.gas_storage._price_model_file import load_price_model
    from finance.gas_storage._price_models import model_paths
    from finance.gas_storage._state_policy import simulate_state_policy
    from snapo_ode import sha256

    saved = out.with_suffix(".policy.eqx")
    assert result["attachments"] == {saved.name: sha256(saved.read_bytes())}
    policy = gs.load_storage_policy(saved)
    inputs = gs.make_inputs(json.loads(open(small_contract[1]).read()),
                            np.loadtxt(small_contract[3], delimiter=",", skiprows=1)[:, 1])
    evaluation = model_paths(load_price_model(model), inputs.forward_curve, 300, jax.random.fold_in(jax.random.key(0), 13))
    value = simulate_state_policy(policy, inputs, stochastic_scene(), evaluation, sharpness=None).value
    assert float(np.mean(value)) == pytest.approx(result["snapo_out_of_sample"], rel=1e-10)
