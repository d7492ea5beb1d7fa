"""Net production rates against Cantera, gradients against central differences, and the errors
that unsupported input gets."""

import re
from pathlib import Path

import cantera
import jax
import jax.numpy as jnp
import numpy as np
import pytest

import snapo_ode
from chemistry import MECHANISMS, Mechanism, compare_rates

CANTERA_DATA = Path(cantera.__file__).parent / "data"
MECHANISM_PATHS = {
    "h2o2": CANTERA_DATA / "h2o2.yaml",
    "gri30": CANTERA_DATA / "gri30.yaml",
    "reaction_types": MECHANISMS / "reaction_types.yaml",
}


@pytest.fixture(scope="module")
def mechanisms():
    return {name: Mechanism.from_yaml(path) for name, path in MECHANISM_PATHS.items()}


@pytest.mark.parametrize("name", sorted(MECHANISM_PATHS))
def test_rates_match_cantera_at_random_states(mechanisms, name):
    comparison = compare_rates(mechanisms[name], MECHANISM_PATHS[name], n_states=120, seed=1)
    assert comparison.rates_of_progress <= 1e-12
    assert comparison.net_production <= 1e-10
    assert comparison.n_compared >= 120


def test_reaction_types_mechanism_has_every_supported_type(mechanisms):
    gas = cantera.Solution(str(MECHANISM_PATHS["reaction_types"]))
    kinds = {reaction.reaction_type for reaction in gas.reactions()}
    assert kinds == {"Arrhenius", "three-body-Arrhenius", "falloff-Lindemann", "falloff-Troe", "falloff-SRI",
                     "falloff-Tsang", "chemically-activated-Troe", "chemically-activated-Lindemann", "Blowers-Masel",
                     "pressure-dependent-Arrhenius", "Chebyshev"}
    mechanism = mechanisms["reaction_types"]
    assert float(mechanism.pre_exponential.min()) < 0  # the negative-A duplicate
    assert not bool(mechanism.thermo.is_nasa.all())  # constant-cp species
    assert mechanism.n_reactions - mechanism.reversible_index.size == 5  # irreversible ones


def _state(mechanism, seed):
    rng = np.random.default_rng(seed)
    fractions = rng.random(mechanism.n_species)
    fractions[1] = 0.0  # a zero concentration: its gradient must be exact, not NaN
    return 1400.0, jnp.asarray(fractions / fractions.sum() * 101325.0 / (8314.46261815324 * 1400.0))


@pytest.mark.parametrize("name", ["h2o2", "reaction_types"])
def test_gradient_wrt_rate_parameters_matches_central_differences(mechanisms, name):
    mechanism = mechanisms[name]
    temperature, concentrations = _state(mechanism, 2)
    weights = jnp.asarray(np.random.default_rng(3).normal(size=mechanism.n_species))

    def objective(parameters):
        return weights @ mechanism.net_production_rates(temperature, concentrations, parameters)

    _, adjoint = snapo_ode.value_and_sensitivities(objective, mechanism.parameters)
    bumped = snapo_ode.bump_and_revalue(objective, mechanism.parameters)
    # Central differences carry round-off of order eps |f| / h (about 3e-6 here, for |f| ~ 1e5):
    # entries below a hundredth of the largest are compared at that scale.
    for leaf_a, leaf_b in zip(jax.tree.leaves(adjoint), jax.tree.leaves(bumped)):
        assert snapo_ode.max_relative_difference(leaf_a, leaf_b, floor=1e-2) < 2e-5


def test_gradient_wrt_state_is_exact_at_zero_concentration(mechanisms):
    mechanism = mechanisms["h2o2"]
    temperature, concentrations = _state(mechanism, 4)

    def objective(inputs):
        return jnp.sum(mechanism.net_production_rates(inputs["T"], inputs["C"]) ** 2)

    inputs = {"T": jnp.asarray(temperature), "C": concentrations}
    _, adjoint = snapo_ode.value_and_sensitivities(objective, inputs)
    assert np.all(np.isfinite(adjoint["C"]))
    # Integer orders make the rates polynomial in C: a central step across zero is exact.
    bumped = snapo_ode.bump_and_revalue(objective, inputs, relative_step=1e-6)
    assert snapo_ode.max_relative_difference(adjoint["C"], bumped["C"], floor=1e-6) < 1e-5
    assert snapo_ode.max_relative_difference(adjoint["T"], bumped["T"]) < 1e-6


