"""The design space's edge uncertainty: the edges traced on the grid against edges of known length,
the expected uncertainty after an experiment against the bivariate normal across a straight edge
(SciPy), the covariance update against the inverse of the information, the gain never negative
and zero without information, and the CQAs' sensitivities to the posterior's coordinates and
their spread against central differences and Monte Carlo of the full chain."""

import numpy as np
import pytest
import scipy.integrate
import scipy.stats

from chemistry.pharma import BUMP_SOLVER, PharmaChain, make_cpps
from chemistry.pharma._edge_uncertainty import EdgeMap, edge_map
from chemistry.pharma._next_experiment import updated_covariance
from chemistry.pharma._posterior import Posterior, posterior_inputs
from chemistry.pharma._sensitivities import input_names, shifted_cqas


def _unit_grid(n: int):
    u = np.linspace(0.0, 1.0, n)
    return np.meshgrid(u, u, indexing="ij")


def _map(margins: np.ndarray, sensitivities: np.ndarray) -> EdgeMap:
    n = margins.shape[0]
    return EdgeMap("x", "y", np.linspace(0, 1, n), np.linspace(0, 1, n), ("l",), margins[..., None],
                   sensitivities[..., None, :])


def test_edges_of_known_length_and_location_spread():
    # A straight edge x = 0.37, g = 2 (x - 0.37), its spread s = 0.02 + 0.1 y: U = integral of s / 2 over y = 0.035,
    # exact on any grid (g and s linear).
    x, y = _unit_grid(7)
    edge = _map(2 * (x - 0.37), np.stack([0.02 + 0.1 * y], -1))
    assert edge.uncertainty(np.eye(1)) == pytest.approx(0.035, rel=1e-12)
    assert edge.edge_length()[0] == pytest.approx(1.0, rel=1e-12)
    # A circle of radius 0.3 (|grad g| = 1, s = 0.01): 2 pi R s, to second order in the grid's step.
    errors = []
    for n in (11, 41):
        x, y = _unit_grid(n)
        circle = _map(0.3 - np.hypot(x - 0.5, y - 0.5), np.full(x.shape + (1,), 0.01))
        errors.append(abs(circle.uncertainty(np.eye(1)) / (2 * np.pi * 0.3 * 0.01) - 1))
        assert circle.edge_length()[0] == pytest.approx(2 * np.pi * 0.3, rel=1e-2)
    assert errors[1] < 0.005 and errors[1] < errors[0] / 2
    # No edge in the box: nothing to know.
    assert _map(1.0 + x, np.ones(x.shape + (1,))).uncertainty(np.eye(1)) == 0.0


@pytest.mark.parametrize("ratio", [1.0, 0.6, 0.1])
def test_expected_bernoulli_variance_across_an_edge_is_the_spread_after(ratio):
    # Across a straight edge g = k x with spread s now and s' = ratio s after, the mean moving by N(0, s^2 - s'^2):
    # the integral over x of the expected p'(1 - p') = P(W1 <= h, W2 > h) (h = g/s, corr(W1, W2) = 1 - ratio^2),
    # from SciPy's bivariate normal, is s' / (k sqrt(pi)): U under the covariance after, over sqrt(pi).
    k, s = 3.0, 0.02
    rho = 1 - ratio ** 2
    normal = scipy.stats.multivariate_normal([0, 0], [[1, rho], [rho, 1]]) if ratio < 1 else None

    def expected(x):
        h = k * x / s
        both = normal.cdf([h, h]) if normal is not None else scipy.stats.norm.cdf(h) ** 2
        return scipy.stats.norm.cdf(h) - both

    integral, _ = scipy.integrate.quad(expected, -0.2, 0.2, points=[0.0], epsabs=1e-12, limit=200)
    x, _ = _unit_grid(5)
    after = _map(k * (x - 0.5), np.full(x.shape + (1,), s * ratio)).uncertainty(np.eye(1))
    np.testing.assert_allclose(integral * np.sqrt(np.pi), after, rtol=1e-5)


