"""The rebalancing policy: weights inside their bounds and on the simplex with exact gradients,
and a trained policy that beats the fixed mixes on fresh (out-of-sample) paths."""

import jax
import jax.numpy as jnp
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from finance import alm
from snapo_ode import InputError

LOW = np.array([0.0, 0.05, 0.1, 0.0, 0.0, 0.1])
HIGH = np.array([0.3, 0.6, 0.9, 0.5, 0.3, 0.7])


@settings(max_examples=30, deadline=None)
@given(st.lists(st.floats(-30, 30), min_size=6, max_size=6))
def test_bounded_weights_sum_to_one_inside_the_bounds(logits):
    weights = np.asarray(alm.bounded_weights(jnp.array([logits]), LOW, HIGH))[0]
    assert weights.sum() == pytest.approx(1.0, abs=1e-12)
    assert np.all(weights >= LOW - 1e-15) and np.all(weights <= HIGH + 1e-15)


def test_bounded_weights_gradient_matches_central_differences():
    logits = jnp.array([0.3, -1.2, 2.0, 0.1, -0.4, 0.9])
    direction = jnp.array([1.0, -0.5, 0.3, 0.0, 2.0, -1.0])

    def f(z):
        return jnp.sum(alm.bounded_weights(z[None], LOW, HIGH)[0] * jnp.arange(1.0, 7.0))

    h = 1e-6
    reference = (f(logits + h * direction) - f(logits - h * direction)) / (2 * h)
    assert float(jnp.dot(jax.grad(f)(logits), direction)) == pytest.approx(float(reference), rel=1e-7)


def test_fixed_mix_must_sum_to_one():
    with pytest.raises(InputError, match="sum to 1"):
        alm.FixedMix([0.5, 0.5, 0.5, 0, 0, 0])


def test_trained_policy_beats_the_fixed_mixes_out_of_sample():
    study = alm.build_study(20, horizon_months=24)
    policy, result = alm.train_policy(study, steps=40, n_paths=128, key=jax.random.key(7),
                                      progress=False)
    assert result.history["value"][-1] > result.history["value"][0]
    fresh = alm.scenarios(study, 1024, jax.random.key(12345))
    trained = alm.evaluate(study, policy, fresh)
    for name, mix in alm.baselines(study).items():
        assert trained.objective > alm.evaluate(study, mix, fresh).objective, name
    # Smooth for training, hard for reporting: the gap is reported and small.
    assert abs(trained.smoothing_gap) < 0.01
