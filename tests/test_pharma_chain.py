"""The pharma chain: the mechanism and R1 against Cantera, the dryer against its closed form, the
crystallizer's mass balance, effects absent from the jaxpr, and the errors bad input gets."""

import itertools
import unittest.mock

import cantera
import diffrax
import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
import pytest

import snapo_ode
from chemistry import Mechanism
from chemistry.pharma import (
    CHAIN_SOLVER, CPP_NAMES, CPP_RANGES, DEFAULT_MECHANISM, PHARMA_EFFECTS, Crystallizer, Dryer, LinearRamp,
    PharmaChain, arrhenius, cantera_check, cqa_vector, default_physical_parameters, make_cpps, outside_par,
    r1_trajectory, solubility, stiffness_ratio)

TIGHT = CHAIN_SOLVER.replace(rtol=1e-12, atol=1e-14, max_steps=20000)


@pytest.fixture(scope="module")
def physical():
    return default_physical_parameters()


def unit_parameters(physical, unit: str, **cpps) -> dict:
    """The built-in chain's `unit` parameters (name -> value) at the nominal CPPs, or at `cpps`."""
    chain = PharmaChain()
    return chain.unit_parameters(chain.inputs(make_cpps(**cpps), physical=physical))[unit]


@pytest.mark.parametrize("without", [(), ("energy_balance",)])
def test_mechanism_rates_and_r1_match_cantera(physical, without):
    chain = PharmaChain(scene=PHARMA_EFFECTS.scene(without=without), solver=TIGHT)
    check = cantera_check(chain, make_cpps(r1_temperature=318.15), physical, DEFAULT_MECHANISM, n_states=60)
    assert check.rates_of_progress <= 1e-12
    assert check.net_production <= 1e-10
    assert check.r1_amounts <= 1e-8  # ConstPressureReactor (+ wall to the jacket) at rtol 1e-11
    assert check.r1_temperature <= 1e-10
    assert tuple(check.reactors) == ("r1", "r2")  # every reactor (tests/test_pharma_every_reactor.py)


def test_mechanism_is_liquid_and_molar_masses_are_cantera_s():
    liquid = cantera.Solution(str(DEFAULT_MECHANISM))
    assert liquid.thermo_model == "ideal-condensed" and liquid.kinetics_model == "bulk"
    assert all(not reaction.reversible for reaction in liquid.reactions())
    masses = np.asarray(PharmaChain().molar_masses)
    # Cantera's from the elements, but the solvent's, which the process file states (46.07, Cantera 46.069).
    np.testing.assert_array_equal(masses[:-1], liquid.molecular_weights[:-1])
    assert liquid.species_names[-1] == "S" and masses[-1] == 46.07
    np.testing.assert_allclose(masses, liquid.molecular_weights, rtol=1e-4)


