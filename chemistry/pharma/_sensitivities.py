"""ICH Q8 sensitivities: every CQA with respect to every CPP (absolute and normalised) and to every
kinetic and physical parameter, from one Jacobian of the chain (5 reverse passes, vmapped, or one
forward tangent per input), checked against central differences."""

from typing import NamedTuple

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np

from chemistry import RateParameters
from snapo_ode import call_checked, choose_mode, flatten_inputs, jacobian, time_function

from ._chain import PharmaChain
from ._cqa import cqa_vector
from ._parameters import CPP_NAMES, CQA_NAMES, PHYSICAL_NAMES, CPPs, PhysicalParameters, default_physical_parameters


class ChainInputs(eqx.Module):
    """Everything the CQAs depend on: `cpps`, the `rates` (per-reaction log-multipliers,
    temperature exponents and activation temperatures [K]) and the `physical` parameters."""

    cpps: CPPs
    rates: RateParameters
    physical: PhysicalParameters


def chain_inputs(chain: PharmaChain, cpps: CPPs, physical: PhysicalParameters | None = None,
                 rates: RateParameters | None = None) -> ChainInputs:
    return ChainInputs(cpps, chain.rate_parameters if rates is None else rates,
                       default_physical_parameters() if physical is None else physical)


def input_names(chain: PharmaChain) -> list[str]:
    """Names of the flattened inputs, in `flatten_inputs(ChainInputs)` order."""
    equations = chain.mechanism.reaction_equations
    rates = [f"{field}[{equation}]" for field in ("log_multiplier", "temperature_exponent", "activation_temperature")
             for equation in equations]
    return [*CPP_NAMES, *rates, *PHYSICAL_NAMES]


def cqa_function(chain: PharmaChain):
    """inputs -> the CQA vector, shape (5,)."""

    def cqas(inputs: ChainInputs):
        return cqa_vector(chain.simulate(inputs.cpps, inputs.rates, inputs.physical))

    return cqas


def cpp_only(chain: PharmaChain, inputs: ChainInputs):
    """cpps -> the CQA vector, the parameters held at `inputs`."""

    def cqas(cpps: CPPs):
        return cqa_vector(chain.simulate(cpps, inputs.rates, inputs.physical))

    return cqas


@eqx.filter_jit
def _values_and_jacobian(chain: PharmaChain, inputs: ChainInputs, with_parameters: bool, mode: str):
    if with_parameters:
        result = jacobian(cqa_function(chain), inputs, mode=mode)
    else:
        result = jacobian(cpp_only(chain, inputs), inputs.cpps, mode=mode)
    return result.values, result.matrix


def jacobian_function(chain: PharmaChain, with_parameters: bool, mode: str):
    """A jitted function of the inputs -> (CQAs (5,), Jacobian (5, n)), with the chain's adjoint
    set for `mode` ("reverse": 5 vmapped vjp passes; "forward": n vmapped jvp tangents). With
    `with_parameters=False`, n = 4 (the CPPs). One compiled program per (scene, solver, mode)
    is shared by every caller in the process, and stored by the persistent compilation cache
    (`snapo_ode.call_checked`: a failed solve raises `SolverFailed` here, on the host)."""
    chain = chain.with_solver(chain.solver.with_differentiation(mode))
    return lambda inputs: call_checked(_values_and_jacobian, chain, inputs, with_parameters, mode,
                                       what="the chain's sensitivities")


def resolve_mode(mode: str, n_inputs: int) -> str:
    return choose_mode(len(CQA_NAMES), n_inputs) if mode == "auto" else mode


class Sensitivities(NamedTuple):
    """`cqas` (5,); `matrix` d CQA / d CPP (5, 4); `normalized` d ln CQA / d ln CPP (5, 4);
    `parameters` d CQA / d parameter (5, n_parameters) with `parameter_names`; `mode` used;
    `seconds_median` and `compile_seconds` of the Jacobian."""

    cqas: np.ndarray
    matrix: np.ndarray
    normalized: np.ndarray
    parameters: np.ndarray
    parameter_names: list[str]
    mode: str
    seconds_median: float
    compile_seconds: float


def sensitivities(chain: PharmaChain, inputs: ChainInputs, *, mode: str = "auto", repeats: int = 5) -> Sensitivities:
    """Every CQA's sensitivity to every CPP and parameter from one Jacobian (`mode` "auto" picks
    reverse for 5 outputs and ~50 inputs: 5 passes)."""
    flat, _ = flatten_inputs(inputs)
    mode = resolve_mode(mode, flat.shape[0])
    timing, (values, matrix) = time_function(jacobian_function(chain, True, mode), inputs, repeats=repeats)
    values, matrix = np.asarray(values), np.asarray(matrix)
    n_cpp = len(CPP_NAMES)
    cpp_values = np.asarray(flat[:n_cpp])
    return Sensitivities(values, matrix[:, :n_cpp], matrix[:, :n_cpp] * cpp_values[None, :] / values[:, None],
                         matrix[:, n_cpp:], input_names(chain)[n_cpp:], mode, timing.median_seconds,
                         timing.compile_seconds)


