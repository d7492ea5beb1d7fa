"""The second shipped process, `processes/antisolvent_route.yaml`, which differs from the built-in
in every dimension (its own mechanism and species names, two reaction steps, a CSTR at steady
state, an antisolvent crystallizer, no dryer, five CPPs and other CQAs): its sensitivities equal
central differences and every balance closes (each reactor against Cantera's own:
tests/test_pharma_every_reactor.py)."""

import numpy as np
import pytest

from chemistry.pharma import BUMP_SOLVER, PharmaChain, mass_balances, sensitivity_study

PROCESS = "antisolvent_route"  # a shipped process, by its name


def test_it_is_a_different_process():
    chain = PharmaChain(process=PROCESS)
    assert [u.type for u in chain.process.units] == ["cstr", "batch_reactor", "antisolvent_crystallizer", "filter"]
    assert chain.mechanism.species_names == ("SM", "AM", "INT", "API", "DIMER", "OX", "MeOH", "H2O")
    assert len(chain.cpp_names) == 5 and chain.cqa_names == ("purity", "dimer", "isolated_yield", "d43",
                                                             "loss_on_drying")
    assert chain.cpp_ranges[0].nominal == pytest.approx(323.15)  # given as 50 degC
    np.testing.assert_allclose(chain.masses, [120.0, 90.0, 210.0, 210.0, 330.0, 210.0, 32.042, 18.015])


def test_its_sensitivities_equal_central_differences_and_its_balances_close():
    chain = PharmaChain(process=PROCESS, solver=BUMP_SOLVER)
    study = sensitivity_study(chain, chain.cpps(), repeats=1, reference=None)
    assert study.max_rel_diff_fd <= 1e-5 and study.max_rel_diff_fd_parameters <= 1e-5
    assert len(study.matrix) == 5 and all(len(row) == 5 for row in study.matrix.values())
    # More water, less API left in the liquor: a higher yield; no dryer: the cake stays wet.
    assert study.matrix["isolated_yield"]["water_ratio"] > 0 and study.cqas["loss_on_drying"] > 20
    # A hotter ageing reactor cyclises more of the intermediate: a higher yield.
    assert study.matrix["isolated_yield"]["ageing_temperature"] > 0
    assert max(float(r) for r in mass_balances(chain, study.inputs).values()) <= 1e-12