@pytest.mark.parametrize("corner", list(itertools.product(*[r.par for r in CPP_RANGES[:2]])))
def test_r1_is_stiff_and_stays_non_negative_at_every_corner(physical, corner):
    chain = PharmaChain()
    cpps = make_cpps(**dict(zip(CPP_NAMES[:2], corner, strict=True)))
    times, amounts, temperature = r1_trajectory(chain, cpps, physical)
    assert times[-1] == pytest.approx(60 * corner[1])
    assert amounts.min() >= -chain.solver.atol
    assert np.all(np.abs(temperature - corner[0]) < 5.0)
    assert stiffness_ratio(chain, cpps, physical) >= 1e6
    # The stiffness persists along the trajectory, not only at the feed.
    assert stiffness_ratio(chain, cpps, physical, jnp.asarray(amounts[len(amounts) // 2])) >= 1e6


def test_dryer_matches_its_closed_form(physical):
    dryer = unit_parameters(physical, "dryer", dryer_temperature=321.0)
    temperature = dryer["temperature"]
    out = Dryer(True).dry(jnp.asarray(0.3), jnp.asarray(0.99), dryer, TIGHT)
    time = float(dryer["time"])
    drying = float(arrhenius(dryer["drying_rate"], dryer["drying_activation"], temperature, dryer["reference_temperature"]))
    degrading = float(arrhenius(dryer["degradation_rate"], dryer["degradation_activation"], temperature,
                                dryer["reference_temperature"]))
    assert float(out.solvent) == pytest.approx(0.3 * np.exp(-drying * time), rel=1e-9)
    assert float(out.degradant_formed) == pytest.approx(0.99 * -np.expm1(-degrading * time), rel=1e-8)


def test_crystallizer_conserves_mass_and_follows_van_t_hoff(physical):
    api0, crystallizer = jnp.asarray(0.28), unit_parameters(physical, "crystallizer")
    api_mass, impurity_mass, degradant_mass = (float(PharmaChain().molar_masses[k]) for k in (2, 3, 5))  # P, I, D
    ramp = LinearRamp(physical["r2.temperature"], crystallizer["final_temperature"])
    physics = Crystallizer(api_mass, True, (impurity_mass, degradant_mass))
    out = physics(api0, jnp.asarray(3e-3), jnp.asarray(1e-4), ramp, 5400.0, crystallizer, TIGHT)
    seed = float(crystallizer["seed_loading"])
    grown = float(out.crystal_mass) - seed
    moved = ((float(api0) - float(out.api)) * api_mass + float(out.impurity_solid) * impurity_mass
             + float(out.degradant_solid) * degradant_mass)
    assert grown == pytest.approx(moved, rel=1e-12)  # a linear invariant: Runge-Kutta keeps it to round-off
    # At the end the liquor is supersaturated (growth needs it) but within a factor 2 of C*.
    saturated = float(solubility(crystallizer["final_temperature"], crystallizer))
    assert saturated < float(out.api) < 2 * saturated
    ratio = float(solubility(jnp.asarray(300.0), crystallizer) / solubility(jnp.asarray(310.0), crystallizer))
    assert ratio == pytest.approx(np.exp(-float(crystallizer["solubility_enthalpy"]) / 8314.46261815324
                                         * (1 / 300 - 1 / 310)), rel=1e-12)
    assert 0 < float(out.impurity_solid) < 3e-3 and float(out.mean_size()) > float(crystallizer["seed_size"])


def _ops(scene, physical):
    chain = PharmaChain(scene=scene)
    return snapo_ode.count_operations(lambda c: cqa_vector(chain.simulate(chain.inputs(c, physical=physical))),
                                      make_cpps())


@pytest.mark.parametrize("effect", ["crystallization", "drying", "energy_balance", "impurity_incorporation",
                                    "degradation"])
def test_an_effect_left_out_is_absent_from_the_jaxpr(physical, effect):
    full = _ops(PHARMA_EFFECTS.scene(), physical)
    without = PHARMA_EFFECTS.scene(without=[effect, *(("impurity_incorporation",) if effect == "crystallization" else ())])
    assert _ops(without, physical) < full


def _spectral_radii(chain, cpps, physical) -> dict[bool, float]:
    """max |lambda| of each unit's Jacobian [1 / unit duration] along its accepted steps, over
    the stiff (True) and the non-stiff (False) units: each unit's solve is recorded, then
    repeated with every step saved."""
    radii = {True: 0.0, False: 0.0}
    solve = snapo_ode.SolverSettings.solve

    def recording(self, rhs, t0, t1, y0, args=None, *, stiff=True, saveat=None, **kwargs):
        solution = solve(self, rhs, t0, t1, y0, args, stiff=stiff, saveat=diffrax.SaveAt(steps=True), **kwargs)
        finite = np.isfinite(np.asarray(solution.ts))
        ts, ys = jnp.asarray(np.asarray(solution.ts)[finite]), jnp.asarray(np.asarray(solution.ys)[finite])
        jacobians = jax.vmap(jax.jacfwd(lambda s, y: rhs(s, y, args), argnums=1))(ts, ys)  # one per step
        radii[stiff] = max(radii[stiff], float(np.abs(np.linalg.eigvals(np.asarray(jacobians))).max()))
        last = int(solution.stats["num_accepted_steps"]) - 1
        return solution if saveat is not None else eqx.tree_at(lambda s: s.ys, solution, solution.ys[last:last + 1])

    with unittest.mock.patch.object(snapo_ode.SolverSettings, "solve", recording):
        chain.simulate(chain.inputs(cpps, physical=physical))
    return radii


@pytest.mark.parametrize("corner", list(itertools.product(*[r.par for r in CPP_RANGES])))
def test_the_units_given_an_explicit_solver_are_not_stiff_at_any_corner(physical, corner):
    # Why the crystallizer and the dryer default to Tsit5: over a unit (duration 1), an explicit
    # method is stable for h |lambda| <~ 3, so |lambda| <= 50 costs at most ~20 steps, while R1
    # and R2 (|lambda| ~ 1e5) need an L-stable solver.
    radii = _spectral_radii(PharmaChain(), make_cpps(**dict(zip(CPP_NAMES, corner, strict=True))), physical)
    assert radii[False] <= 50.0
    assert radii[True] >= 1e5


def test_side_reactions_off_removes_the_impurity_and_the_stiffness(physical):
    chain = PharmaChain(scene=PHARMA_EFFECTS.scene(without=["side_reactions"]))
    assert len(chain.active_reactions) == 2
    result = chain.simulate(chain.inputs(make_cpps(), physical=physical))
    i, x = chain.species_index("I"), chain.species_index("X")
    assert float(result.outlets["r2"].amounts[i]) == 0.0 and float(result.outlets["r2"].amounts[x]) == 0.0
    assert float(cqa_vector(result)[1]) == 0.0


def test_nominal_chain_meets_the_specs_and_an_extreme_corner_does_not(physical):
    from chemistry.pharma import meets_specs

    chain = PharmaChain()
    nominal = cqa_vector(chain.simulate(chain.inputs(make_cpps(), physical=physical)))
    hot = cqa_vector(chain.simulate(chain.inputs(make_cpps(r1_temperature=323.15, r1_residence_time=40.0,
                                                           dryer_temperature=328.15), physical=physical)))
    assert float(meets_specs(nominal)) == 1.0
    assert float(meets_specs(hot)) == 0.0
    assert float(hot[2]) > float(nominal[2])  # a hotter dryer degrades more


def test_bad_input_names_the_field(tmp_path):
    with pytest.raises(snapo_ode.InputError, match="r1_residence_time"):
        make_cpps(r1_residence_time=-5.0)
    with pytest.raises(snapo_ode.InputError, match="dryer_temperature"):
        make_cpps(dryer_temperature=150.0)
    with pytest.raises(snapo_ode.InputError, match="r1_temperature"):
        make_cpps(r1_temperature=360.0)  # above the solvent's boiling point
    with pytest.raises(snapo_ode.InputError, match="unknown CPP 'r1_pressure'"):
        make_cpps(r1_pressure=2.0)
    with pytest.raises(snapo_ode.InputError, match="unknown physical parameter"):
        default_physical_parameters(jacket_area=1.0)
    with pytest.raises(snapo_ode.InputError, match="rtol"):
        CHAIN_SOLVER.replace(rtol=2.0)
    assert outside_par(make_cpps(cooling_rate=2.0))[0].startswith("cooling_rate = 2")
    assert outside_par(make_cpps()) == []
    text = DEFAULT_MECHANISM.read_text().replace("species: [A, B, P, I, X, D, S]", "species: [A, B, P, I, X, S]")
    lacking = tmp_path / "lacking.yaml"
    lacking.write_text(text.replace("- equation: P => D\n  rate-constant: {A: 5.0e+10, b: 0.0, Ea: 110.0}\n", ""))
    with pytest.raises(snapo_ode.InputError, match="species 'D'"):
        PharmaChain(Mechanism.from_yaml(lacking))


def test_a_failed_solve_raises_with_advice_either_way(physical):
    args = (jnp.asarray(0.3), jnp.asarray(0.99), unit_parameters(physical, "dryer"), CHAIN_SOLVER.replace(max_steps=2))
    # Through call_checked: no callback in the program; the NaN mark is turned into the error on the host.
    with pytest.raises(snapo_ode.SolverFailed, match="max_steps"):
        snapo_ode.call_checked(eqx.filter_jit(Dryer(True).dry), *args, what="the dryer")
    # A plain call afterwards raises inside the program: it does not reuse the checked trace.
    with pytest.raises(Exception, match="max_steps"):
        jax.block_until_ready(Dryer(True).dry(*args))

