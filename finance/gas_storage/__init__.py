"""Natural-gas storage: the intrinsic LP, a neural inject/withdraw policy trained with smooth
constraints, all forward-curve deltas from one reverse pass, and the least-squares Monte Carlo
baseline. Public names load on first use (see `snapo_ode.lazy_exports`)."""

from snapo_ode import lazy_exports

__getattr__, __dir__, __all__ = lazy_exports(__name__, {
    "._action_heads": ("make_action_policy", "simulate_path"),
    "._basestock": ("BasestockPolicy", "basestock_targets", "inventory_ceiling", "make_basestock_policy"),
    "._bench": ("run_gas_benchmark",),
    "._bench_lsmc": ("run_lsmc_benchmark",),
    "._cases": ("BDJ_MEAN_REVERSION", "BDJ_PUBLISHED", "BDJ_VOLATILITY", "CASES", "boogert_de_jong"),
    "._certificate": ("duality_gaps", "intrinsic_schedule"),
    "._dual": ("DualBound", "RelaxedGrid", "dual_bound", "relaxed_grid", "schedule_penalty"),
    "._files": ("FacilityFile", "load_curve", "load_facility", "sample_curve", "sample_facility"),
    "._inputs": ("FACILITY_FIELDS", "MAX_PRICE", "MAX_QUANTITY", "StorageInputs", "make_inputs"),
    "._lattice": ("FactorLattice", "LatticePenalty", "run_lattice_policy", "solve_factor_lattice"),
    "._lp": ("IntrinsicSolution", "solve_intrinsic"),
    "._lsmc": ("InventoryGrid", "LSMCFit", "candidate_inventories", "fit_lsmc", "inventory_grid", "perfect_foresight",
               "run_lsmc_policy", "value_lsmc"),
    "._lsmc_deltas": ("lsmc_bumped_deltas", "lsmc_valuation", "lsmc_value_and_deltas"),
    "._model": ("GAS_EFFECTS", "FactorTransition", "Schedule", "deterministic_scene", "factor_transition",
                "feasible_flows", "flows_and_cash", "inventory_floor", "spot_factor", "spot_prices", "stochastic_scene"),
    "._model_study": ("value_on_model",),
    "._path_files": ("load_paths", "save_paths"),
    "._paths": ("PricePaths",),
    "._price_model_file": ("load_price_model", "sample_price_model"),
    "._price_models": ("PRICE_MODELS", "AbstractPriceModel", "OneFactorModel", "ThreeFactorSeasonalModel",
                       "TwoFactorModel", "model_paths"),
    "._rolling_intrinsic": ("rolling_intrinsic",),
    "._state_lsmc": ("StateBasis", "StateLSMCFit", "fit_state_lsmc", "run_state_lsmc", "state_lsmc_value_and_deltas"),
    "._state_penalty": ("StatePenalty", "fit_state_penalty", "fit_state_lsmc_and_penalty"),
    "._state_policy": ("StatePolicy", "make_state_policy", "simulate_state_policy"),
    "._penalty": ("AbstractInnovationBasis", "AbstractPenalty", "RegressionPenalty", "ShockHermite", "SpotCalls",
                  "SpotPowers", "fit_penalty"),
    "._policy": ("DEFAULT_HEAD", "POLICY_HEADS", "expected_value", "load_storage_policy", "make_policy", "simulate",
                 "storage_policy_bytes"),
    "._report": ("build_gas_report", "gas_report"),
    "._results": ("LSMCComparison", "StorageStudy", "standard_error"),
    "._study": ("HEAD_TRAINING", "StudySettings", "constraint_violation", "evaluation_shocks", "run_study"),
    "._versus_lsmc": ("LSMC_KEY", "compare_with_lsmc", "lsmc_fit_shocks"),
})
