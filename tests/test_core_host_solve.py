"""Peer solvers on the host (`SolverSettings(solver="cvode" | "scipy-bdf" | ...)`): the same vector
field integrated by SUNDIALS CVODE and SciPy agrees with Rodas4 and with SciPy's Radau at tight
tolerance; pytree states and closed-over integer tables work; a failed host solve raises
`SolverFailed`; what a host solve cannot do is refused by name."""

import diffrax
import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
import pytest

from snapo_ode import InputError, SolverFailed, SolverSettings, call_checked

RATES = jnp.array([0.04, 1e4, 3e7])
ORDER = jnp.array([2, 0, 1])  # an integer table the field closes over


def _robertson(t, y, rates):
    a, b, c = y["a"], y["bc"][0], y["bc"][1]
    return {"a": -rates[0] * a + rates[1] * b * c,
            "bc": jnp.stack([rates[0] * a - rates[1] * b * c - rates[2] * b**2, rates[2] * b**2])}


def _end(settings, t1=1e5):
    y0 = {"a": jnp.array(1.0), "bc": jnp.zeros(2)}

    @eqx.filter_jit
    def solve(rates):
        rates = rates[ORDER][ORDER][ORDER]  # the identity permutation, through a traced integer table
        ys = settings.solve(_robertson, 0.0, t1, y0, rates).ys
        return jnp.concatenate([ys["a"][-1:], ys["bc"][-1]])

    return np.asarray(call_checked(solve, RATES, what=settings.solver))


@pytest.mark.parametrize("solver", ["cvode", "scipy-bdf", "scipy-radau", "scipy-lsoda"])
def test_host_solvers_agree_with_rodas4_and_radau(solver):
    reference = _end(SolverSettings(solver="scipy-radau", rtol=1e-12, atol=1e-18))
    ours = _end(SolverSettings(solver="rodas4", rtol=1e-10, atol=1e-16))
    np.testing.assert_allclose(ours, reference, rtol=1e-8, atol=1e-15)
    np.testing.assert_allclose(_end(SolverSettings(solver=solver, rtol=1e-9, atol=1e-15)), reference, rtol=1e-5,
                               atol=1e-12)


def test_values_at_given_times():
    ts = jnp.array([1.0, 10.0, 100.0])
    settings = SolverSettings(solver="cvode", rtol=1e-10, atol=1e-16)
    ys = jax.jit(lambda: settings.solve(_robertson, 0.0, 100.0, {"a": jnp.array(1.0), "bc": jnp.zeros(2)}, RATES,
                                        saveat=diffrax.SaveAt(ts=ts)).ys)()
    assert ys["a"].shape == (3,) and ys["bc"].shape == (3, 2)
    for i, t in enumerate(np.asarray(ts)):
        np.testing.assert_allclose(float(ys["a"][i]), _end(SolverSettings(solver="rodas4", rtol=1e-10, atol=1e-16),
                                                          t1=float(t))[0], rtol=1e-7)


def test_a_failed_host_solve_raises_and_unsupported_uses_are_refused():
    settings = SolverSettings(solver="cvode", rtol=1e-8, atol=1e-10, max_steps=2000)
    blow_up = jax.jit(lambda y0: settings.solve(lambda t, y, args: y**2, 0.0, 2.0, y0).ys[-1])  # blows up at t = 1
    with pytest.raises(SolverFailed):
        call_checked(blow_up, jnp.array(1.0), what="the blow-up")
    with pytest.raises(InputError, match="dense"):
        settings.solve(lambda t, y, args: -y, 0.0, 1.0, jnp.array(1.0), saveat=diffrax.SaveAt(t1=True, dense=True))
    with pytest.raises(InputError, match="'cvode' is not a Diffrax method"):
        settings.method()