def test_gain_is_never_negative_and_zero_without_information():
    rng = np.random.default_rng(3)
    x, y = _unit_grid(9)
    g = 0.4 - np.hypot(x - 0.3, y - 0.6) + 0.05 * x * y
    edge = _map(g, rng.standard_normal(x.shape + (4,)))
    root = rng.standard_normal((4, 4))
    covariance = root @ root.T / 4
    now = edge.uncertainty(covariance)
    assert now > 0
    for rows in (1, 3, 8):
        jacobian = rng.standard_normal((rows, 4)) * rng.uniform(0.01, 3)
        after = updated_covariance(covariance, jacobian)
        np.testing.assert_allclose(after, np.linalg.inv(np.linalg.inv(covariance) + jacobian.T @ jacobian),
                                   rtol=1e-9, atol=1e-12)
        assert edge.uncertainty(after) <= now
    assert edge.uncertainty(updated_covariance(covariance, np.zeros((5, 4)))) == now
    # A singular covariance (a direction the data do not move) needs no inverse.
    singular = covariance.copy()
    singular[:, 0] = singular[0, :] = 0.0
    assert np.all(np.isfinite(updated_covariance(singular, rng.standard_normal((2, 4)))))


@pytest.fixture(scope="module")
def bump_chain():
    return PharmaChain(solver=BUMP_SOLVER)


def test_sensitivities_and_spread_against_the_full_chain(bump_chain):
    # A posterior over the synthesis's ln k and activation temperature (correlated) and the over-reaction's ln k, at
    # the hot corner of r1_temperature x dryer_temperature; the full chain by central differences in each scaled
    # coordinate (d ln margin / d coordinate) and by Monte Carlo from the covariance (the margins' spread).
    chain = bump_chain
    j = chain.mechanism.reaction_equations.index("A + B => P")
    posterior = Posterior(("log_multiplier[A + B => P]", "log_multiplier[P => I]", "activation_temperature[A + B => P]"),
                          np.array([0.1, 0.2, float(chain.rate_parameters.activation_temperature[j]) + 50.0]),
                          np.array([1.0, 1.0, 313.0]), np.array([[4e-4, 0.0, 3e-4], [0.0, 2e-4, 0.0], [3e-4, 0.0, 4e-4]]),
                          "api_chain")
    inputs = chain.inputs(make_cpps())
    edge = edge_map(chain, inputs, posterior, x="r1_temperature", y="dryer_temperature", points=3)
    at = posterior_inputs(chain, inputs, posterior)
    column = {name: k for k, name in enumerate(input_names(chain))}
    base = np.zeros(len(column))
    base[column["r1_temperature"]] = edge.xs[2] - float(at.cpps.r1_temperature)
    base[column["dryer_temperature"]] = edge.ys[2] - float(at.cpps.dryer_temperature)
    step, n = 1e-4, 181  # 188 rows in all, as the posterior design space's verification: one compiled program
    shifts = [base]
    for k, name in enumerate(posterior.names):
        for sign in (1, -1):
            shift = base.copy()
            shift[column[name]] += sign * step * posterior.scales[k]
            shifts.append(shift)
    draws = posterior.draws(np.random.default_rng(0).standard_normal((n, 3)))
    sampled = np.tile(base, (n, 1))
    sampled[:, [column[name] for name in posterior.names]] += draws * posterior.scales
    cqas = shifted_cqas(chain, at, np.vstack([np.array(shifts), sampled]))
    margins = np.stack([sign * (np.log(cqas[:, c]) - np.log(limit)) for c, spec in enumerate(chain.process.cqas)
                        for limit, sign in ((spec.low, 1.0), (spec.high, -1.0))
                        if limit is not None and np.isfinite(limit) and limit > 0], -1)
    np.testing.assert_allclose(edge.margins[2, 2], margins[0], rtol=1e-9)
    central = (margins[1:7:2] - margins[2:7:2]).T / (2 * step)
    np.testing.assert_allclose(edge.sensitivities[2, 2], central, rtol=1e-5, atol=1e-5 * np.abs(central).max())
    spread, sampled_sd = edge.spread(posterior.covariance)[2, 2], margins[7:].std(axis=0, ddof=1)
    moving = spread > 1e-3 * spread.max()
    assert moving.sum() >= 2
    # The standard deviation of n normal draws has a relative standard error of 1 / sqrt(2 (n - 1)).
    np.testing.assert_allclose(sampled_sd[moving], spread[moving], rtol=4 / np.sqrt(2 * (n - 1)))
