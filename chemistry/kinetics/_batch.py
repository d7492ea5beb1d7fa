"""Batched constant-volume adiabatic ignitions: many initial conditions (temperature, pressure,
composition) and rate-multiplier sets solved in one program, `jax.vmap` of the single solve, for
values (the temperature at a time, the ignition delay) and each reactor's d ln T / d ln A_i (a
reverse pass per reactor, vmapped).

Each reactor keeps its own adaptive step: under `jax.vmap`, Diffrax's while loop runs until the
slowest reactor of the group has finished (the others' steps are computed and discarded), so a
batch costs about (its largest step count) x (its size) single steps. `group_size` solves the
batch in groups of that many (`jax.lax.map(..., batch_size=group_size)`): conditions sorted by
expected difficulty then waste less (`IgnitionBatch.sorted_by`), on a CPU, where batching does
not amortise much: a vmapped step costs about N single steps (`snapo bench kinetics --batch 256`;
docs/chemistry.md, "Batched solves"). On a GPU it does, and one vmap is the setting there (groups
run one after the other; docs/chemistry.md, "On a GPU").

The reverse passes are vmapped too since the Rosenbrock solvers step a finished reactor (h = 0 in
the loop's discarded steps) by one ulp instead of forming I / (gamma h) = inf: before, every
gradient of a reactor that finished before the slowest was NaN, and the gradients ran one reactor
at a time. Now one vmap is the faster, and agrees with one reactor at a time to round-off through
the ignition (docs/chemistry.md, "Batched solves")."""

from collections.abc import Callable, Mapping, Sequence
from typing import NamedTuple

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np

from snapo_ode import (
    InputError, SolverSettings, call_checked, check_count, check_increasing, check_range, check_scalar)

from ._ignition import IGNITION_RISE, late_ignition, trajectory_and_delay
from ._mechanism import Mechanism
from ._reactor import REACTOR_SOLVER, Reactor
from ._sensitivities import temperature_at, with_multipliers
from ._types import Matrix, Vector
from ._units import GAS_CONSTANT

Composition = str | Mapping[str, float] | Sequence[float] | np.ndarray
"""Mole ratios: Cantera's "CH4:1,O2:2" string, a {species: ratio} mapping, or an array of shape
`(n_species,)`."""


def mole_ratios(mechanism: Mechanism, composition: Composition) -> np.ndarray:
    """`composition` as an array of mole ratios, shape `(n_species,)` (not normalised).

    **Raises:** `InputError` for an unknown species or a malformed "name:ratio" entry."""
    if isinstance(composition, str):
        entries = [item.split(":") for item in composition.replace(" ", "").split(",") if item]
        try:
            composition = {name: float(ratio) for name, ratio in entries}
        except ValueError:  # a ratio that is no number, or an entry without exactly one ":"
            raise InputError(f"composition = {composition!r} is not of the form 'A:1,B:2' (species:ratio).") from None
    if isinstance(composition, Mapping):
        ratios = np.zeros(mechanism.n_species)
        for name, ratio in composition.items():
            ratios[mechanism.species_index(name)] += ratio
        return ratios
    return np.asarray(composition, dtype=float)


