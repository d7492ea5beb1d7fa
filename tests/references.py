"""Independent references shared by several test files."""

import numpy as np
from scipy.integrate import solve_ivp


def robertson_reference(rates, t1: float, *, rtol: float = 1e-12, atol: float = 1e-18) -> np.ndarray:
    """Robertson's kinetics y = (a, b, c) from (1, 0, 0) to `t1` by SciPy's Radau, written in NumPy
    with its exact Jacobian (a JAX call per evaluation would dominate SciPy's time): y(t1), (3,)."""
    k = np.asarray(rates, float)

    def field(t, y):
        a, b, c = y
        return np.array([-k[0] * a + k[1] * b * c, k[0] * a - k[1] * b * c - k[2] * b**2, k[2] * b**2])

    def jacobian(t, y):
        a, b, c = y
        return np.array([[-k[0], k[1] * c, k[1] * b], [k[0], -k[1] * c - 2 * k[2] * b, -k[1] * b],
                         [0.0, 2 * k[2] * b, 0.0]])

    solved = solve_ivp(field, (0.0, t1), [1.0, 0.0, 0.0], method="Radau", rtol=rtol, atol=atol, jac=jacobian)
    assert solved.success, solved.message
    return solved.y[:, -1]