# reaction_types holds every reaction type gri30 has: gri30 (~55 s on CI) under `make test-slow`.
@pytest.mark.parametrize("name", ["h2o2", pytest.param("gri30", marks=pytest.mark.slow), "reaction_types", "pharma"])
def test_concentration_jacobian_matches_autodiff_and_central_differences(mechanisms, name):
    # The closed form (behind every concentration tangent of net_production_rates) against
    # forward-mode autodiff of the rate law itself, and against central differences; then the
    # derivative of that Jacobian (what a reverse pass through a Rosenbrock step needs).
    from chemistry.pharma import DEFAULT_MECHANISM

    mechanism = Mechanism.from_yaml(DEFAULT_MECHANISM) if name == "pharma" else mechanisms[name]
    temperature, concentrations = _state(mechanism, 5)
    # No zero concentration: a fractional order (reaction_types has one) is singular there.
    concentrations = jnp.maximum(concentrations, 1e-2 * concentrations.max())
    if name == "pharma":  # a liquid: mole fractions from concentrations, at a liquid temperature
        temperature = 320.0
    closed = np.asarray(mechanism.concentration_jacobian(temperature, concentrations))
    through_rates = np.asarray(jax.jacfwd(lambda c: mechanism.net_production_rates(temperature, c))(concentrations))
    autodiff = np.asarray(jax.jacfwd(lambda c: mechanism._net_production(temperature, c, mechanism.parameters))(
        concentrations))
    scale = np.abs(autodiff).max()
    assert np.abs(closed - autodiff).max() <= 1e-12 * scale
    assert np.abs(through_rates - autodiff).max() <= 1e-12 * scale
    rates = jax.jit(lambda c: mechanism.net_production_rates(temperature, c))
    steps = 1e-6 * np.maximum(np.asarray(concentrations), 1e-3 * float(concentrations.max()))
    bumped = np.stack([(rates(concentrations.at[i].add(h)) - rates(concentrations.at[i].add(-h))) / (2 * h)
                       for i, h in enumerate(steps)], axis=1)
    assert np.abs(bumped - closed).max() <= 1e-6 * scale

    def roughness(t, c, rates):
        return jnp.sum(jnp.tanh(jax.jacfwd(lambda c: rates(t, c))(c) / scale))

    ours = jax.grad(roughness, argnums=(0, 1))(temperature, concentrations, mechanism.net_production_rates)
    plain = jax.grad(roughness, argnums=(0, 1))(
        temperature, concentrations, lambda t, c: mechanism._net_production(t, c, mechanism.parameters))
    for a, b in zip(ours, plain, strict=True):
        assert snapo_ode.max_relative_difference(a, b) <= 1e-10


_UNSUPPORTED = {
    "linear-Burke": """
  type: linear-Burke
  colliders:
  - name: M
    type: falloff
    low-P-rate-constant: {A: 1.0e+18, b: -1.0, Ea: 0.0}
    high-P-rate-constant: {A: 1.0e+13, b: 0.0, Ea: 0.0}""",
    "two-temperature-plasma": """
  type: two-temperature-plasma
  rate-constant: {A: 1.0e+13, b: 0.0, Ea-gas: 0.0, Ea-electron: 0.0}""",
}


@pytest.mark.parametrize("kind", sorted(_UNSUPPORTED))
def test_unsupported_reaction_type_is_named_with_its_index_and_line(tmp_path, kind):
    text = MECHANISM_PATHS["reaction_types"].read_text()
    equation = "A + B (+M) <=> C (+M)"
    text += f"- equation: {equation}{_UNSUPPORTED[kind]}\n"
    path = tmp_path / "bad.yaml"
    path.write_text(text)
    line = text.count("\n", 0, text.index(f"- equation: {equation}\n")) + 1
    n_reactions = cantera.Solution(str(MECHANISM_PATHS["reaction_types"])).n_reactions
    with pytest.raises(snapo_ode.InputError, match=rf"bad.yaml:{line}: reaction {n_reactions} .*{re.escape(kind)}"):
        Mechanism.from_yaml(path)


def test_unknown_phase_and_missing_file_are_named(tmp_path):
    with pytest.raises(snapo_ode.InputError, match="phase = 'nope'"):
        Mechanism.from_yaml(MECHANISM_PATHS["h2o2"], phase="nope")
    with pytest.raises(snapo_ode.InputError, match="is not a file"):
        Mechanism.from_yaml(tmp_path / "missing.yaml")
