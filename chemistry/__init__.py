"""Chemistry on snapo_ode: Cantera-YAML kinetics in JAX, stiff reactors in Diffrax, the pharma chain.

Public names load on first use (see `snapo_ode.lazy_exports`)."""

from pathlib import Path

from snapo_ode import lazy_exports

MECHANISMS = Path(__file__).parent / "mechanisms"
"""The directory of the mechanisms that ship with this package [`reaction_types.yaml`, `pharma.yaml`]."""

__getattr__, __dir__, __all__ = lazy_exports(__name__, {
    "._batch": ("IgnitionBatch", "IgnitionBatchResult", "final_temperature_batch", "mole_ratios",
                "solve_ignition_batch", "temperature_sensitivities_batch"),
    "._check": ("KineticsCheck", "check_against_cantera", "default_case"),
    "._crosscheck": ("RateComparison", "compare_rates"),
    "._ignition": ("IGNITION_CASES", "IgnitionCase", "IgnitionResult", "cantera_ignition", "ignition_delay",
                   "initial_concentrations", "solve_ignition"),
    "._mechanism": ("Mechanism",),
    "._rate_laws": ("RateParameters",),
    "._reactor": ("REACTOR_EFFECTS", "REACTOR_BDF_SOLVER", "REACTOR_SOLVER", "Reactor", "Trajectory", "simulate"),
    "._sensitivities": ("SensitivityComparison", "cantera_sensitivities", "compare_sensitivities",
                        "final_temperature", "temperature_at", "temperature_sensitivities"),
    "._thermo": ("SpeciesThermo",),
    "._units": ("GAS_CONSTANT", "ONE_ATM"),
    "snapo_ode": ("SolverSettings",),
}, submodules=("pharma",))
__all__.append("MECHANISMS")
