"""Ideal reactors on Diffrax: batch at constant volume or pressure, and the CSTR, assembled from
named effects (energy balance, jacket, flow) and integrated with a stiff solver.

The state is scaled, [T / T0, N_k / N_total0] (N_k: amounts [kmol]), so one atol means the same
for the temperature and for every species.
"""

from collections.abc import Callable
from typing import Literal, NamedTuple

import diffrax
import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np

from snapo_ode import (
    BDF, EffectCatalogue, InputError, Rodas5, Scene, SolverSettings, check_choice, check_increasing, check_range)

from ._mechanism import Mechanism
from ._rate_laws import RateParameters
from ._units import GAS_CONSTANT
from ._types import Scalar, Vector


REACTOR_EFFECTS = EffectCatalogue(
    "reactor",
    effects={
        "energy": "energy balance: the temperature follows the heat of reaction (else isothermal)",
        "jacket": "heat exchange U A (T_jacket - T) with a jacket",
        "flow": "continuous stirred tank: feed in and product out at volume / residence_time",
    },
    requires={"jacket": ("energy",)},
)
ReactorKind = Literal["constant-volume", "constant-pressure"]


REACTOR_SOLVER = SolverSettings(atol=1e-11, solver=Rodas5(unroll_stages=True))
"""The reactors' default `snapo_ode.SolverSettings`: Rodas5 at rtol 1e-8 / atol 1e-11 on the
scaled state [T / T0, N_k / N_total0], 20,000 steps at most. Rodas5 rather than
Rodas4: on an h2o2 ignition it takes far fewer steps, runs faster and ends nearer the converged
temperature (docs/dev/chemistry_notes.md, Measurements behind the design). Its stages unrolled
(`unroll_stages`): reactors run in sweeps and benchmarks against Cantera, where the run counts,
and there the stage loop's reverse pass was the slower (the h2o2 gradient: docs/decisions.md,
Rosenbrock stages in a loop)."""


REACTOR_BDF_SOLVER = REACTOR_SOLVER.replace(solver=BDF())
"""The reactors' settings with `snapo_ode`'s BDF ("bdf") in place of Rodas5: a Newton iteration
that reuses its Jacobian and factorisation across steps (CVODES's design) instead of a Jacobian,
an LU and 8 evaluations a step. At the kinetics benchmark's rtol 1e-10 / atol 1e-14
(`snapo bench kinetics`) it runs h2o2 and gri30 ignitions faster than Rodas5, and their gradients
(one reverse pass, the corrector differentiated implicitly) by a larger factor, within the
tolerance's reach of the converged temperature but less close than Rodas5 (docs/dev/chemistry_notes.md,
Measurements behind the design): its error follows atol more than Rodas5's, so tighten atol with it. It saves at given
times only (no dense output, so not for `ignition_delay`);
`REACTOR_SOLVER` stays the default."""


TRIAL_TEMPERATURE_CEILING = 2.0
"""A trial state hotter than this many times the mechanism's hottest thermo fit
(`SpeciesThermo.max_temperature`: h2o2 5,000 K, gri30 6,000 K, so 10,000 and 12,000 K) rejects the step
(see `scaled_problem`): no reactor of the mechanism gets there, and far above the fits the rates
overflow."""


