"""chemistry.pharma: any process described in a file (`load_process`; two are shipped, the
built-in API chain and an antisolvent route) as Diffrax solves composed of units, its ICH Q8
sensitivities (every CQA to every CPP and to every kinetic and physical parameter), design space,
trained temperature profiles and report, and its kinetics fitted to lab data (`fit`). Public names
load on first use (see `snapo_ode.lazy_exports`)."""

from snapo_ode import lazy_exports

__getattr__, __dir__, __all__ = lazy_exports(__name__, {
    "._balances": ("element_matrix", "mass_balances"),
    "._bench": ("run_pharma_benchmark",),
    "._chain": ("CHAIN_SOLVER", "DEFAULT_MECHANISM", "PHARMA_EFFECTS", "ChainResult", "PharmaChain"),
    "._cqa": ("cqa_dict", "cqa_vector", "meets_specs", "spec_margins", "spec_penalty"),
    "._crystallizer": ("CoolingCrystallizer", "Crystallizer", "CrystallizerOutlet", "EquilibriumIsolation", "Slurry",
                       "SpeciesRoles", "solubility"),
    "._design_space": ("DesignSpace", "DesignSpaceSettings", "default_uncertain", "design_space"),
    "._dryer": ("Dryer", "DryerOutlet"),
    "._edge_uncertainty": ("EdgeMap", "edge_map"),
    "._experiments": ("ErrorModel", "Experiment", "LabData", "Measurements", "read_experiments", "read_lab_data",
                      "read_measurements"),
    "._filter": ("Filter", "FilterStreams"),
    "._fit": ("FitResult", "fit"),
    "._fit_model": ("FittedParameters", "fitted_parameters"),
    "._fit_synthetic": ("lab_design", "simulate_lab_data"),
    "._liquid": ("HoldReactor", "LiquidBatch", "SynthesisReactor", "TEMPERATURE_SCALE"),
    "._next_experiment": ("rank_candidates",),
    "._parameters": ("ChainInputs", "CPPs", "NamedValues", "PhysicalParameters", "arrhenius"),
    "._process": ("default_physical_parameters", "make_cpps", "molar_masses", "outside_par", "physical_parameters"),
    "._process_file": ("BUILT_IN_PROCESS", "CPP_NAMES", "CPP_RANGES", "CQA_NAMES", "CQA_SPECS", "CQA_UNITS", "ProcessSpec",
                       "UnitSpec", "load_process", "process_from_dict", "read_process_file"),
    "._process_units": ("register_unit_type",),
    "._unit_catalogue": ("UNIT_PARAMETERS", "Parameter"),
    "._posterior": ("Posterior", "posterior_draws", "posterior_from_fit", "read_posterior", "write_posterior"),
    "._policy": ("ProfileStudy", "Profiles", "evaluate_hard", "train_profiles"),
    "._profiles": ("AbstractTemperatureProfile", "ConstantTemperature", "LinearRamp", "NeuralTemperature"),
    "._ranges": ("ParameterRange", "Specification"),
    "._report": ("build_report", "pharma_report", "report_provenance", "write_report"),
    "._sensitivities": ("cqa_function", "input_names", "input_scales", "jacobian_function", "named_jacobian",
                        "parameter_names", "rate_names", "shifted_cqas"),
    "._study": ("BUMP_SOLVER", "REFERENCE", "SensitivityStudy", "sensitivities", "sensitivity_study"),
    "._unit": ("AbstractUnit", "Liquid", "Solids"),
    "._verification": ("CanteraCheck", "cantera_check", "cantera_r1", "cantera_reactor", "cantera_reactors",
                       "outlet_differences", "r1_outlet", "r1_trajectory", "scipy_r1", "stiffness_ratio"),
})
