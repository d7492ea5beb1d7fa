"""PLOG, Chebyshev, SRI and Tsang falloff, chemically-activated and Blowers-Masel reactions against
Cantera at pressures below, at, between and above the PLOG pressures (300-3000 K: every
Blowers-Masel branch), and their gradients (rate parameters and state) against central
differences, finite at a tabulated pressure too."""

import re

import cantera
import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
import pytest

import snapo_ode
from chemistry import GAS_CONSTANT, MECHANISMS, ONE_ATM, Mechanism

PATH = MECHANISMS / "reaction_types.yaml"
# reaction_types.yaml's PLOG pressures [Pa]: 0.1, 1, 10 and 100 atm, and 5e4 and 2e6 Pa.
TABULATED = [0.1 * ONE_ATM, ONE_ATM, 10.0 * ONE_ATM, 100.0 * ONE_ATM, 5e4, 2e6]
BETWEEN = [3e4, 1e6, 4e6]
OUTSIDE = [1e3, 5e3, 2e7, 1e8]


@pytest.fixture(scope="module")
def mechanism():
    return Mechanism.from_yaml(PATH)


def _states(n_temperatures, seed):
    rng = np.random.default_rng(seed)
    for temperature in rng.uniform(300.0, 3000.0, n_temperatures):
        for pressure in TABULATED + BETWEEN + OUTSIDE:
            yield float(temperature), pressure, rng.random(7) + 0.05


def test_new_types_match_cantera_below_at_between_and_above_the_plog_pressures(mechanism):
    gas = cantera.Solution(str(PATH))
    kinds = [reaction.reaction_type for reaction in gas.reactions()]
    # Cantera's forward_rate_constants leave out a three-body reaction's collider concentration.
    compared = np.array([kind != "three-body-Arrhenius" for kind in kinds])
    assert {"pressure-dependent-Arrhenius", "Chebyshev", "falloff-SRI", "falloff-Tsang", "chemically-activated-Troe",
            "Blowers-Masel"} <= set(kinds)
    rate_constants = eqx.filter_jit(lambda m, t, c: m._rate_constants(t, c, m.parameters)[0])
    rates = eqx.filter_jit(lambda m, t, c: m.rates_of_progress(t, c))
    worst = {"k": 0.0, "progress": 0.0, "net": 0.0}
    for temperature, pressure, fractions in _states(12, 0):
        gas.TPX = temperature, pressure, fractions
        c = jnp.asarray(gas.concentrations)
        k = np.asarray(rate_constants(mechanism, temperature, c))
        forward, reverse = (np.asarray(a) for a in rates(mechanism, temperature, c))
        net = (forward - reverse) @ np.asarray(mechanism.net_stoichiometry)
        worst["k"] = max(worst["k"], np.max(np.abs(k / gas.forward_rate_constants - 1)[compared]))
        for ours, theirs in ((forward, gas.forward_rates_of_progress), (reverse, gas.reverse_rates_of_progress)):
            nonzero = theirs != 0
            assert np.all(ours[~nonzero] == 0)
            worst["progress"] = max(worst["progress"], np.max(np.abs(ours[nonzero] / theirs[nonzero] - 1)))
        # A net rate far below its gross rates is a difference of nearly equal numbers.
        clean = np.abs(gas.net_production_rates) > 1e-4 * (gas.creation_rates + gas.destruction_rates)
        worst["net"] = max(worst["net"], np.max(np.abs(net[clean] / gas.net_production_rates[clean] - 1)))
    assert max(worst.values()) <= 1e-10, worst


def _concentrations(temperature, pressure, seed):
    fractions = np.random.default_rng(seed).random(7) + 0.05
    return jnp.asarray(fractions / fractions.sum() * pressure / (GAS_CONSTANT * temperature))


def _with(mechanism, parts):
    return eqx.tree_at(lambda m: (m.plog, m.chebyshev, m.falloff, m.blowers_masel), mechanism, parts)


