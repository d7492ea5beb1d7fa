"""ICH Q8 sensitivities: every CQA with respect to every CPP and every kinetic and physical
parameter, from one Jacobian of the chain (5 reverse passes, vmapped, or one forward tangent per
input), addressed by name (`snapo_ode.Jacobian`)."""

import itertools

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
from jax.sharding import NamedSharding

from snapo_ode import (
    ONCE_COMPILE, QUICK_COMPILE, SAMPLES, Jacobian, bump_steps, call_checked, choose_mode, exported, flatten_inputs, jacobian, per_sample,
    prefetch_checked, spec, to_host)

from ._chain import PharmaChain
from ._cqa import cqa_vector
from ._parameters import ChainInputs, CPPs

RATE_FIELDS = ("log_multiplier", "temperature_exponent", "activation_temperature")


def input_names(chain: PharmaChain) -> list[str]:
    """Names of the flattened `ChainInputs`, in their flat order: the CPPs, then each rate field of
    each reaction ("log_multiplier[A + B => P]"), then the physical parameters ("feed.A",
    "crystallizer.growth_rate")."""
    equations = chain.mechanism.reaction_equations
    rates = [f"{field}[{equation}]" for field in RATE_FIELDS for equation in equations]
    return [*chain.cpp_names, *rates, *chain.process.physical_defaults()]


def rate_names(chain: PharmaChain, field: str = "log_multiplier") -> list[str]:
    """The names of one rate field's entries, one per reaction."""
    return [f"{field}[{equation}]" for equation in chain.mechanism.reaction_equations]


def parameter_names(chain: PharmaChain) -> list[str]:
    """Every input but the CPPs: the kinetic and physical parameters."""
    return input_names(chain)[len(chain.cpp_names):]


def cqa_function(chain: PharmaChain):
    """inputs (`ChainInputs`) -> the CQA vector of the chain's process, shape (n_cqas,)."""

    def cqas(inputs: ChainInputs):
        return cqa_vector(chain.simulate(inputs), chain.process)

    return cqas


def cpp_only(chain: PharmaChain, inputs: ChainInputs):
    """cpps -> the CQA vector, the parameters held at `inputs`."""

    def cqas(cpps: CPPs):
        return cqa_vector(chain.simulate(inputs._replace(cpps=cpps)), chain.process)

    return cqas


@eqx.filter_jit
def _values_and_jacobian(chain: PharmaChain, inputs: ChainInputs, with_parameters: bool, mode: str):
    if with_parameters:
        result = jacobian(cqa_function(chain), inputs, mode=mode, names=input_names(chain))
    else:
        result = jacobian(cpp_only(chain, inputs), inputs.cpps, mode=mode, names=chain.cpp_names)
    return result.values, result.matrix


_exported_values_and_jacobian = exported(_values_and_jacobian, name="pharma-jacobian", compiler_options=QUICK_COMPILE)
"""The chain's Jacobian programs, compiled with `snapo_ode.QUICK_COMPILE`: a cold first process
spends more on their compiles than on their runs (docs/architecture.md, Measurements behind the
design)."""
_exported_check = exported(_values_and_jacobian, name="pharma-jacobian-check", compiler_options=ONCE_COMPILE)
"""The same programs for a Jacobian a command computes once (a study's tight-tolerance
reference), compiled with `snapo_ode.ONCE_COMPILE`: half the compile, twice the run."""


def _program(once: bool):
    """The exported Jacobian program: for a Jacobian computed once (`_exported_check`), or not."""
    return _exported_check if once else _exported_values_and_jacobian


def jacobian_function(chain: PharmaChain, with_parameters: bool, mode: str, *, once: bool = False):
    """A jitted function of the inputs -> (CQAs (5,), Jacobian (5, n)), with the chain's adjoint
    set for `mode` ("reverse": 5 vmapped vjp passes; "forward": n vmapped jvp tangents). With
    `with_parameters=False`, n = 4 (the CPPs). One program per (scene, solver, mode, shapes) is
    shared by every caller in the process, and kept on disk traced (`snapo_ode.exported`) and
    compiled (the persistent compilation cache), so a second process does neither
    (`snapo_ode.call_checked`: a failed solve raises `SolverFailed` here, on the host). With
    `once`, a program for a Jacobian computed once (`_exported_check`)."""
    chain = chain.with_solver(chain.solver.replace(differentiation=mode))
    return lambda inputs: call_checked(_program(once), chain, inputs, with_parameters, mode,
                                       what="the chain's sensitivities")


def prefetch_jacobian(chain: PharmaChain, inputs: ChainInputs, with_parameters: bool, mode: str, *,
                      once: bool = False, elsewhere: bool = False) -> bool:
    """Prepare `jacobian_function(chain, with_parameters, mode, once=once)`'s program for `inputs` ahead of
    its call (`snapo_ode.prefetch_checked`: read in the background if on disk, else traced here,
    or with `elsewhere` in a helper process, and compiled in the background); whether it was on
    disk."""
    chain = chain.with_solver(chain.solver.replace(differentiation=mode))
    return prefetch_checked(_program(once), chain, inputs, with_parameters, mode, elsewhere=elsewhere)


