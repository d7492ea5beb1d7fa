"""The CQA vocabulary a chemist signs: `yield` is the API the process made and isolated (the seed
crystals charged are not product), `yield_including_seed` the product's API as it is, and
`residual_solvent` is stated per solvent (`{residual_solvent: species}`, ICH Q3C's limits are
per solvent) beside the total. Each against an independent reckoning from the units' own
streams, and their sensitivities against central differences on the test process
`tests/data/coil_route.yaml` (methanol solvent, water antisolvent, a dryer)."""

import pathlib

import numpy as np
import pytest

from chemistry.pharma import BUMP_SOLVER, PharmaChain, arrhenius, cqa_dict, cqa_vector, mass_balances, sensitivity_study

COIL_ROUTE = pathlib.Path(__file__).parent / "data" / "coil_route.yaml"


@pytest.fixture(scope="module")
def coil():
    chain = PharmaChain(process=COIL_ROUTE)
    inputs = chain.inputs(chain.cpps())
    result = chain.simulate(inputs)
    return chain, inputs, result, cqa_dict(cqa_vector(result, chain.process), chain.process)


def test_the_yield_is_the_api_the_liquor_lost_to_the_crystals_not_the_seeds():
    # antisolvent_route has no dryer: the product is the cake, its API the crystals' and the retained liquor's.
    chain = PharmaChain(process="antisolvent_route")
    inputs = chain.inputs(chain.cpps())
    result = chain.simulate(inputs)
    roles, masses = chain.roles, np.asarray(chain.molar_masses)
    parameters = chain.unit_parameters(inputs)
    slurry = result.outlets["crystallizer"]
    liquor_volume = float(np.asarray(result.outlets["ageing"].amounts) @ np.asarray(chain.mechanism.molar_volumes))
    fed = float(inputs.physical["feed.SM"]) / liquor_volume  # [kmol SM per m^3 of liquor]
    liquid = float(parameters["filter"]["cake_liquor"] * slurry.crystals.crystal_mass)
    liquor = np.asarray(slurry.final_liquor(roles)) * masses
    retained_api = float(parameters["filter"]["wash_residue"]) * liquid * liquor[roles.api] / liquor.sum()
    crystallized = float(slurry.liquor[roles.api] - slurry.crystals.api)  # [kmol/m^3] out of the liquor
    made = crystallized + float(retained_api) / masses[roles.api]
    cqas = cqa_dict(cqa_vector(result, chain.process), chain.process)
    assert cqas["isolated_yield"] == pytest.approx(100 * made / fed, rel=1e-12)
    seeds = float(parameters["crystallizer"]["seed_loading"]) / masses[roles.api]
    assert float(result.api_yield_including_seed) == pytest.approx(100 * (made + seeds) / fed, rel=1e-12)
    assert float(result.api_yield_including_seed - result.api_yield) > 0.1  # percentage points: not round-off


def test_residual_solvent_per_solvent_sums_to_the_total_and_dries_at_the_one_rate(coil):
    chain, inputs, result, cqas = coil
    assert cqas["methanol"] + 1e4 * cqas["water"] == pytest.approx(cqas["residual_solvent"], rel=1e-12)
    cake, product = result.cake, result.product
    roles, masses = chain.roles, np.asarray(chain.molar_masses)
    parameters = chain.unit_parameters(inputs)
    # The cake: the retained mother liquor's water; its methanol plus all the wash (methanol).
    slurry = result.outlets["crystallizer"]
    liquid = float(parameters["filter"]["cake_liquor"] * slurry.crystals.crystal_mass)
    liquor = np.asarray(slurry.final_liquor(roles)) * masses
    retained = float(parameters["filter"]["wash_residue"]) * liquid * liquor / liquor.sum()
    wash = liquid - retained.sum()  # what the wash put in the cake's liquid in place of the liquor
    np.testing.assert_allclose(np.asarray(cake.by_solvent), [retained[roles.solvent] + wash, retained[roles.antisolvent]],
                               rtol=1e-12)
    # The dryer: first order at one rate for both, the closed form exp(-k t).
    dryer = parameters["dryer"]
    rate = float(arrhenius(dryer["drying_rate"], dryer["drying_activation"], dryer["temperature"],
                           dryer["reference_temperature"]))
    np.testing.assert_allclose(np.asarray(product.by_solvent),
                               np.asarray(cake.by_solvent) * np.exp(-rate * float(dryer["time"])),
                               rtol=1e-7)  # Tsit5 at rtol 1e-8
    assert cqas["methanol"] == pytest.approx(1e6 * float(product.by_solvent[0] / product.total), rel=1e-12)


def test_the_new_cqas_sensitivities_equal_central_differences_and_the_balances_close():
    chain = PharmaChain(process=COIL_ROUTE, solver=BUMP_SOLVER)
    study = sensitivity_study(chain, chain.cpps(), repeats=1, reference=None)
    assert study.max_rel_diff_fd <= 1e-5 and study.max_rel_diff_fd_parameters <= 1e-5
    # The seeds are a constant: the two yields move alike with every CPP but the coupling's (the liquor's volume).
    assert study.matrix["yield"]["water_ratio"] == pytest.approx(study.matrix["yield_including_seed"]["water_ratio"],
                                                                 rel=1e-9)
    # A hotter dryer leaves less of either solvent.
    assert study.matrix["methanol"]["dryer_temperature"] < 0 and study.matrix["water"]["dryer_temperature"] < 0
    assert max(float(r) for r in mass_balances(chain, study.inputs).values()) <= 1e-12
