"""Chemistry on snapo_ode: Cantera-YAML kinetics in JAX, stiff reactors in Diffrax, the pharma chain."""

from pathlib import Path

from ._crosscheck import RateComparison as RateComparison, compare_rates as compare_rates
from ._mechanism import Mechanism as Mechanism, RateParameters as RateParameters
from ._ignition import (
    IGNITION_CASES as IGNITION_CASES,
    IgnitionCase as IgnitionCase,
    IgnitionResult as IgnitionResult,
    cantera_ignition as cantera_ignition,
    ignition_delay as ignition_delay,
    initial_concentrations as initial_concentrations,
    solve_ignition as solve_ignition,
)
from ._reactor import (
    REACTOR_EFFECTS as REACTOR_EFFECTS,
    Reactor as Reactor,
    SolverSettings as SolverSettings,
    Trajectory as Trajectory,
    simulate as simulate,
)
from ._sensitivities import (
    SensitivityComparison as SensitivityComparison,
    cantera_sensitivities as cantera_sensitivities,
    compare_sensitivities as compare_sensitivities,
    final_temperature as final_temperature,
    temperature_sensitivities as temperature_sensitivities,
)
from ._thermo import SpeciesThermo as SpeciesThermo
from ._units import GAS_CONSTANT as GAS_CONSTANT, ONE_ATM as ONE_ATM

MECHANISMS = Path(__file__).parent / "mechanisms"
"""The directory of the mechanisms that ship with this package [`reaction_types.yaml`, `pharma.yaml`]."""
