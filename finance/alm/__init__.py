"""Pension-fund asset-liability management (ALM) with a neural rebalancing policy, and the
sensitivities of its objective to every risk factor from one reverse pass.

Layers: `_market` (curve, drivers, correlation) -> `_liabilities`, `_assets` -> `_market_step`
(the market a month on) -> `_factors` (the named risk factors) -> `_policy` -> `_model`
(effects, monthly simulation, objective) -> `_board` (the board's figures) ->
`_units`, `_liability_file`, `_fund_schema`, `_fund_file` (a fund in files), `_memory`, `_scenario_file`, `_scenarios`
(scenario sets from outside) -> `_sensitivities` (the objective of the reported factors, how the
baselines batch), `_baselines` (the fixed mixes compared) -> `_study` (training, baselines, typed results) -> `_bench`, `_cli`. See
docs/alm.md. Public names load on first use (see `snapo_ode.lazy_exports`).
"""

from snapo_ode import lazy_exports

__getattr__, __dir__, __all__ = lazy_exports(__name__, {
    "._assets": ("MarketState", "gross_returns"),
    "._bench": ("format_table", "scaling_rows", "write_scaling"),
    "._board": ("BoardSettings", "balance_sheet_figures", "board_figures", "path_figures"),
    "._factors": ("DEFAULT_MIX", "GROUPS", "FactorLayout", "check_factors", "default_factors", "factor_names",
                  "holdings_at_funding_ratio", "layout_for", "named_sensitivities", "split_reported"),
    "._fund_file": ("Fund", "fund_holdings", "load_fund", "sample_fund_path"),
    "._fund_schema": ("FundFile",),
    "._scenario_file": ("ScenarioSet", "load_scenarios", "variable_names", "write_scenarios"),
    "._scenarios": ("generated_scenarios", "scenario_start"),
    "._liabilities": ("LiabilitySchedule", "bucket_schedule", "cash_flow_maturities", "default_liability_cash_flows",
                      "key_rate_profile", "liability_duration_as_valued", "liability_value", "liability_value_at_dates",
                      "monthly_cash_flows", "outstanding_cash_flows", "row_schedule", "starting_liability_value"),
    "._liability_file": ("Liabilities", "load_liabilities"),
    "._market": ("ASSETS", "Market", "check_correlation", "correlated_shocks", "default_correlation", "driver_names",
                 "interpolation_segments", "interpolation_weights", "key_tenors"),
    "._market_step": ("next_market", "scenario_state"),
    "._model": ("EFFECTS", "ALMConfig", "ALMProblem", "Outcome", "Trajectory", "indexed_share", "initial_funding_ratio",
                "initial_values", "limited_weights", "objective", "simulate"),
    "._policy": ("FEATURES", "AbstractRebalancing", "FixedMix", "NeuralRebalancing", "bounded_weights",
                 "liability_matching", "sixty_forty"),
    "._sensitivities": ("BUMP_RELATIVE_STEP", "chunk_size", "objective_of_reported"),
    "._report": ("alm_report", "build_alm_report"),
    "._results": ("ALMStudy", "Evaluation", "SensitivityMeasurement"),
    "._baselines": ("baselines", "liability_duration"),
    "._study": ("Study", "build_fund_study", "build_study", "compared_baselines", "evaluate", "measure_sensitivities", "run_alm", "scenarios", "study_for", "train_policy"),
})
