"""The design space (Monte Carlo next to the linearised estimate) and the trained temperature
profiles (smooth for training, hard spec checks for reporting)."""

import numpy as np
import pytest

import snapo_ode
from chemistry.pharma import BUMP_SOLVER, PharmaChain, design_space, make_cpps, train_profiles


def test_design_space_monte_carlo_agrees_with_the_linearised_estimate():
    # 2 x 2 points x 47 draws: the batch shape of the central differences, so a process that ran
    # those compiles nothing new.
    chain = PharmaChain(solver=BUMP_SOLVER)
    space = design_space(chain, make_cpps(), points=2, samples=47, sigma=0.1)
    mc, linear = np.array(space.probability_mc), np.array(space.probability_linear)
    assert mc.shape == linear.shape == (2, 2)
    assert np.all((0 <= mc) & (mc <= 1))
    # The hot corner (R1 and dryer at the top of their PARs) fails the degradant spec whatever the
    # kinetics; the cool corner passes for most draws.
    assert mc[1, 1] == 0.0 and mc[0, 0] >= 0.5
    assert space.max_abs_difference <= 0.15
    with pytest.raises(snapo_ode.InputError, match="x = 'r1_pressure'"):
        design_space(chain, make_cpps(), x="r1_pressure")


def test_trained_profiles_raise_the_yield_and_are_checked_hard():
    study = train_profiles(PharmaChain(), make_cpps(), steps=12, progress=False)
    baseline, trained = study.baseline, study.trained
    assert trained["api_yield"] > baseline["api_yield"]
    assert trained["meets_all_specs"]
    assert all(margin >= 0 for margin in trained["spec_margins"].values())
    assert trained["gap"] == pytest.approx(trained["api_yield"] - trained["smooth_objective"])
    assert all(303.15 <= t <= 323.15 for t in study.r1_jacket_profile)
    assert study.cooling_profile[0] == pytest.approx(318.15) and study.cooling_profile[-1] == pytest.approx(278.15)