def jacobians_function(chain: PharmaChain, with_parameters: bool, mode: str, mesh=None):
    """As `jacobian_function`, for many points at once: a function of a sequence of inputs ->
    a list of (CQAs (5,), Jacobian (5, n)) as NumPy arrays. Every point is dispatched before
    any result is read, so that JAX runs one while Python dispatches the next (faster than
    reading them one by one: docs/dev/pharma_notes.md, Measurements behind the design). With a samples `mesh`,
    the points go to this process's devices of it in turn; without, through the program on disk
    (`jacobian_function`). Not through `shard_map`: the reverse pass of equinox's checkpointed
    while loop refuses to run inside it ("Closure-converted function called with different
    dynamic arguments")."""
    chain = chain.with_solver(chain.solver.replace(differentiation=mode))
    devices = [None] if mesh is None else [d for d in mesh.devices.flat if d.process_index == jax.process_index()]

    program = _exported_values_and_jacobian if mesh is None else _values_and_jacobian

    def on_devices(points):
        return [program(chain, inputs if device is None else jax.device_put(inputs, device), with_parameters, mode)
                for inputs, device in zip(points, itertools.cycle(devices))]

    def evaluate_many(points):
        outputs = call_checked(on_devices, list(points), what="the chain's sensitivities")
        return [(np.asarray(values), np.asarray(matrix)) for values, matrix in outputs]

    return evaluate_many


def resolve_mode(mode: str, n_inputs: int, n_outputs: int = 5) -> str:
    """`mode`, or for "auto" the cheaper for a Jacobian of `n_outputs` x `n_inputs`."""
    return choose_mode(n_outputs, n_inputs) if mode == "auto" else mode


def named_jacobian(chain: PharmaChain, inputs: ChainInputs, values, matrix, mode: str) -> Jacobian:
    """A `snapo_ode.Jacobian` of the CQAs over every input, its rows and columns named; its arrays
    on the host (NumPy), so that picking columns compiles nothing (JAX's gathers did, at the end
    of a cold `snapo pharma sensitivities`: docs/pharma.md)."""
    _, rebuild = flatten_inputs(inputs)
    return Jacobian(np.asarray(values), np.asarray(matrix), mode, rebuild, tuple(input_names(chain)), chain.cqa_names)


def normalized(jac: Jacobian, inputs: ChainInputs, names) -> np.ndarray:
    """d ln CQA / d ln x for the inputs `names`, shape (5, len(names))."""
    scales = dict(zip(jac.input_names, input_scales(inputs), strict=True))
    return np.asarray(jac.columns(names)) * np.array([scales[name] for name in names]) / np.asarray(jac.values)[:, None]


def input_scales(inputs: ChainInputs) -> np.ndarray:
    """|x| of each flattened input (1 where x = 0: log-multipliers, temperature exponents): the
    factors that make d CQA / d x into d CQA / d ln x."""
    return bump_steps(flatten_inputs(inputs)[0], 1.0, step_floor=0.0)


@eqx.filter_jit
def _shifted_cqas(chain: PharmaChain, inputs: ChainInputs, shifts, mesh):
    flat, rebuild = flatten_inputs(inputs)

    def rows(chain, flat, shifts):
        evaluate = cqa_function(chain)
        return jax.vmap(lambda shift: evaluate(rebuild(flat + shift)))(shifts)

    return per_sample(rows, mesh, (spec(), spec(), spec(SAMPLES)))(chain, flat, shifts)


_exported_shifted_cqas = exported(_shifted_cqas, name="pharma-shifted-cqas")


def shifted_cqas(chain: PharmaChain, inputs: ChainInputs, shifts, mesh=None) -> np.ndarray:
    """The CQAs at the flattened inputs + each row of `shifts` (shape (m, n)), in one vmapped,
    cacheable call; shape (m, 5). With a samples `mesh` the rows split over its devices (padded
    with zero shifts to a multiple of the device count); without, the program is kept on disk for
    each shape of `shifts` (`snapo_ode.exported`). Raises `SolverFailed` if any solve failed."""
    program = _exported_shifted_cqas if mesh is None else _shifted_cqas
    out = call_checked(program, chain, inputs, placed_shifts(shifts, mesh), mesh, what="the shifted chains")
    return to_host(out)[:len(shifts)]


def placed_shifts(shifts, mesh=None) -> jax.Array:
    """`shifts` (m, n) as `shifted_cqas` runs them: with a samples `mesh`, padded with zero rows
    to a multiple of the device count and split over its devices."""
    shifts = np.asarray(shifts, dtype=float)
    if mesh is None:
        return jnp.asarray(shifts)
    padded = np.concatenate([shifts, np.zeros(((-len(shifts)) % mesh.size, shifts.shape[1]))])
    return jax.device_put(padded, NamedSharding(mesh, spec(SAMPLES)))