@pytest.mark.parametrize("pressure", [1e3, 3e4, 4e6, 3e8])
def test_gradient_wrt_new_rate_parameters_matches_central_differences(mechanism, pressure):
    # Every PLOG, Chebyshev and falloff (SRI included) parameter, below, between and above the
    # PLOG pressures (at a tabulated one the rate has a kink in ln P; see the next test). The
    # objective is a weighted sum of the reactions' ln k, of order 100, so that central
    # differences resolve every entry (net production rates of order 1e9 would drown the small ones).
    temperature = 1300.0
    concentrations = _concentrations(temperature, pressure, 1)
    reactions = jnp.concatenate([mechanism.plog.index, mechanism.chebyshev.index, mechanism.falloff.index,
                                 mechanism.blowers_masel.index])
    weights = jnp.asarray(np.random.default_rng(2).normal(size=reactions.size))
    parts, indices = eqx.partition((mechanism.plog, mechanism.chebyshev, mechanism.falloff, mechanism.blowers_masel),
                                   eqx.is_inexact_array)

    def objective(parts):
        changed = _with(mechanism, eqx.combine(parts, indices))
        k, _ = changed._rate_constants(temperature, concentrations, changed.parameters)
        return weights @ jnp.log(k[reactions])

    _, adjoint = snapo_ode.value_and_sensitivities(objective, parts)
    bumped = snapo_ode.bump_and_revalue(objective, parts)
    # 1/T_min and 1/T_max (~1e-3 K^-1) and the Tsang slope (~1e-4 K^-1) take an absolute step of
    # 1e-6, too coarse: a finer one.
    fine = snapo_ode.bump_and_revalue(objective, parts, relative_step=1e-8)
    ranges = lambda parts: (parts[1].inv_t_min, parts[1].inv_t_max, parts[2].tsang_slope)  # noqa: E731
    bumped = eqx.tree_at(ranges, bumped, ranges(fine))
    # Not compared: a padding PLOG term (A = 0), d ln k / dA = 1/k, which a bump of 1e-6 on
    # k ~ 1e10 cannot resolve, and an absent SRI term (c = 0), where a bump to c < 0 gives
    # exp(-T/c) = inf (the derivative there is 0, from the side c > 0).
    for leaf in (lambda parts: parts[0].a, lambda parts: parts[2].sri_c):
        adjoint = eqx.tree_at(leaf, adjoint, jnp.where(leaf(parts) == 0, 0.0, leaf(adjoint)))
        bumped = eqx.tree_at(leaf, bumped, jnp.where(leaf(parts) == 0, 0.0, leaf(bumped)))
    assert float(jnp.abs(adjoint[1].coefficients).min()) > 0 and float(jnp.abs(adjoint[2].sri_c).max()) > 0
    for leaf_a, leaf_b in zip(jax.tree.leaves(adjoint), jax.tree.leaves(bumped), strict=True):
        assert np.all(np.isfinite(leaf_a))
        # Round-off of the differences, eps |f| / h ~ 2e-8 on f ~ 100 with h = 1e-6, is 1e-4 of the
        # smallest leaves' derivatives (d ln k / d SRI b ~ 3e-5 per K).
        assert snapo_ode.max_relative_difference(leaf_a, leaf_b, floor=1e-2) < 1e-4


def test_plog_gradients_are_finite_at_and_between_the_tabulated_pressures(mechanism):
    plog = mechanism.plog
    temperature = 900.0

    def log_k(plog, log_pressure, g):
        return jnp.log(plog.rate(temperature, jnp.log(temperature), log_pressure)[g])

    slope = eqx.filter_grad(lambda inputs, g: log_k(*inputs, g))
    for g in range(plog.index.size):
        n_levels = int(plog.segment_weight[g].sum()) + 1
        table = np.asarray(plog.log_pressure[g, :n_levels])
        log_ks = np.array([float(log_k(plog, p, g)) for p in table])
        for i, log_p in enumerate(table):
            by_plog, by_pressure = slope((plog, jnp.asarray(log_p)), g)
            assert all(np.all(np.isfinite(leaf)) for leaf in jax.tree.leaves(by_plog))
            assert float(jnp.sum(jnp.abs(by_plog.a))) > 0
            # At a tabulated pressure: the mean of the two sides' slopes (what a central difference gives).
            sides = np.diff(log_ks) / np.diff(table)
            left = sides[i - 1] if i > 0 else 0.0
            right = sides[i] if i < n_levels - 1 else 0.0
            assert float(by_pressure) == pytest.approx((left + right) / 2, rel=1e-12, abs=1e-14)
        for i in range(n_levels - 1):  # midway: the interval's slope
            _, by_pressure = slope((plog, jnp.asarray((table[i] + table[i + 1]) / 2)), g)
            assert float(by_pressure) == pytest.approx(sides[i], rel=1e-12)


