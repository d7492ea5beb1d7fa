"""The numerical differentiation formulas of orders 1-5 (Shampine & Reichelt, "The MATLAB ODE
Suite", SIAM J. Sci. Comput. 18, 1997) on a backward-difference array D, shape
`(MAX_ORDER + 3, n)`: their coefficients, the predictor, the update after an accepted step, the
re-expression of D for a new step size, and the interpolant of a step. Used by `snapo_ode._solver.bdf`;
the order is a traced integer, so every operation masks rows instead of slicing them."""

import jax.numpy as jnp
import numpy as np

MAX_ORDER = 5

# The NDF coefficients: kappa (Shampine & Reichelt, table 1), gamma_k = sum_{j<=k} 1/j, the
# implicit formula's alpha_k = (1 - kappa_k) gamma_k and the error constants
# kappa_k gamma_k + 1 / (k + 1), indexed by the order k (index 0 unused).
KAPPA = np.array([0.0, -0.1850, -1.0 / 9.0, -0.0823, -0.0415, 0.0])
GAMMA = np.concatenate([[0.0], np.cumsum(1.0 / np.arange(1, MAX_ORDER + 1))])
ALPHA = (1.0 - KAPPA) * GAMMA
ERROR_CONSTANT = np.concatenate([KAPPA * GAMMA + 1.0 / np.arange(1, MAX_ORDER + 2), [np.inf]])
ROWS = MAX_ORDER + 3  # differences 0..order+2 are kept


def rms(x):
    return jnp.sqrt(jnp.mean(x * x))


def _r_matrix(factor, xp=jnp):
    """R of Shampine & Reichelt for a step size ratio `factor`, full size (MAX_ORDER + 1)^2."""
    i = np.arange(1, MAX_ORDER + 1)[:, None]
    j = np.arange(1, MAX_ORDER + 1)[None, :]
    lower = xp.concatenate([xp.zeros((MAX_ORDER, 1)), (i - 1 - factor * j) / i], axis=1)
    return xp.cumprod(xp.concatenate([xp.ones((1, MAX_ORDER + 1)), lower], axis=0), axis=0)


_U = _r_matrix(1.0, np)
_ROW = np.arange(ROWS)[:, None]


def rescale(differences, order, factor):
    """The differences 0..`order` of a step h re-expressed for the step `factor` h (the same
    interpolating polynomial at the new spacing); the others unchanged."""
    size = MAX_ORDER + 1
    block = (np.arange(size)[:, None] <= order) & (np.arange(size)[None, :] <= order)
    ru = jnp.where(block, _r_matrix(factor), 0.0) @ jnp.where(block, _U, 0.0)
    ru = jnp.where(block, ru, jnp.eye(size))
    return differences.at[:size].set(ru.T @ differences[:size])


def predict(differences, order):
    """The predicted state sum_{i<=order} D_i and psi = sum_{1<=i<=order} gamma_i D_i / alpha_order,
    shape `(n,)` each."""
    used = _ROW <= order
    gamma = jnp.concatenate([jnp.asarray(GAMMA, differences.dtype), jnp.zeros(ROWS - GAMMA.size)])[:, None]
    predicted = jnp.sum(jnp.where(used, differences, 0.0), axis=0)
    psi = jnp.sum(jnp.where(used, gamma * differences, 0.0), axis=0) / jnp.asarray(ALPHA)[order]
    return predicted, psi


def update(differences, increment, order):
    """The differences after an accepted step with corrector `increment` d:
    D_{order+2} = d - D_{order+1}, D_{order+1} = d, then D_i += D_{i+1} from i = order down to 0."""
    top = jnp.where(_ROW == order + 2, increment - differences[jnp.minimum(order + 1, ROWS - 1)],
                    jnp.where(_ROW == order + 1, increment, differences))
    summed = jnp.flip(jnp.cumsum(jnp.flip(jnp.where(_ROW <= order + 1, top, 0.0), 0), 0), 0)
    return jnp.where(_ROW <= order, summed, top)


def interpolate(differences, order, t, h, times):
    """The BDF interpolant of a step (ending at `t`, size `h`, its updated differences) at
    `times`, shape `(n_ts, n)`: y = D_0 + sum_{j=1..order} D_j prod_{m<j} (tau - t + m h) / ((m + 1) h)."""
    m = np.arange(MAX_ORDER)
    factors = (times[:, None] - (t - m * h)) / ((m + 1) * h)  # (n_ts, MAX_ORDER)
    products = jnp.cumprod(factors, axis=1) * (m + 1 <= order)
    return differences[0] + products @ differences[1:MAX_ORDER + 1]


def initial_outputs(ts, t0, y0):
    """The outputs before the first step, shape `(n_ts, n)`: y0 at the times <= t0, zeros (to be
    filled by the steps that cover them) at the others."""
    return jnp.where((ts <= t0)[:, None], y0, jnp.zeros((ts.size, y0.size), y0.dtype))
