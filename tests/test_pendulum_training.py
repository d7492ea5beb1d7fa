"""A short training by backpropagation through whole episodes improves the return on Gymnasium's
own Pendulum-v1 (its dynamics, not ours), and the gradient-decay curriculum runs as documented."""

import jax
import numpy as np
import pytest

from snapo_control.pendulum import Pendulum, TrainingSettings, gymnasium_returns, new_policy, train_policy
from snapo_ode import InputError


def test_a_short_training_improves_the_gymnasium_return():
    settings = TrainingSettings(steps=40, batch=32)
    key = jax.random.key(0)
    policy, result = train_policy(Pendulum(), settings, key, progress=False)
    untrained = new_policy(Pendulum(), settings, jax.random.split(key)[0])  # train_policy's initial weights
    before, after = gymnasium_returns(untrained, 10, 0), gymnasium_returns(policy, 10, 0)
    assert after.mean() > before.mean() + 100, (before.mean(), after.mean())
    assert result.history["value"][-1] > result.history["value"][0]
    assert policy.mlp.layers[0].weight.dtype == np.float64  # trained in float32, handed back in float64
    # The curriculum: held at 0.9 for 30% of the steps, then linear to 0.99 at the last step.
    decays = result.history["gradient_decay"]
    assert decays[0] == decays[11] == pytest.approx(0.9) and decays[-1] == pytest.approx(0.99)
    assert np.all(np.diff(decays) >= -1e-7)


def test_settings_are_checked_before_anything_is_traced():
    with pytest.raises(InputError, match="gradient_decay = 1.5 is outside the allowed range"):
        TrainingSettings(gradient_decay=1.5)
    with pytest.raises(InputError, match="batch = 0"):
        TrainingSettings(batch=0)
