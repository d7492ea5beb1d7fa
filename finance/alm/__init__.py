"""Pension-fund asset-liability management (ALM) with a neural rebalancing policy, and the
sensitivities of its objective to every risk factor from one reverse pass.

Layers: `_market` (curve, drivers, correlation) -> `_liabilities`, `_assets` -> `_factors` (the
named risk factors) -> `_policy` -> `_model` (effects, monthly simulation, objective) ->
`_sensitivities` (adjoint, bump-and-revalue, forward mode) -> `_study` (training, baselines,
reports). See docs/alm.md.
"""

from ._assets import MarketState as MarketState, gross_returns as gross_returns
from ._factors import (
    GROUPS as GROUPS,
    FactorLayout as FactorLayout,
    check_factors as check_factors,
    default_factors as default_factors,
    factor_names as factor_names,
    layout_for as layout_for,
    named_sensitivities as named_sensitivities,
    split_reported as split_reported,
)
from ._liabilities import (
    default_liability_cash_flows as default_liability_cash_flows,
    key_rate_profile as key_rate_profile,
    liability_value as liability_value,
)
from ._market import (
    ASSETS as ASSETS,
    Market as Market,
    check_correlation as check_correlation,
    correlated_shocks as correlated_shocks,
    default_correlation as default_correlation,
    driver_names as driver_names,
    interpolation_weights as interpolation_weights,
    key_tenors as key_tenors,
)
from ._model import (
    EFFECTS as EFFECTS,
    ALMConfig as ALMConfig,
    ALMProblem as ALMProblem,
    Outcome as Outcome,
    objective as objective,
    simulate as simulate,
)
from ._policy import (
    FEATURES as FEATURES,
    AbstractRebalancing as AbstractRebalancing,
    FixedMix as FixedMix,
    NeuralRebalancing as NeuralRebalancing,
    bounded_weights as bounded_weights,
    liability_matching as liability_matching,
    sixty_forty as sixty_forty,
)
from ._sensitivities import (
    adjoint as adjoint,
    bump as bump,
    forward as forward,
    objective_of_reported as objective_of_reported,
    time_compiled as time_compiled,
)
from ._study import (
    Study as Study,
    baselines as baselines,
    build_study as build_study,
    evaluate as evaluate,
    liability_duration as liability_duration,
    measure_sensitivities as measure_sensitivities,
    run_alm as run_alm,
    scenarios as scenarios,
    train_policy as train_policy,
)
from ._bench import format_table as format_table, scaling_rows as scaling_rows, write_scaling as write_scaling
