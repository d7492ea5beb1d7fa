"""Effects and scenes; policy initialisation and serialisation; input validation messages."""

import jax
import jax.numpy as jnp
import numpy as np
import pytest

import snapo_ode

CATALOGUE = snapo_ode.EffectCatalogue(
    "toy",
    {"decay": "first-order loss", "forcing": "periodic input", "cap": "saturating cap", "floor": "floor"},
    conflicts=(("cap", "floor"),),
    requires={"forcing": ("decay",)},
)


def toy_model(x, rate, scene):
    y = x
    if scene.has("decay"):
        y = y * jnp.exp(-rate)
    if scene.has("forcing"):
        y = y + jnp.sin(x)
    if scene.has("cap"):
        y = snapo_ode.smooth.minimum(y, 10.0, 50.0)
    return y


def test_absent_effect_is_not_traced_and_neutral_parameters_match():
    full = CATALOGUE.scene(["decay", "forcing"])
    reduced = CATALOGUE.scene(["forcing", "decay"], without=["forcing"])
    ops_full = snapo_ode.count_operations(lambda x: toy_model(x, 0.0, full), 1.0)
    ops_reduced = snapo_ode.count_operations(lambda x: toy_model(x, 0.0, reduced), 1.0)
    assert ops_reduced < ops_full
    # With the decay rate neutral (0) a scene without decay gives the same result.
    no_decay = CATALOGUE.scene([])
    assert float(toy_model(2.0, 0.0, no_decay)) == float(toy_model(2.0, 0.0, CATALOGUE.scene(["decay"])))


def test_unknown_conflicting_and_missing_effects_raise_listing_valid_ones():
    with pytest.raises(snapo_ode.InputError, match="valid effects: cap, decay, floor, forcing"):
        CATALOGUE.scene(["decay", "decy"])
    with pytest.raises(snapo_ode.InputError, match="cannot be active together"):
        CATALOGUE.scene(["cap", "floor"])
    with pytest.raises(snapo_ode.InputError, match="needs 'decay'"):
        CATALOGUE.scene(["forcing"])
    with pytest.raises(snapo_ode.InputError, match="not defined"):
        CATALOGUE.scene(["decay"]).has("decy")


def test_policy_deterministic_bounded_and_round_trips(tmp_path):
    make = lambda: snapo_ode.MLPPolicy(3, 2, key=jax.random.key(1), action_low=[-1, 0], action_high=[1, 5],  # noqa: E731
                                       feature_offset=[0, 1, 2], feature_scale=[1, 2, 3], output_gain=5.0)
    a, b = make(), make()
    features = jnp.array([[100.0, -100.0, 3.0], [0.0, 0.0, 0.0]])
    np.testing.assert_array_equal(jax.vmap(a)(features), jax.vmap(b)(features))
    actions = jax.vmap(a)(features)
    assert bool(jnp.all(actions >= jnp.array([-1, 0]))) and bool(jnp.all(actions <= jnp.array([1, 5])))
    snapo_ode.save_policy(tmp_path / "policy.eqx", a)
    restored = snapo_ode.load_policy(tmp_path / "policy.eqx")
    np.testing.assert_array_equal(jax.vmap(restored)(features), actions)
    other = snapo_ode.MLPPolicy(3, 2, key=jax.random.key(2))
    assert not np.allclose(other(features[0]), snapo_ode.MLPPolicy(3, 2, key=jax.random.key(1))(features[0]))


def test_validation_messages_name_field_value_and_range():
    with pytest.raises(snapo_ode.InputError, match=r"capacity = -1.0 is outside the allowed range \(0, inf\]"):
        snapo_ode.check_range("capacity", -1.0, 0.0, low_open=True)
    with pytest.raises(snapo_ode.InputError, match=r"price\[2\] = nan is not a finite number"):
        snapo_ode.check_finite("price", [1.0, 2.0, float("nan")])
    with pytest.raises(snapo_ode.InputError, match="entry 2"):
        snapo_ode.check_increasing("fill", [0.0, 0.5, 0.5])
    with pytest.raises(snapo_ode.InputError, match="action_low and action_high"):
        snapo_ode.MLPPolicy(1, 1, key=jax.random.key(0), action_low=0.0)
