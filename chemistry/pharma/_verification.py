"""Independent checks of the chain: the mechanism's rates and every reactor against Cantera, R1's
stiffness ratio, and R1 against SciPy's Radau at tight tolerance. Used by the tests and the report."""

from typing import NamedTuple

import diffrax
import jax
import numpy as np

from chemistry import compare_rates

from ._chain import PharmaChain
from ._liquid import TEMPERATURE_SCALE, LiquidBatch
from ._parameters import CPPs, PhysicalParameters
from ._profiles import ConstantTemperature
from ._unit_catalogue import UNIT_ROLES


class CanteraCheck(NamedTuple):
    """Rates of progress and net production rates at random liquid states (max relative error),
    and every reactor of the process against Cantera's own (`cantera_reactor`, fed with the
    stream the chain gives it): `reactors`, reactor name -> (max relative difference of the
    outlet amounts, of T); `r1_amounts` and `r1_temperature` are the first reactor's."""

    rates_of_progress: float
    net_production: float
    r1_amounts: float
    r1_temperature: float
    reactors: dict


def _r1(chain: PharmaChain, cpps: CPPs, physical: PhysicalParameters):
    """The inputs, the active ones and the first reactor's parameters."""
    inputs = chain.inputs(cpps, physical=physical)
    _, active = chain.active(inputs)
    return inputs, active, chain.unit_parameters(inputs)[chain.process.units[0].name]


def stiffness_ratio(chain: PharmaChain, cpps: CPPs, physical: PhysicalParameters, state=None) -> float:
    """max |Re lambda| / min |Re lambda| over the non-zero eigenvalues of R1's species Jacobian
    d(dy/dt)/dy [1/s] at its feed (or at `state`, amounts [kmol/m^3]) and the R1 temperature.
    Eigenvalues below 1e-13 of the largest are the conserved quantities' zeros (solvent,
    element balances) up to round-off."""
    inputs, active, r1 = _r1(chain, cpps, physical)
    batch = LiquidBatch(chain.active(inputs)[0], False)
    start = chain.feed(inputs).amounts if state is None else state
    jacobian = jax.jacfwd(lambda y: batch.production(r1["temperature"], y, active.rates))(start)
    magnitudes = np.abs(np.linalg.eigvals(np.asarray(jacobian)).real)
    nonzero = magnitudes[magnitudes > 1e-13 * magnitudes.max()]
    return float(nonzero.max() / nonzero.min())


def r1_trajectory(chain: PharmaChain, cpps: CPPs, physical: PhysicalParameters):
    """R1's accepted steps: (times [s], amounts [kmol/m^3] shape (n, n_species), T [K] shape (n,))."""
    inputs, active, r1 = _r1(chain, cpps, physical)
    solution = chain.r1(inputs)(chain.feed(inputs), r1, active.rates, chain.solver, saveat=diffrax.SaveAt(steps=True))
    finite = np.isfinite(np.asarray(solution.ts))
    ys = np.asarray(solution.ys)[finite]
    n_species = chain.mechanism.n_species
    temperature = ys[:, n_species] * TEMPERATURE_SCALE if ys.shape[1] > n_species else np.full(len(ys), float(r1["temperature"]))
    return 60.0 * float(r1["residence_time"]) * np.asarray(solution.ts)[finite], ys[:, :n_species], temperature


def r1_outlet(chain: PharmaChain, cpps: CPPs, physical: PhysicalParameters):
    """R1's outlet `Liquid` at `cpps` (amounts [kmol per m^3 of feed volume], T [K])."""
    inputs, active, r1 = _r1(chain, cpps, physical)
    return chain.r1(inputs)(chain.feed(inputs), r1, active.rates, chain.solver)


