"""Sensitivities: one reverse pass for a scalar, a vmapped Jacobian for a vector, addressed by
name rather than by position in a flat vector.

Inputs are any pytree (an `equinox.Module` policy, a dict of model inputs, or both together);
the differentiable part is every inexact array leaf, as in `equinox.filter_grad`. The flat
order is `flatten_inputs`'s; `input_names` names each entry of it.
"""

from collections.abc import Callable, Sequence
from typing import Literal, NamedTuple

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
from jax.flatten_util import ravel_pytree

from ._platform.config import require_float64
from ._platform.validation import InputError, check_choice

JacobianMode = Literal["auto", "reverse", "forward"]


def flatten_inputs(inputs):
    """Split `inputs` into a flat float vector of its inexact array leaves and a function that
    rebuilds the full pytree from such a vector."""
    params, static = eqx.partition(inputs, eqx.is_inexact_array)
    flat, unravel = ravel_pytree(params)

    def rebuild(vector):
        return eqx.combine(unravel(vector), static)

    return flat, rebuild


def _key_name(key) -> str:
    for attribute in ("name", "key", "idx"):
        if hasattr(key, attribute):
            return str(getattr(key, attribute))
    return str(key)


def input_names(inputs) -> list[str]:
    """A name for each entry of `flatten_inputs(inputs)[0]`: the path of its leaf, dotted
    (`cpps.r1_temperature`, `forward_curve`), with the index of an array entry in brackets
    (`rates.log_multiplier[3]`, `injection_ratchet[1][0]`)."""
    params = eqx.filter(inputs, eqx.is_inexact_array)
    names = []
    for path, leaf in jax.tree_util.tree_flatten_with_path(params)[0]:
        base = ".".join(_key_name(key) for key in path)
        shape = np.shape(leaf)
        if not shape:
            names.append(base)
        else:
            names.extend(base + "".join(f"[{i}]" for i in index) for index in np.ndindex(*shape))
    return names


def value_and_sensitivities(fn: Callable, inputs, *args, has_aux: bool = False):
    """The value of scalar `fn(inputs, *args)` and its gradient with respect to every inexact
    array leaf of `inputs`, from one reverse pass.

    **Returns:** `(value, gradient)` (or `((value, aux), gradient)` with `has_aux`); the gradient
    has the structure of `inputs`, with `None` at non-differentiable leaves.

    **Raises:** `ConfigurationError` when float64 is off (`snapo_ode.configure()`).
    """
    require_float64("sensitivities")
    return eqx.filter_value_and_grad(fn, has_aux=has_aux)(inputs, *args)


class Jacobian(NamedTuple):
    """`values`: shape (m,); `matrix`: d values / d inputs, shape (m, n) over the flattened
    inputs; `mode`: "reverse" (m vmapped reverse passes) or "forward" (n vmapped tangents);
    `rebuild`: maps a length-n vector back to the structure of the inputs; `input_names`
    (n,) and `output_names` (m,): the names of the columns and rows. The arrays are JAX's as
    `jacobian` returns them, or NumPy's where a caller keeps them on the host (the pharma
    study's `named_jacobian`)."""

    values: jax.Array | np.ndarray
    matrix: jax.Array | np.ndarray
    mode: str
    rebuild: Callable
    input_names: tuple[str, ...]
    output_names: tuple[str, ...]

    def row(self, output: str | int):
        """d values[output] / d inputs (an output's name or position), in the structure of the
        inputs."""
        return self.rebuild(self.matrix[output if isinstance(output, int) else self.output_names.index(output)])

    def columns(self, names: Sequence[str]) -> jax.Array | np.ndarray:
        """The columns of the inputs `names`, shape (m, len(names)).

        **Raises:** `InputError` naming an input that is not a column."""
        where = {name: i for i, name in enumerate(self.input_names)}
        missing = [name for name in names if name not in where]
        if missing:
            raise InputError(f"no input named {missing[0]!r}; inputs: {', '.join(self.input_names[:8])}, ...")
        return self.matrix[:, np.array([where[name] for name in names], dtype=int)]

    def named(self, names: Sequence[str] | None = None) -> dict[str, dict[str, float]]:
        """output -> input -> d output / d input, for the inputs `names` (default: all)."""
        names = self.input_names if names is None else tuple(names)
        block = np.asarray(self.columns(names))
        return {output: {name: float(value) for name, value in zip(names, row, strict=True)}
                for output, row in zip(self.output_names, block, strict=True)}


def choose_mode(n_outputs: int, n_inputs: int) -> str:
    """Reverse mode costs one pass per output, forward mode one per input: pick the fewer
    (reverse on a tie, since it also serves gradients of scalar objectives)."""
    return "reverse" if n_outputs <= n_inputs else "forward"


def jacobian(fn: Callable, inputs, *args, mode: JacobianMode = "auto", names: Sequence[str] | None = None,
             output_names: Sequence[str] | None = None) -> Jacobian:
    """The Jacobian of the vector `fn(inputs, *args)` (shape (m,)) with respect to `inputs`.

    `mode="auto"` picks reverse or forward mode from the Jacobian's shape (`choose_mode`); the
    mode used is in the result. A model integrated with `diffrax.RecursiveCheckpointAdjoint`
    supports reverse mode only; build it with `diffrax.ForwardMode()` for forward mode.
    `names` (default `input_names(inputs)`) and `output_names` (default "0", "1", ...) label the
    columns and rows.

    **Raises:** `ConfigurationError` when float64 is off.
    """
    require_float64("sensitivities")
    check_choice("mode", mode, ("auto", "reverse", "forward"))
    flat, rebuild = flatten_inputs(inputs)

    def flat_fn(vector):
        return jnp.ravel(fn(rebuild(vector), *args))

    if mode == "auto":
        mode = choose_mode(jax.eval_shape(flat_fn, flat).shape[0], flat.shape[0])
    if mode == "reverse":
        values, pullback = jax.vjp(flat_fn, flat)
        (matrix,) = jax.vmap(pullback)(jnp.eye(values.shape[0], dtype=values.dtype))
    else:
        tangents = jnp.eye(flat.shape[0], dtype=flat.dtype)
        # The values do not depend on the tangent: they come out of the vmapped JVP once
        # (out_axes None) instead of from a second evaluation (a second solve of a model).
        values, matrix = jax.vmap(lambda tangent: jax.jvp(flat_fn, (flat,), (tangent,)), out_axes=(None, 1))(tangents)
    n_outputs = values.shape[0]
    names = tuple(input_names(inputs) if names is None else names)
    output_names = tuple(str(i) for i in range(n_outputs)) if output_names is None else tuple(output_names)
    if len(names) != flat.shape[0] or len(output_names) != n_outputs:
        raise InputError(f"{len(names)} input names and {len(output_names)} output names for a Jacobian of shape "
                         f"({n_outputs}, {flat.shape[0]}).")
    return Jacobian(values, matrix, mode, rebuild, names, output_names)
