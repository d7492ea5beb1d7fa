"""Fractional and negative reaction orders at and near zero concentration: finite rates equal to
Cantera's (which sets such a factor to 0 where the concentration is not positive) and finite
gradients, where c ** -0.5 used to give an infinite rate."""

import cantera as ct
import jax
import jax.numpy as jnp
import numpy as np
import pytest

import chemistry

MECHANISM = """
units: {length: m, quantity: kmol, activation-energy: J/kmol}
phases:
- name: gas
  thermo: ideal-gas
  elements: [H, O, N]
  species: [H2, O2, H2O, N2]
  kinetics: gas
  reactions: all
  state: {T: 1000.0, P: 1 atm}
species:
- name: H2
  composition: {H: 2}
  thermo: {model: constant-cp, T0: 298.15, h0: 0.0, s0: 130.68 J/mol/K, cp0: 28.8 J/mol/K}
- name: O2
  composition: {O: 2}
  thermo: {model: constant-cp, T0: 298.15, h0: 0.0, s0: 205.15 J/mol/K, cp0: 29.4 J/mol/K}
- name: H2O
  composition: {H: 2, O: 1}
  thermo: {model: constant-cp, T0: 298.15, h0: -241.826 kJ/mol, s0: 188.84 J/mol/K, cp0: 33.6 J/mol/K}
- name: N2
  composition: {N: 2}
  thermo: {model: constant-cp, T0: 298.15, h0: 0.0, s0: 191.61 J/mol/K, cp0: 29.1 J/mol/K}
reactions:
- equation: 2 H2 + O2 => 2 H2O
  rate-constant: {A: 1.0e9, b: 0.0, Ea: 1.0e7}
  orders: {H2: 1.5, O2: 0.5, H2O: -0.5}
  nonreactant-orders: true
  negative-orders: true
"""


@pytest.fixture(scope="module")
def both(tmp_path_factory):
    path = tmp_path_factory.mktemp("orders") / "orders.yaml"
    path.write_text(MECHANISM)
    return chemistry.Mechanism.from_yaml(path), ct.Solution(str(path))


@pytest.mark.parametrize("water", [0.0, 1e-30, 1e-12, 1.0])
@pytest.mark.parametrize("oxygen", [0.0, 1e-30, 1.0])
def test_rates_at_and_near_zero_equal_cantera_and_stay_finite(both, water, oxygen):
    mechanism, gas = both
    gas.TPX = 1200.0, ct.one_atm, {"H2": 1.0, "O2": oxygen, "H2O": water, "N2": 1.0}
    concentrations = jnp.asarray(gas.concentrations)
    forward, reverse = (np.asarray(rate) for rate in mechanism.rates_of_progress(1200.0, concentrations))
    np.testing.assert_allclose(forward, gas.forward_rates_of_progress, rtol=1e-12)
    np.testing.assert_allclose(reverse, gas.reverse_rates_of_progress, rtol=1e-12)
    np.testing.assert_allclose(mechanism.net_production_rates(1200.0, concentrations), gas.net_production_rates,
                               rtol=1e-12, atol=1e-300)
    gradient = jax.grad(lambda c: mechanism.net_production_rates(1200.0, c)[2])(concentrations)
    jacobian = mechanism.concentration_jacobian(1200.0, concentrations)
    assert np.all(np.isfinite(gradient)) and np.all(np.isfinite(jacobian))
    if water == 0.0 or oxygen == 0.0:
        assert forward[0] == 0.0  # Cantera: a fractional or negative order's factor is 0 at zero


def test_gradient_away_from_zero_equals_central_differences(both):
    mechanism, gas = both
    gas.TPX = 1200.0, ct.one_atm, {"H2": 1.0, "O2": 0.5, "H2O": 0.2, "N2": 1.0}
    concentrations = jnp.asarray(gas.concentrations)
    rate = lambda c: mechanism.rates_of_progress(1200.0, c)[0][0]  # noqa: E731
    gradient = np.asarray(jax.grad(rate)(concentrations))
    step = 1e-6 * np.asarray(concentrations)
    for k in range(3):
        bump = jnp.zeros_like(concentrations).at[k].set(step[k])
        central = (rate(concentrations + bump) - rate(concentrations - bump)) / (2 * step[k])
        assert float(central) == pytest.approx(gradient[k], rel=1e-7)