@eqx.filter_jit
def _bumped_cqas(chain: PharmaChain, inputs: ChainInputs, bumps):
    flat, rebuild = flatten_inputs(inputs)
    evaluate = cqa_function(chain)
    return jax.vmap(lambda bump: evaluate(rebuild(flat + bump)))(bumps)


def bumped_cqas(chain: PharmaChain, inputs: ChainInputs, bumps) -> np.ndarray:
    """The CQAs at the flattened inputs + each row of `bumps` (shape (m, n)), in one vmapped,
    cacheable call; shape (m, 5). Raises `SolverFailed` if any solve failed."""
    return np.asarray(call_checked(_bumped_cqas, chain, inputs, jnp.asarray(bumps), what="the bumped chains"))


def central_differences(chain: PharmaChain, inputs: ChainInputs, indices, *, relative_step: float = 1e-3):
    """Central differences of the CQA vector with respect to the flattened inputs `indices`,
    Richardson-extrapolated from steps h and h/2 (error O(h^4), so h can be large enough that
    the solver's error divided by h stays far below 1e-5), shape (5, len(indices)).
    h = `relative_step` * |x| (* 1 where x = 0, e.g. a log-multiplier); all 4 len(indices)
    bumped chains in one vmapped call."""
    flat, _ = flatten_inputs(inputs)
    indices = np.asarray(indices)
    values = np.abs(np.asarray(flat)[indices])
    steps = relative_step * np.where(values == 0, 1.0, values)
    n = len(indices)
    bumps = np.zeros((n, flat.shape[0]))
    bumps[np.arange(n), indices] = steps
    bumps = np.concatenate([bumps, -bumps, bumps / 2, -bumps / 2])
    up, down, half_up, half_down = np.split(bumped_cqas(chain, inputs, bumps), 4)
    coarse = (up - down) / (2 * steps[:, None])
    fine = (half_up - half_down) / steps[:, None]
    return ((4 * fine - coarse) / 3).T


def input_scales(inputs: ChainInputs) -> np.ndarray:
    """|x| of each flattened input (1 where x = 0: log-multipliers, temperature exponents)."""
    flat, _ = flatten_inputs(inputs)
    values = np.abs(np.asarray(flat))
    return np.where(values == 0, 1.0, values)


def relative_errors(estimate, reference, scales=None, *, floor: float = 1e-8) -> np.ndarray:
    """Entrywise relative differences of two (CQA x input) sensitivity matrices.

    Both are first multiplied by the inputs' `scales` (giving d CQA / d ln x, so that a
    parameter of size 1e-8 and one of size 1e4 are compared on the same footing); then each
    entry is compared at max(|reference|, `floor` * max |reference row|): each CQA row has its
    own unit, and an entry a `floor` fraction of its row's largest (exact zeros, e.g. crystal size
    against the dryer) is compared at that scale, not against round-off."""
    estimate, reference = np.atleast_2d(estimate), np.atleast_2d(reference)
    if scales is not None:
        estimate, reference = estimate * scales, reference * scales
    scale = np.maximum(np.abs(reference), floor * np.max(np.abs(reference), axis=1, keepdims=True))
    return np.abs(estimate - reference) / np.where(scale == 0, 1.0, scale)


def max_rel_diff(estimate, reference, scales=None, *, floor: float = 1e-8) -> float:
    """The largest of `relative_errors`."""
    return float(np.max(relative_errors(estimate, reference, scales, floor=floor)))


def bump_agreement(adjoint, bumped, scales) -> tuple[float, float]:
    """Adjoint (CQA x input) sensitivities against central differences: the largest
    `relative_errors` over the entries that are not structurally zero, and the largest |bumped|
    (scaled, over its row's largest) where the adjoint is exactly zero up to 1e-12 (a CQA that
    does not depend on an input, such as crystal size on the dryer: the bumps see round-off)."""
    scaled = np.abs(adjoint * scales)
    row_max = scaled.max(axis=1, keepdims=True)
    zero = scaled <= 1e-12 * row_max
    errors = relative_errors(adjoint, bumped, scales)
    at_zeros = np.abs(bumped * scales)[zero] / np.broadcast_to(row_max, zero.shape)[zero]
    return float(errors[~zero].max()), float(at_zeros.max(initial=0.0))
