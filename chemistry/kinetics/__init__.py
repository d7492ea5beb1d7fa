"""Kinetics and reactors: Cantera-YAML mechanisms read into JAX (every Cantera gas rate type), rates
checked against Cantera, ideal-gas reactors and ignition as stiff ODEs in Diffrax, their adjoint
sensitivities, batches over conditions, and the kinetics benches and CLI verbs.

Public names load on first use (see `snapo_ode.lazy_exports`); `chemistry` re-exports them."""

from snapo_ode import lazy_exports

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
})
