"""Every unit closes its mass balances to round-off (`chemistry.pharma.mass_balances`): on the
built-in process with each group of effects, at random CPPs and physical parameters, and the
check catches the crystallizer's accounting before issue 35 (incorporated impurity taken from
the liquor on top of the API's volume growth: 8.6e-4 of the crystals' mass unaccounted)."""

import jax.numpy as jnp
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from chemistry.pharma import PHARMA_EFFECTS, BUMP_SOLVER, Crystallizer, LinearRamp, PharmaChain, mass_balances

ROUND_OFF = 1e-12


@pytest.fixture(scope="module")
def chain():
    return PharmaChain(solver=BUMP_SOLVER)


@pytest.mark.parametrize("without", [(), ("crystallization", "impurity_incorporation", "energy_balance")])
def test_every_unit_closes_its_balances(without):
    chain = PharmaChain(scene=PHARMA_EFFECTS.scene(without=without), solver=BUMP_SOLVER)
    residuals = mass_balances(chain, chain.inputs(chain.cpps()))
    assert set(residuals) == {"r1", "r2", "crystallizer", "filter", "dryer"}
    assert max(float(r) for r in residuals.values()) <= ROUND_OFF, residuals


@settings(max_examples=8, deadline=None)
@given(r1=st.floats(303.15, 323.15), residence=st.floats(20.0, 40.0), cooling=st.floats(0.25, 1.0),
       dryer=st.floats(308.15, 328.15), cake=st.floats(0.05, 1.0), wash=st.floats(0.0, 0.5),
       partition=st.floats(0.0, 0.5), feed=st.floats(0.2, 0.4), seeds=st.floats(0.05, 2.0))
def test_balances_close_at_random_cpps_and_parameters(chain, r1, residence, cooling, dryer, cake, wash, partition,
                                                      feed, seeds):
    physical = chain.physical(**{"filter.cake_liquor": cake, "filter.wash_residue": max(wash, 1e-6),
                                 "crystallizer.partition_impurity": max(partition, 1e-6),
                                 "crystallizer.partition_degradant": max(partition / 2, 1e-6), "feed.A": feed,
                                 "feed.B": 1.1 * feed, "crystallizer.seed_loading": seeds})
    cpps = chain.cpps(r1_temperature=r1, r1_residence_time=residence, cooling_rate=cooling, dryer_temperature=dryer)
    residuals = mass_balances(chain, chain.inputs(cpps, physical=physical))
    assert max(float(r) for r in residuals.values()) <= ROUND_OFF, residuals


def test_the_check_catches_the_crystallizer_before_the_fix(chain):
    """With no mass given to the incorporated species (the accounting before the fix), the
    crystals' growth is the API alone while the liquor also loses the impurity and degradant."""
    inputs = chain.inputs(chain.cpps())
    crystallizer = chain.unit_parameters(inputs)["crystallizer"]
    masses = [float(m) for m in chain.molar_masses]
    fixed, before = (Crystallizer(masses[2], True, incorporated) for incorporated in ((masses[3], masses[5]), (0.0, 0.0)))
    ramp, args = LinearRamp(318.15, 278.15), (jnp.asarray(0.28), jnp.asarray(3e-3), jnp.asarray(1e-4))

    def unaccounted(physics):
        out = physics(*args, ramp, 4800.0, crystallizer, BUMP_SOLVER)
        lost = ((0.28 - float(out.api)) * masses[2] + float(out.impurity_solid) * masses[3]
                + float(out.degradant_solid) * masses[5])
        return abs(lost - (float(out.crystal_mass) - float(crystallizer["seed_loading"]))) / float(out.crystal_mass)

    assert unaccounted(fixed) <= ROUND_OFF
    assert unaccounted(before) >= 1e-4


@settings(max_examples=3, deadline=None)
@given(reactors=st.lists(st.sampled_from(["plug_flow_reactor", "batch_reactor", "cstr"]), min_size=1, max_size=2),
       dryer=st.booleans(), temperature=st.floats(300.0, 330.0), hold=st.floats(600.0, 7200.0))
def test_balances_close_on_random_flowsheets(reactors, dryer, temperature, hold):
    """Processes generated from the built-in one: its mechanism, one or two reactors of any type
    (the first one's temperature the CPP), the cooling crystallizer and the filter, a dryer or not."""
    from chemistry import MECHANISMS
    from chemistry.pharma import BUILT_IN_PROCESS, process_from_dict
    from snapo_ode import strict_yaml

    data = strict_yaml(BUILT_IN_PROCESS.read_text(), "the built-in process")
    data["mechanism"]["file"] = str(MECHANISMS / "pharma.yaml")
    parameters = {"plug_flow_reactor": {"jacket_ua": 2.0e4}, "batch_reactor": {"time": hold}, "cstr": {}}
    time = {"plug_flow_reactor": "residence_time", "batch_reactor": "time", "cstr": "residence_time"}
    units = []
    for k, kind in enumerate(reactors):
        unit = {"name": f"reactor{k}", "type": kind, **parameters[kind]}
        if k:  # the first reactor's temperature and time are the CPPs r1_temperature and r1_residence_time
            unit.update(temperature=temperature, **({time[kind]: 30.0} if kind != "batch_reactor" else {}))
        units.append(unit)
    data["units"] = units + data["units"][2:(5 if dryer else 4)]
    data["cpps"][0]["target"], data["cpps"][1]["target"] = "reactor0.temperature", f"reactor0.{time[reactors[0]]}"
    if reactors[0] == "batch_reactor":
        units[0].pop("time")
        data["cpps"][1]["unit"] = "min"
    if not dryer:
        data["cpps"] = data["cpps"][:3]
        data["cqas"] = [c for c in data["cqas"] if c["name"] != "residual_solvent"]
    data["uncertain"] = [name for name in data["uncertain"] if not name.startswith("dryer.") or dryer]
    chain = PharmaChain(process=process_from_dict(data, name="random flowsheet"), solver=BUMP_SOLVER)
    residuals = mass_balances(chain, chain.inputs(chain.cpps()))
    assert len(residuals) == len(reactors) + 2 + dryer
    assert max(float(r) for r in residuals.values()) <= ROUND_OFF, residuals