class IgnitionBatch(eqx.Module):
    """N constant-volume adiabatic reactors of one mechanism, each from its own state.

    **Arguments** (each either one value for every reactor or one per reactor; those given per
    reactor must agree on N):
    - `mechanism`: the `Mechanism` (for the species and reaction counts; not stored).
    - `temperature` [K]: shape `()` or `(N,)`, > 0.
    - `pressure` [Pa]: shape `()` or `(N,)`, > 0.
    - `composition`: mole ratios (`Composition`), or a list of N of them, or an array of shape
      `(N, n_species)`; >= 0 with a positive sum (normalised here).
    - `log_multiplier`: ln of the rate multipliers, shape `(n_reactions,)` or `(N,
      n_reactions)`; default 0 (the file's rates).

    **Fields:** `temperature`, `pressure` (shape `(N,)`), `mole_fractions` (`(N, n_species)`),
    `log_multiplier` (`(N, n_reactions)`).

    **Raises:** `InputError` naming the field, its value and the allowed range or shape, before
    anything compiles.
    """

    temperature: Vector
    pressure: Vector
    mole_fractions: Matrix
    log_multiplier: Matrix

    def __init__(self, mechanism: Mechanism, temperature, pressure, composition, log_multiplier=None):
        temperature = check_range("temperature", temperature, 0.0, low_open=True)
        pressure = check_range("pressure", pressure, 0.0, low_open=True)
        if isinstance(composition, (list, tuple)) and composition and not isinstance(composition[0], (int, float)):
            composition = np.stack([mole_ratios(mechanism, c) for c in composition])
        ratios = check_range("composition", mole_ratios(mechanism, composition), 0.0)
        multiplier = check_range("log_multiplier", np.zeros(mechanism.n_reactions) if log_multiplier is None
                                 else log_multiplier)
        fields = {"temperature": (temperature, ()), "pressure": (pressure, ()),
                  "composition": (ratios, (mechanism.n_species,)),
                  "log_multiplier": (multiplier, (mechanism.n_reactions,))}
        size = _batch_size(fields)
        totals = ratios.sum(axis=-1)
        if np.any(totals <= 0.0):
            raise InputError(f"composition sums to {np.min(totals):g}; the mole ratios must have a positive sum.")
        self.temperature = jnp.asarray(np.broadcast_to(temperature, (size,)))
        self.pressure = jnp.asarray(np.broadcast_to(pressure, (size,)))
        self.mole_fractions = jnp.asarray(np.broadcast_to(ratios / totals[..., None], (size, mechanism.n_species)))
        self.log_multiplier = jnp.asarray(np.broadcast_to(multiplier, (size, mechanism.n_reactions)))

    @property
    def size(self) -> int:
        """N, the number of reactors."""
        return self.temperature.shape[0]

    @property
    def concentrations(self) -> Matrix:
        """Molar concentrations [kmol/m^3], shape `(N, n_species)`: X_k P / (R T), the ideal gas."""
        return self.mole_fractions * (self.pressure / (GAS_CONSTANT * self.temperature))[:, None]

    def sorted_by(self, key) -> tuple["IgnitionBatch", np.ndarray]:
        """The batch reordered by ascending `key` (shape `(N,)`), and the order (indices into this
        batch): grouping alike conditions wastes fewer masked steps (see the module docstring)."""
        order = np.argsort(np.asarray(key), kind="stable")
        return jax.tree.map(lambda x: x[order], self), order


def _batch_size(fields: dict) -> int:
    sizes = {}
    for name, (value, single) in fields.items():
        if value.shape == single:
            continue
        if value.ndim != len(single) + 1 or value.shape[1:] != single:
            per_reactor = "(N" + "".join(f", {d}" for d in single) + ("" if single else ",") + ")"
            raise InputError(f"{name} has shape {value.shape}; expected {single} (one for every reactor) or "
                             f"{per_reactor} (one per reactor).")
        sizes[name] = value.shape[0]
    if len(set(sizes.values())) > 1:
        described = ", ".join(f"{name} {n}" for name, n in sizes.items())
        raise InputError(f"the batched fields disagree on the number of reactors ({described}); give each the "
                         f"same N, or one value for every reactor.")
    size = next(iter(sizes.values()), 1)
    return check_count("N (reactors)", size, 1)


def _check(mechanism: Mechanism, batch: IgnitionBatch, group_size: int | None):
    if batch.mole_fractions.shape[1:] != (mechanism.n_species,) or \
            batch.log_multiplier.shape[1:] != (mechanism.n_reactions,):
        raise InputError(f"the batch has {batch.mole_fractions.shape[1]} species and {batch.log_multiplier.shape[1]} "
                         f"reactions; the mechanism {mechanism.n_species} and {mechanism.n_reactions}: build it "
                         f"with this mechanism.")
    if group_size is not None:
        check_count("group_size", group_size, 1)


def _over_reactors(fn: Callable, arrays: tuple, group_size: int | None):
    """`fn` over the leading axis of every array in `arrays`: one `vmap`, or groups of
    `group_size` one after the other."""
    if group_size is None or group_size >= arrays[0].shape[0]:
        return jax.vmap(fn)(*arrays)
    return jax.lax.map(lambda row: fn(*row), arrays, batch_size=group_size)


