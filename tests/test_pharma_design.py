"""The design space (a sensitivity-based surrogate checked by full Monte Carlo, its edges of failure)
and the trained temperature profiles (smooth for training, hard spec checks for reporting)."""

import numpy as np
import pytest

import snapo_ode
from chemistry.pharma import BUMP_SOLVER, ParameterRange, PharmaChain, design_space, make_cpps, train_profiles
from chemistry.pharma._design_edges import acceptable_range, choose_verification_points, probability_se


def test_design_space_surrogate_agrees_with_full_monte_carlo():
    # 3 x 3 grid; 4 verification points x 47 draws: the batch shape of the central differences, so a
    # process that ran those compiles nothing new.
    chain = PharmaChain(solver=BUMP_SOLVER)
    space = design_space(chain, make_cpps(), points=3, verify_points=4, samples=47, surrogate_samples=512,
                         curvature_points=2)
    probability = np.array(space.probability)
    assert probability.shape == (3, 3) and np.all((0 <= probability) & (probability <= 1))
    # The hot end of the dryer's PAR fails the degradant spec for most draws; the operating point passes.
    assert probability[:, 2].max() < 0.5 and space.operating_probability >= 0.95
    assert all(space.limiting_cqa[i][2] == "degradant" for i in range(3))
    check = space.verification
    assert check["points"][0]["x"] == 313.15 and check["points"][0]["y"] == 318.15
    assert check["all_within_se"] and check["max_difference_over_se"] <= 1.0
    assert space.edges["dryer_temperature"]["edge_high"] < 328.15
    with pytest.raises(snapo_ode.InputError, match="x = 'r1_pressure'"):
        design_space(chain, make_cpps(), x="r1_pressure")
    with pytest.raises(snapo_ode.InputError, match="curvature_points = 1"):
        design_space(chain, make_cpps(), curvature_points=1)


def test_edges_of_failure_and_verification_points_on_a_known_map():
    values = np.linspace(300.0, 320.0, 5)  # PAR; NOR 305-315
    spec = ParameterRange("t", "K", 310.0, (305.0, 315.0), (300.0, 320.0), (0.0, 1e9), "")
    found = acceptable_range(values, np.array([0.5, 0.96, 1.0, 0.99, 0.7]), 2, 0.95, spec)
    assert found.edge_low == pytest.approx(300.0 + 5.0 * (0.96 - 0.5 - 0.01) / (0.96 - 0.5))
    assert found.edge_high == pytest.approx(315.0 + 5.0 * (0.99 - 0.95) / (0.99 - 0.7))
    assert found.as_dict()["margin_above_nor"] == pytest.approx(found.edge_high - 315.0)
    everywhere = acceptable_range(values, np.ones(5), 2, 0.95, spec)
    assert everywhere.interval == [300.0, 320.0] and everywhere.edge_low is None and everywhere.edge_high is None
    assert acceptable_range(values, np.full(5, 0.5), 2, 0.95, spec).interval is None
    grid = np.ones((5, 5))
    grid[:, 4] = 0.0
    grid[:, 3] = [0.9, 0.93, 0.96, 0.97, 0.999]
    chosen = choose_verification_points(grid, (2, 2), 4, 0.95)
    assert chosen[0] == (2, 2) and chosen[1] == (2, 3) and len(set(chosen)) == 4
    assert all(j == 3 for _, j in chosen[1:])  # the edge of failure first
    assert probability_se(0, 98) == pytest.approx(np.sqrt((1 / 100) * (99 / 100) / 98))


def test_trained_profiles_raise_the_yield_and_are_checked_hard():
    study = train_profiles(PharmaChain(), make_cpps(), steps=12, progress=False)
    baseline, trained = study.baseline, study.trained
    assert trained["api_yield"] > baseline["api_yield"]
    assert trained["meets_all_specs"]
    assert all(margin >= 0 for margin in trained["spec_margins"].values())
    assert trained["gap"] == pytest.approx(trained["api_yield"] - trained["smooth_objective"])
    assert all(303.15 <= t <= 323.15 for t in study.r1_jacket_profile)
    # The JSON names each profile by its unit; r1_jacket_profile stays as a deprecated alias.
    payload = study.to_json()
    assert payload["profiles"] == {"r1": study.r1_jacket_profile, "crystallizer": study.cooling_profile}
    assert payload["r1_jacket_profile"] == payload["profiles"][study.jacket_unit]
    assert study.cooling_profile[0] == pytest.approx(318.15) and study.cooling_profile[-1] == pytest.approx(278.15)