@pytest.mark.parametrize("pressure", [ONE_ATM, 10.0 * ONE_ATM, 2e6, 1e3, 1e8])
def test_state_gradient_is_finite_and_matches_central_differences(mechanism, pressure):
    temperature = 1100.0
    inputs = {"T": jnp.asarray(temperature), "C": _concentrations(temperature, pressure, 3)}

    def objective(inputs):
        return jnp.sum(jnp.tanh(mechanism.net_production_rates(inputs["T"], inputs["C"])))

    _, adjoint = snapo_ode.value_and_sensitivities(objective, inputs)
    assert all(np.all(np.isfinite(leaf)) for leaf in jax.tree.leaves(adjoint))
    bumped = snapo_ode.bump_and_revalue(objective, inputs, relative_step=1e-6)
    assert snapo_ode.max_relative_difference(adjoint["T"], bumped["T"]) < 1e-5
    assert snapo_ode.max_relative_difference(adjoint["C"], bumped["C"], floor=1e-3) < 1e-5


_REFUSED = {
    "PLOG with a third body": ("A + B + M <=> C + M", """
  type: pressure-dependent-Arrhenius
  rate-constants:
  - {P: 1 atm, A: 1.0e+13, b: 0.0, Ea: 0.0}""", "pressure-dependent-Arrhenius reaction with a third body"),
    "SRI with 4 parameters": ("A + B (+M) <=> C (+M)", """
  type: falloff
  low-P-rate-constant: {A: 1.0e+18, b: -1.0, Ea: 0.0}
  high-P-rate-constant: {A: 1.0e+13, b: 0.0, Ea: 0.0}
  SRI: {A: 1.1, B: 700.0, C: 1234.0, D: 1.0}""", "SRI needs A, B, C or A, B, C, D, E"),
    "Chebyshev with a ragged table": ("A + B <=> C", """
  type: Chebyshev
  temperature-range: [300.0, 2000.0]
  pressure-range: [0.01 atm, 100 atm]
  data: [[1.0, 0.5], [0.1]]""", "Chebyshev 'data' must be a non-empty rectangular"),
    "Blowers-Masel with w below Ea0": ("A + B <=> C", """
  type: Blowers-Masel
  rate-constant: {A: 1.0e+13, b: 0.0, Ea0: 5000.0, w: 4000.0}""", "w = 4000.0 must exceed Ea0 = 5000.0"),
    "Blowers-Masel without w": ("A + B <=> C", """
  type: Blowers-Masel
  rate-constant: {A: 1.0e+13, b: 0.0, Ea0: 5000.0}""", "needs rate-constant: {A: ..., b: ..., Ea0: ..., w: ...}"),
    "Tsang and Troe": ("A + B (+M) <=> C (+M)", """
  type: falloff
  low-P-rate-constant: {A: 1.0e+18, b: -1.0, Ea: 0.0}
  high-P-rate-constant: {A: 1.0e+13, b: 0.0, Ea: 0.0}
  Troe: {A: 0.5, T3: 100.0, T1: 1000.0}
  Tsang: {A: 0.5}""", "one of Troe, Tsang or SRI parameters; got Troe and Tsang"),
    "chemically-activated without its low-pressure limit": ("A + B (+M) <=> C (+M)", """
  type: chemically-activated
  high-P-rate-constant: {A: 1.0e+13, b: 0.0, Ea: 0.0}""", "missing 'low-P-rate-constant'"),
}


@pytest.mark.parametrize("case", sorted(_REFUSED))
def test_malformed_new_types_are_refused_naming_the_reaction(tmp_path, case):
    equation, body, message = _REFUSED[case]
    path = tmp_path / "bad.yaml"
    path.write_text(PATH.read_text() + f"- equation: {equation}{body}\n")
    n_reactions = cantera.Solution(str(PATH)).n_reactions
    with pytest.raises(snapo_ode.InputError, match=rf"reaction {n_reactions} \({re.escape(equation)}\).*{message}"):
        Mechanism.from_yaml(path)