def final_temperature_batch(mechanism: Mechanism, batch: IgnitionBatch, time: float, *,
                            settings: SolverSettings = REACTOR_SOLVER, group_size: int | None = None) -> Vector:
    """T(`time`) [K] of every reactor of `batch`, shape `(N,)`: `chemistry.temperature_at` per
    reactor, vmapped (in groups of `group_size`, see the module docstring). **Raises:**
    `SolverFailed` with advice if a reactor's solve fails."""
    return call_checked(temperature_program, mechanism, batch, _checked_time(mechanism, batch, time, group_size),
                        settings, group_size, gradient=False, what="the batch's ignitions")


def temperature_sensitivities_batch(mechanism: Mechanism, batch: IgnitionBatch, time: float, *,
                                    settings: SolverSettings = REACTOR_SOLVER, group_size: int | None = None):
    """d ln T(`time`) / d ln A_i of every reactor, shape `(N, n_reactions)`, at the batch's
    multipliers, from one reverse pass per reactor, vmapped (in groups of `group_size`; 1: one
    reactor at a time), and T(`time`) [K], shape `(N,)`. **Raises:** `SolverFailed` with advice
    if a reactor's solve or reverse pass fails."""
    return call_checked(temperature_program, mechanism, batch, _checked_time(mechanism, batch, time, group_size),
                        settings, group_size, gradient=True, what="the batch's sensitivities")


def _checked_time(mechanism, batch, time, group_size):
    _check(mechanism, batch, group_size)
    return jnp.asarray(check_scalar("time", time, 0.0, low_open=True))


@eqx.filter_jit
def temperature_program(mechanism, batch, time, settings, group_size, gradient: bool):
    """The program of `final_temperature_batch` (`gradient` False) and of
    `temperature_sensitivities_batch` (True), unchecked: the bench compiles it ahead of time."""
    def one(log_multiplier, temperature, concentrations):
        def at(log_multiplier):
            return temperature_at(log_multiplier, mechanism, temperature, concentrations, time, settings)

        if not gradient:
            return at(log_multiplier)
        value, derivative = jax.value_and_grad(at)(log_multiplier)
        return derivative / value, value

    return _over_reactors(one, (batch.log_multiplier, batch.temperature, batch.concentrations), group_size)


class IgnitionBatchResult(NamedTuple):
    """N ignition runs: `times` [s] (shape `(n_t,)`), `temperature` [K] (shape `(N, n_t)`), the
    ignition `delay` [s] (shape `(N,)`) and each reactor's accepted `steps` (shape `(N,)`)."""

    times: np.ndarray
    temperature: np.ndarray
    delay: np.ndarray
    steps: np.ndarray


def solve_ignition_batch(mechanism: Mechanism, batch: IgnitionBatch, times, *,
                         settings: SolverSettings = REACTOR_SOLVER, rise: float = IGNITION_RISE,
                         group_size: int | None = None) -> IgnitionBatchResult:
    """Every reactor of `batch` saved at `times` [s] (shape `(n_t,)`, from 0, increasing) and its
    ignition delay (the first time T reaches T0 + `rise` [K], as `chemistry.solve_ignition`).

    **Raises:** `InputError` for bad `times` or `rise`; `SolverFailed` with advice if a
    reactor's solve fails or it does not ignite before the last time."""
    _check(mechanism, batch, group_size)
    times = check_range("times", times, 0.0)
    if times.ndim != 1 or times.size < 2:
        raise InputError(f"times has shape {times.shape}; expected (n_t,) with n_t >= 2.")
    check_increasing("times", times)
    rise = check_scalar("rise", rise, 0.0, low_open=True)
    temperature, delay, steps = call_checked(ignition_program, mechanism, batch, jnp.asarray(times), settings, rise,
                                             group_size, what="the batch's ignitions",
                                             causes=(late_ignition(times, rise),))
    return IgnitionBatchResult(times, np.asarray(temperature), np.asarray(delay), np.asarray(steps))


@eqx.filter_jit
def ignition_program(mechanism, batch, times, settings, rise, group_size):
    """The program of `solve_ignition_batch`, unchecked."""
    reactor = Reactor(mechanism, "constant-volume", ("energy",))

    def one(log_multiplier, temperature, concentrations):
        trajectory, delay = trajectory_and_delay(reactor, temperature, concentrations, times, settings, rise,
                                                 with_multipliers(mechanism, log_multiplier))
        return trajectory.temperature, delay, trajectory.solution.stats["num_accepted_steps"]

    return _over_reactors(one, (batch.log_multiplier, batch.temperature, batch.concentrations), group_size)