class Reactor(eqx.Module):
    """An ideal reactor of one mechanism.

    **Arguments:**
    - `mechanism`: the `Mechanism`.
    - `kind`: "constant-volume" or "constant-pressure" (an ideal-gas volume follows
      N R T / P; an ideal-condensed one sum_k N_k v_k).
    - `effects`: names from `REACTOR_EFFECTS` ("energy", "jacket", "flow"); default: none
      (an isothermal batch reactor).
    - `pressure` [Pa]: the constant pressure (constant-pressure reactors).
    - `heat_transfer` [W/K]: U A of the jacket; `jacket_temperature` [K].
    - `residence_time` [s], `feed_concentrations` [kmol/m^3] (shape `(n_species,)`),
      `feed_temperature` [K]: the flow (constant-volume only; the feed enthalpy enters the
      energy balance at the feed temperature).
    """

    mechanism: Mechanism
    scene: Scene = eqx.field(static=True)
    kind: str = eqx.field(static=True)
    pressure: Scalar
    heat_transfer: Scalar
    jacket_temperature: Scalar
    residence_time: Scalar
    feed_concentrations: Vector
    feed_temperature: Scalar

    def __init__(self, mechanism: Mechanism, kind: ReactorKind = "constant-volume", effects=(), *,
                 pressure=101325.0, heat_transfer=0.0, jacket_temperature=300.0, residence_time=1.0,
                 feed_concentrations=None, feed_temperature=300.0):
        check_choice("kind", kind, ("constant-volume", "constant-pressure"))
        self.mechanism = mechanism
        self.scene = REACTOR_EFFECTS.scene(effects)
        if self.scene.has("flow") and kind != "constant-volume":
            raise InputError("effect 'flow' (a CSTR) needs kind = 'constant-volume'.")
        if kind == "constant-volume" and mechanism.thermo_model != "ideal-gas" and self.scene.has("energy"):
            raise InputError("an ideal-condensed phase has no constant-volume energy balance here; "
                             "use kind = 'constant-pressure'.")
        self.kind = kind
        self.pressure = jnp.asarray(check_range("pressure", pressure, 0.0, low_open=True))
        self.heat_transfer = jnp.asarray(check_range("heat_transfer", heat_transfer, 0.0))
        self.jacket_temperature = jnp.asarray(check_range("jacket_temperature", jacket_temperature, 0.0, low_open=True))
        self.residence_time = jnp.asarray(check_range("residence_time", residence_time, 0.0, low_open=True))
        feed = np.zeros(mechanism.n_species) if feed_concentrations is None else feed_concentrations
        self.feed_concentrations = jnp.asarray(check_range("feed_concentrations", feed, 0.0))
        if self.feed_concentrations.shape != (mechanism.n_species,):
            raise InputError(f"feed_concentrations has shape {self.feed_concentrations.shape}; "
                             f"expected ({mechanism.n_species},), one per species.")
        self.feed_temperature = jnp.asarray(check_range("feed_temperature", feed_temperature, 0.0, low_open=True))

    def volume(self, temperature, amounts, initial_volume):
        """The volume [m^3] at `temperature` [K] and `amounts` [kmol], shape `(n_species,)`."""
        if self.kind == "constant-volume":
            return initial_volume
        if self.mechanism.thermo_model == "ideal-gas":
            return jnp.sum(amounts) * GAS_CONSTANT * temperature / self.pressure
        return amounts @ self.mechanism.molar_volumes

    def time_derivatives(self, temperature, amounts, initial_volume, parameters: RateParameters):
        """d T/dt [K/s] and d N_k/dt [kmol/s] (shape `(n_species,)`)."""
        volume = self.volume(temperature, amounts, initial_volume)
        concentrations = amounts / volume
        production = self.mechanism.net_production_rates(temperature, concentrations, parameters) * volume
        flow = volume / self.residence_time if self.scene.has("flow") else None
        d_amounts = production if flow is None else production + flow * (self.feed_concentrations - concentrations)
        if not self.scene.has("energy"):
            return jnp.zeros_like(temperature), d_amounts
        thermo = self.mechanism.thermo
        enthalpy = thermo.h_rt(temperature) * GAS_CONSTANT * temperature  # [J/kmol]
        heat_capacity = thermo.cp_r(temperature) * GAS_CONSTANT  # [J/kmol/K]
        if self.kind == "constant-volume" and self.mechanism.thermo_model == "ideal-gas":
            enthalpy = enthalpy - GAS_CONSTANT * temperature  # internal energies
            heat_capacity = heat_capacity - GAS_CONSTANT
        heat = -(enthalpy @ production)  # [W]
        if self.scene.has("jacket"):
            heat = heat + self.heat_transfer * (self.jacket_temperature - temperature)
        if flow is not None:
            # The outflow carries enthalpy h; the balance is on the internal energy u (= enthalpy
            # here), so in (h_feed - u) - out (h - u): the outflow's flow work for a gas.
            feed_enthalpy = thermo.h_rt(self.feed_temperature) * GAS_CONSTANT * self.feed_temperature
            heat = heat + flow * (self.feed_concentrations @ (feed_enthalpy - enthalpy))
            if self.mechanism.thermo_model == "ideal-gas":
                heat = heat - flow * jnp.sum(concentrations) * GAS_CONSTANT * temperature
        return heat / (amounts @ heat_capacity), d_amounts


def _check_initial_state(mechanism: Mechanism, temperature, concentrations, times, volume):
    if jnp.shape(concentrations) != (mechanism.n_species,):
        raise InputError(f"concentrations has shape {jnp.shape(concentrations)}; expected "
                         f"({mechanism.n_species},), one per species.")
    if jnp.ndim(times) != 1 or jnp.size(times) < 2:
        raise InputError(f"times has shape {jnp.shape(times)}; expected (n_t,) with n_t >= 2.")
    concrete = {name: value for name, value in [("temperature", temperature), ("concentrations", concentrations),
                                                ("times", times), ("volume", volume)]
                if not isinstance(value, jax.core.Tracer)}
    bounds = {"temperature": (0.0, True), "concentrations": (0.0, False), "times": (0.0, False), "volume": (0.0, True)}
    for name, value in concrete.items():
        low, open_ = bounds[name]
        check_range(name, value, low, low_open=open_)
    if "times" in concrete:
        check_increasing("times", times)


class Trajectory(NamedTuple):
    """A reactor solve: `times` [s] (shape `(n_t,)`), `temperature` [K] (shape `(n_t,)`),
    `amounts` [kmol] and `concentrations` [kmol/m^3] (shape `(n_t, n_species)`), `volume`
    [m^3] (shape `(n_t,)`), and the `diffrax.Solution` (its `stats`, and dense output when asked)."""

    times: jax.Array
    temperature: jax.Array
    amounts: jax.Array
    concentrations: jax.Array
    volume: jax.Array
    solution: diffrax.Solution