def cantera_reactor(chain: PharmaChain, inputs, name: str, *, rtol=1e-11, result=None):
    """The reactor `name` of `chain`'s process integrated by Cantera's own reactor from the same
    inlet (the feed, or the outlet of the unit before it in `result`, `chain.simulate(inputs)`
    unless given): (amounts per m^3 of the first feed's volume, T [K]) at its outlet. A plug-flow
    reactor is a `ConstPressureReactor` of the inlet's volume V_in for its residence time, the
    liquid entering at the inlet's temperature, with a wall of area V_in (U = `jacket_ua`) to a
    reservoir at the jacket temperature (energy on with the energy balance, else isothermal at
    the jacket's), a batch reactor one at its temperature for its time, a CSTR one fed and
    emptied by two mass-flow controllers at rho V / tau, run for 60 residence times (its
    transients decay at least as e^-t/tau: Cantera's `advance_to_steady_state` stopped short of a
    residual of 1e-14)."""
    import cantera

    names = [unit.name for unit in chain.process.units]
    kind = chain.process.units[names.index(name)].type
    position = names.index(name)
    if position == 0:
        inlet = chain.feed(inputs)
    else:
        inlet = (chain.simulate(inputs) if result is None else result).outlets[names[position - 1]]
    amounts, parameters = np.asarray(inlet.amounts), chain.unit_parameters(inputs)[name]
    volume, temperature = float(amounts @ np.asarray(chain.mechanism.molar_volumes)), float(parameters["temperature"])
    process = chain.process

    def solution(at=temperature):
        liquid = cantera.Solution(process.mechanism, process.phase or "")
        liquid.TPX = at, cantera.one_atm, amounts / amounts.sum()
        return liquid

    # clone=False: in Cantera 3.2 a cloned ideal-condensed phase does not keep the state it was
    # given (its density and composition change), so each reactor gets its own Solution.
    energy = "on" if kind == "plug_flow_reactor" and chain.scene.has("energy_balance") else "off"
    # With the energy balance the liquid enters at the inlet's temperature (the upstream outlet's)
    # and the jacket heats or cools it; without, the reactor is isothermal at its own.
    reactor = cantera.ConstPressureReactor(solution(float(inlet.temperature) if energy == "on" else temperature),
                                           energy=energy, clone=False)
    reactor.volume = volume
    if kind == "plug_flow_reactor":
        cantera.Wall(cantera.Reservoir(solution(), clone=False), reactor, A=volume, U=float(parameters["jacket_ua"]))
    if kind == "cstr":
        flow = reactor.phase.density * volume / (60.0 * float(parameters["residence_time"]))
        cantera.MassFlowController(cantera.Reservoir(solution(), clone=False), reactor, mdot=flow)
        cantera.MassFlowController(reactor, cantera.Reservoir(solution(), clone=False), mdot=flow)
    network = cantera.ReactorNet([reactor])
    network.rtol, network.atol = rtol, 1e-20
    if kind == "cstr":
        network.advance(60.0 * 60.0 * float(parameters["residence_time"]))  # 60 residence times: transients e^-60
    else:
        network.advance(60.0 * float(parameters["residence_time"]) if kind == "plug_flow_reactor"
                        else float(parameters["time"]))
    return reactor.phase.concentrations * reactor.volume, reactor.phase.T


def outlet_differences(outlet, amounts, temperature) -> tuple[float, float]:
    """(largest relative difference of `outlet`'s amounts from Cantera's `amounts`, over those
    above 1e-12 of the largest; relative difference of the temperatures): how a reactor is held
    against Cantera's own (`cantera_reactor`)."""
    ours = np.asarray(outlet.amounts)
    significant = amounts > 1e-12 * amounts.max()
    return (float(np.max(np.abs(ours - amounts)[significant] / amounts[significant])),
            float(abs(float(outlet.temperature) - temperature) / temperature))


def cantera_r1(chain: PharmaChain, cpps: CPPs, physical: PhysicalParameters, path=None, *, rtol=1e-11):
    """The first reactor integrated by Cantera (`cantera_reactor`): (amounts per m^3 of feed
    volume, T [K]) at the outlet."""
    return cantera_reactor(chain, chain.inputs(cpps, physical=physical), chain.process.units[0].name, rtol=rtol)


def cantera_reactors(chain: PharmaChain, inputs, *, rtol=1e-11) -> dict[str, tuple[float, float]]:
    """Every reactor of `chain`'s process against Cantera's own, fed with the stream the chain
    computes for it: reactor name -> (`outlet_differences`), in the process's order."""
    result = chain.simulate(inputs)
    return {unit.name: outlet_differences(result.outlets[unit.name],
                                          *cantera_reactor(chain, inputs, unit.name, rtol=rtol, result=result))
            for unit in chain.process.units if UNIT_ROLES[unit.type] == "reactor"}


def cantera_check(chain: PharmaChain, cpps: CPPs, physical: PhysicalParameters, path, *, n_states: int = 100) -> CanteraCheck:
    """The mechanism and every reactor against Cantera (`chain` should use tight tolerances)."""
    rates = compare_rates(chain.mechanism, path, n_states=n_states, temperature=(270.0, 360.0))
    reactors = cantera_reactors(chain, chain.inputs(cpps, physical=physical))
    return CanteraCheck(rates.rates_of_progress, rates.net_production, *next(iter(reactors.values())), reactors)


def scipy_r1(chain: PharmaChain, cpps: CPPs, physical: PhysicalParameters, *, rtol: float = 1e-12,
             atol: float = 1e-16):
    """R1 integrated by SciPy's Radau (an independent implicit Runge-Kutta code) at tight
    tolerances, on the same right-hand side and its exact Jacobian: the outlet state (amounts
    [kmol/m^3], then T / 300 K with the energy balance)."""
    from scipy.integrate import solve_ivp

    inputs, active, r1 = _r1(chain, cpps, physical)
    unit = LiquidBatch(chain.active(inputs)[0], chain.scene.has("energy_balance"))
    feed = chain.feed(inputs)
    start = unit.start(feed)
    args = unit.arguments(feed, ConstantTemperature(r1["temperature"]), 60.0 * r1["residence_time"], active.rates,
                          r1["jacket_ua"])
    rhs = jax.jit(lambda s, y: unit.rhs(s, y, args))
    jac = jax.jit(jax.jacfwd(lambda s, y: unit.rhs(s, y, args), argnums=1))
    solution = solve_ivp(lambda s, y: np.asarray(rhs(s, y)), (0.0, 1.0), np.asarray(start), method="Radau",
                         rtol=rtol, atol=atol, jac=lambda s, y: np.asarray(jac(s, y)))
    return solution.y[:, -1]
