"""Effects: an effect not in the scene is absent from the jaxpr (fewer operations), and with its
parameters neutral the full model equals the model without it."""

import jax
import numpy as np
import pytest

from finance import alm
from snapo_ode import InputError, count_operations

NEUTRAL = dict(
    transaction_costs=dict(transaction_cost=0.0),
    inflation_indexation=dict(indexation=0.0),
    contributions=dict(contribution=0.0),
    funding_floor=dict(floor_penalty=0.0),
    credit=None,  # neutral through the factors: zero spread and spread volatility
)


def _objective(study, smooth=True):
    shocks = alm.scenarios(study, 8, jax.random.key(1))
    policy = alm.NeuralRebalancing(study.market, key=jax.random.key(2))
    fn = alm.objective_of_reported(study.problem, study.fixed, smooth_constraints=smooth)
    return fn, (study.reported, policy, shocks)


@pytest.mark.parametrize("effect", sorted(NEUTRAL))
def test_an_absent_effect_is_absent_from_the_jaxpr_and_neutral_parameters_change_nothing(effect):
    config = alm.ALMConfig(**(NEUTRAL[effect] or {}))
    factors = None
    if effect == "credit":
        base = alm.build_study(40, horizon_months=6)
        factors = {**base.fixed, **base.reported, "spread": 0.0, "spread_vol": 0.0}
    full = alm.build_study(40, horizon_months=6, config=config, factors=factors)
    without = alm.build_study(40, horizon_months=6, config=config, factors=factors, without=[effect])

    def operations(study):
        fn, (reported, policy, shocks) = _objective(study)
        return count_operations(lambda r, s: fn(r, policy, s), reported, shocks)

    assert operations(without) < operations(full)
    for smooth in (True, False):
        fn_full, args_full = _objective(full, smooth)
        fn_without, args_without = _objective(without, smooth)
        np.testing.assert_allclose(float(fn_full(*args_full)), float(fn_without(*args_without)),
                                   rtol=1e-13)


def test_each_effect_matters_at_its_default_parameters():
    # The same holdings in every scene, starting below the funding floor (1.1 -> 0.95), so the floor binds.
    base = alm.build_study(40, horizon_months=6)
    factors = {**base.fixed, **base.reported}
    factors["holdings"] = np.asarray(factors["holdings"]) * 0.95 / 1.1
    full = alm.build_study(40, horizon_months=6, factors=factors)
    fn, args = _objective(full)
    reference = float(fn(*args))
    for effect in NEUTRAL:
        fn_without, args_without = _objective(alm.build_study(40, horizon_months=6, without=[effect], factors=factors))
        assert abs(float(fn_without(*args_without)) - reference) > 1e-6, effect


def test_unknown_effect_names_the_valid_ones():
    with pytest.raises(InputError, match="valid effects: contributions, credit"):
        alm.build_study(40, horizon_months=6, effects=["transaction_cost"])
