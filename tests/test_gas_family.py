"""The generated family of storage contracts: reproducible, valid inputs, each shape and kind
showing the feature it names, and `snapo bench gas-family` writing its table at a small size."""

import json

import numpy as np
import pytest

from finance import gas_storage as gs
from finance.gas_storage import _family as family


def test_the_family_is_reproducible_valid_and_covers_every_shape_and_kind():
    cases = family.family()
    again = family.family()
    assert [c.name for c in cases] == [c.name for c in again]
    for case, twin in zip(cases, again):
        np.testing.assert_array_equal(case.curve, twin.curve)
        gs.make_inputs(case.facility, case.curve)  # validated as a user's files would be
    names = " ".join(c.name for c in cases)
    assert all(names.count(shape) >= 2 for shape in family.CURVE_SHAPES)
    assert all(names.count(kind) >= 2 for kind in family.FACILITY_KINDS)
    assert {len(c.curve) for c in cases} == {90, 180, 365}
    # Another seed gives other contracts.
    assert not np.allclose(family.family(1, seed=5)[0].curve, cases[0].curve)


def test_each_shape_and_kind_has_its_feature():
    weekly = family.curve("weekly", 364, 3)
    seasonal = family.curve("seasonal", 364, 3)
    weekend = np.arange(364) % 7 >= 5
    assert np.all(weekly[weekend] < seasonal[weekend]) and np.allclose(weekly[~weekend], seasonal[~weekend])
    assert np.sum(family.curve("holidays", 180, 1) < family.curve("seasonal", 180, 1) - 1e-12) >= 2
    assert np.sum(family.curve("spikes", 180, 1) > family.curve("seasonal", 180, 1) * 1.1) >= 2
    contango, backwardation = family.curve("contango", 365), family.curve("backwardation", 365)
    assert contango[-30:].mean() > 1.2 * contango[:30].mean()
    assert backwardation[-30:].mean() < 0.85 * backwardation[:30].mean()
    fast, slow = family.facility("fast"), family.facility("slow")
    assert fast["capacity"] / fast["max_injection"] < 15 < slow["capacity"] / slow["max_injection"]
    everything = family.facility("everything")
    assert everything["fuel_loss"] > 0 and everything["rate"] > 0 and len(everything["injection_ratchet"]) == 3
    with pytest.raises(ValueError, match="weekly"):
        family.curve("weekley", 10)


def test_bench_gas_family_writes_its_table(tmp_path):
    from snapo_ode.cli import main

    assert main(["bench", "gas-family", "--case", "nowhere-fast-90", "--out", str(tmp_path)]) == 2  # before any compile
    for option in ("--fit-paths", "--rolling-paths"):  # one-factor: no such option
        assert main(["bench", "gas-family", option, "100", "--out", str(tmp_path)]) == 2
    assert main(["bench", "gas-family", "--case", "weekly-fuel_costs-90", "--paths", "64", "--train-steps", "2",
                 "--volatility", "high", "--no-progress", "--out", str(tmp_path)]) == 0
    table = json.loads((tmp_path / "bench_gas_family.json").read_text())
    (row,) = table["rows"]
    assert row["case"] == "weekly-fuel_costs-90" and row["volatility"] == "high"
    assert row["dual_upper_bound"] >= row["intrinsic_lp"] and row["lsmc_out_of_sample"] > row["intrinsic_lp"]
    assert (tmp_path / "bench_gas_family.csv").read_text().startswith("case,")


def test_bench_gas_family_under_a_price_model_writes_its_table(tmp_path):
    """The two-factor family verb end to end at a tiny size: its row, its training and rolling
    intrinsic's paths as asked, its start chosen and timed."""
    from snapo_ode.cli import main

    assert main(["bench", "gas-family", "--price-model", "two-factor", "--case", "flat-fast-90", "--paths", "64",
                 "--fit-paths", "128", "--rolling-paths", "16", "--train-steps", "2", "--no-progress", "--out",
                 str(tmp_path)]) == 0
    table = json.loads((tmp_path / "bench_gas_family_two_factor.json").read_text())
    assert table["fit_paths"] == 128 and table["paths"] == 64 and table["price_model"] == "two-factor"
    assert table["results"]["flat-fast-90"]["rolling_paths"] == 16
    (row,) = table["rows"]
    assert row["case"] == "flat-fast-90" and row["goals"] != "all"  # two training steps meet no goal
    assert row["dual_upper_bound"] >= row["intrinsic_lp"] and row["rolling_intrinsic"] >= row["intrinsic_lp"]
    assert 0 <= row["lsmc_gap"] < 1 and 0 <= row["snapo_gap"] < 1
    assert table["results"]["flat-fast-90"]["lsmc_nodes"] == 101  # a fast facility: 4 steps to a day's flow fit in 101
    assert row["snapo_start"] in ("lattice", "lsmc") and row["start_seconds"] > 0
    assert row["dual_penalty_choice"] in ("lattice", "state", "blend")
    assert row["snapo_minus_rolling_control_variate_se"] > 0


def test_state_lsmc_default_grid_has_four_steps_to_a_days_flow():
    """The price-model LSMC's default grid (`trading_nodes(inputs, 101, 4)`): the fewest levels whose
    step is at most a quarter of a day's smaller full flow, on a slow facility (one step to it: 109 levels)."""
    from finance.gas_storage._bench_family import chosen_cases
    from finance.gas_storage._inputs import make_inputs
    from finance.gas_storage._model import largest_flows, stochastic_scene
    from finance.gas_storage._versus_lsmc import trading_nodes

    case = chosen_cases(None, ("contango-slow-180",), 0)[0]
    inputs = make_inputs(case.facility, case.curve)
    flow = min(largest_flows(inputs, stochastic_scene()))
    nodes = trading_nodes(inputs, 101, 4)
    capacity = float(inputs.capacity)
    assert capacity / (nodes - 1) <= flow / 4 < capacity / (nodes - 2)