class ScaledProblem(NamedTuple):
    """The reactor's ODE on the scaled state [T / T0, N_k / N_total0] (without the energy
    effect, [N_k / N_total0]): `vector_field(t, state, args)`, its closed-form `jacobian(t, state,
    args)` (None without energy: differentiate the field), the initial `state0`, and the scales
    `temperature` T0 [K] and `amount_scale` N_total0 [kmol]."""

    vector_field: Callable
    jacobian: Callable | None
    state0: jax.Array
    temperature: jax.Array
    amount_scale: jax.Array


def scaled_problem(reactor: Reactor, temperature, concentrations, volume=1.0,
                   parameters: RateParameters | None = None) -> ScaledProblem:
    """The scaled ODE that `simulate` integrates (any solver can integrate it: SciPy's in the
    accuracy benchmark), from `temperature` [K] and `concentrations` [kmol/m^3] in `volume` [m^3]."""
    mechanism = reactor.mechanism
    parameters = mechanism.parameters if parameters is None else parameters
    temperature = jnp.asarray(temperature, float)
    amounts0 = jnp.asarray(concentrations, float) * volume
    amount_scale = jnp.sum(amounts0)
    energy = reactor.scene.has("energy")
    n_scaled = amounts0 / amount_scale
    state0 = jnp.concatenate([jnp.ones(1), n_scaled]) if energy else n_scaled

    def energy_field(t_scaled, n_scaled):
        d_t, d_n = reactor.time_derivatives(t_scaled * temperature, n_scaled * amount_scale, volume, parameters)
        return jnp.concatenate([(d_t / temperature)[None], d_n / amount_scale])

    def field(state):
        if energy:
            return energy_field(state[0], state[1:])
        _, d_n = reactor.time_derivatives(temperature, state * amount_scale, volume, parameters)
        return d_n / amount_scale

    ceiling = TRIAL_TEMPERATURE_CEILING * mechanism.thermo.max_temperature / temperature  # scaled

    def vector_field(t, state, args):
        # A trial step that overshoots (it is rejected afterwards) can reach a state without
        # meaning: T <= 0 (log T is NaN), T far above the thermo fits (the rates or equilibrium
        # constants overflow to inf) or NaN from an earlier stage. There the field is NaN, which
        # rejects the step, and it is evaluated at the initial state, so that the reverse pass
        # through the rejected step meets no 0 * NaN or 0 * inf (without it, Rodas5's first trial
        # step of a gri30 ignition, the whole interval, made every gradient NaN, and trial states
        # far above the fits made gradients of a batch NaN: docs/chemistry.md, On a GPU).
        valid = jnp.isfinite(jnp.sum(state))
        if energy:
            valid = valid & (state[0] > 0.0) & (state[0] < ceiling)
        return jnp.where(valid, field(jnp.where(valid, state, state0)), jnp.nan)

    def energy_jacobian(t, state, args):
        """d(vector_field)/d(state): one tangent for the temperature, one per amount."""
        t_scaled, n_scaled = state[0], state[1:]
        by_temperature = jax.jvp(lambda x: energy_field(x, n_scaled), (t_scaled,), (jnp.ones_like(t_scaled),))[1]
        by_amounts = jax.jacfwd(lambda n: energy_field(t_scaled, n))(n_scaled)
        return jnp.concatenate([by_temperature[:, None], by_amounts], axis=1)

    return ScaledProblem(vector_field, energy_jacobian if energy else None, state0, temperature, amount_scale)


def simulate(reactor: Reactor, temperature, concentrations, times, *, volume=1.0,
             parameters: RateParameters | None = None, settings: SolverSettings = REACTOR_SOLVER,
             dense: bool = False) -> Trajectory:
    """Integrate `reactor` from `temperature` [K] and `concentrations` [kmol/m^3] (shape
    `(n_species,)`) in `volume` [m^3], saving at `times` [s] (shape `(n_t,)`, from t = 0).

    **Arguments:** `parameters` (default: the mechanism's) are what gradients flow into;
    `settings` picks the solver and tolerances; `dense` keeps the dense output (for
    `ignition_delay`).

    **Raises:** `InputError` for a wrong shape, and, where the inputs are concrete (not traced),
    for a non-positive temperature, negative concentrations or times that do not increase from
    t >= 0; inside jit, an error with advice if the solve fails (max_steps, step collapse).
    """
    _check_initial_state(reactor.mechanism, temperature, concentrations, times, volume)
    problem = scaled_problem(reactor, temperature, concentrations, volume, parameters)
    energy = reactor.scene.has("energy")
    temperature, amount_scale = problem.temperature, problem.amount_scale
    times = jnp.asarray(times, float)
    solution = settings.solve(problem.vector_field, 0.0, times[-1], problem.state0,
                              saveat=diffrax.SaveAt(ts=times, dense=dense), jacobian=problem.jacobian)
    ys = solution.ys
    temperatures = ys[:, 0] * temperature if energy else jnp.full(times.shape, temperature)
    amounts = (ys[:, 1:] if energy else ys) * amount_scale
    volumes = jax.vmap(lambda t, n: reactor.volume(t, n, volume))(temperatures, amounts)
    return Trajectory(times, temperatures, amounts, amounts / volumes[:, None], volumes, solution)
