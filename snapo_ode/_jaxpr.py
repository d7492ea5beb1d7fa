"""Reading traced programs: the primitive operations of a jaxpr, loop and branch bodies included.

Used to prove that an effect left out of a scene is absent from the traced computation
(`count_operations`), and that a program holds no host callback (`snapo_ode.call_checked`).
"""

from collections.abc import Iterator

import jax


def equations(jaxpr) -> Iterator:
    """Every equation of `jaxpr` (a `Jaxpr` or `ClosedJaxpr`), recursing into the bodies of
    loops, conditionals and calls."""
    if isinstance(jaxpr, jax.extend.core.ClosedJaxpr):
        jaxpr = jaxpr.jaxpr
    for equation in jaxpr.eqns:
        yield equation
        for param in equation.params.values():
            for sub in param if isinstance(param, (tuple, list)) else (param,):
                if isinstance(sub, (jax.extend.core.ClosedJaxpr, jax.extend.core.Jaxpr)):
                    yield from equations(sub)


def count_operations(fn, *args, **kwargs) -> int:
    """The number of primitive operations in the jaxpr of `fn(*args, **kwargs)`, counting the
    bodies of loops, conditionals and calls recursively. Used to show an effect is absent."""
    return sum(1 for _ in equations(jax.make_jaxpr(fn)(*args, **kwargs)))
