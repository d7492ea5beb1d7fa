"""Every reactor of a process against Cantera's own reactor, fed with the stream the chain computes
for it: both shipped processes and `tests/data/coil_route.yaml`, whose jacketed plug-flow coil
follows a CSTR that shrinks the liquid (so the coil's inlet volume is not the feed's, and a jacket
term taken per m^3 of feed instead of per m^3 of the reactor would be seen)."""

import pathlib

import numpy as np
import pytest

from chemistry.pharma import CHAIN_SOLVER, PharmaChain, cantera_check, cantera_reactors

COIL_ROUTE = pathlib.Path(__file__).parent / "data" / "coil_route.yaml"
TIGHT = CHAIN_SOLVER.replace(rtol=1e-12, atol=1e-14, max_steps=20000)
PROCESSES = {  # process -> (its reactors, CPPs off nominal where a shipped test used them)
    "api_chain": (("r1", "r2"), {"r1_temperature": 318.15}),
    "antisolvent_route": (("coupling", "ageing"), {"coupling_temperature": 328.15, "ageing_temperature": 330.15}),
    COIL_ROUTE: (("coupling", "coil"), {"coil_temperature": 335.15}),
}


@pytest.mark.parametrize("process", PROCESSES, ids=["api_chain", "antisolvent_route", "coil_route"])
def test_every_reactor_agrees_with_cantera_s_own(process):
    reactors, cpps = PROCESSES[process]
    chain = PharmaChain(process=process, solver=TIGHT)
    differences = cantera_reactors(chain, chain.inputs(chain.cpps(**cpps)))
    assert tuple(differences) == reactors
    for name, (amounts, temperature) in differences.items():
        assert amounts <= 1e-8 and temperature <= 1e-10, (name, amounts, temperature)


def test_the_coil_follows_a_volume_change_and_its_jacket_is_per_reactor_volume():
    chain = PharmaChain(process=COIL_ROUTE, solver=TIGHT)
    inputs = chain.inputs(chain.cpps())
    result = chain.simulate(inputs)
    volumes = np.asarray(chain.mechanism.molar_volumes)
    coil_inlet = result.outlets["coupling"]
    assert float(np.asarray(coil_inlet.amounts) @ volumes) < 0.995  # the CSTR shrank the liquid by > 0.5 %
    # The coil enters at the CSTR's temperature (50 degC) and its jacket (60 degC) heats it.
    assert float(coil_inlet.temperature) == pytest.approx(323.15, abs=1e-9)
    assert float(result.outlets["coil"].temperature) > 332.0
    check = cantera_check(chain, chain.cpps(), inputs.physical, chain.process.mechanism, n_states=10)
    assert tuple(check.reactors) == ("coupling", "coil")
    assert (check.r1_amounts, check.r1_temperature) == check.reactors["coupling"]
    assert check.reactors["coil"][0] <= 1e-8 and check.reactors["coil"][1] <= 1e-10
    # Its molar volumes differ, so the rate laws' activity concentrations x_k / v_k (the
    # species-molar-volume basis) are not the molar concentrations: the rates still are Cantera's.
    concentrations = np.asarray(coil_inlet.amounts) / float(np.asarray(coil_inlet.amounts) @ volumes)
    activities = np.asarray(chain.mechanism.activity_concentrations(concentrations))
    present = concentrations > 0  # no water before the crystallizer
    assert np.max(np.abs(activities[present] / concentrations[present] - 1)) > 0.2
    assert check.rates_of_progress <= 1e-12 and check.net_production <= 1e-10
