"""The kinetic experiments as one differentiable function of the fitted parameters: every
experiment an isothermal batch of its reactor's liquid (`LiquidBatch`, the chain's own physics)
from its charges, sampled at the data's times, all experiments in one `vmap`.

Fitted coordinates (`FittedParameters`): a reaction whose rate constant and activation energy are
both fitted is written as ln k at the reference temperature T_ref and its activation temperature,
so the pair decorrelates (1/T_ref is the mean of the experiments' 1/T): internally `ln_k_ref`
(the shift of ln k(T_ref) from the mechanism's) and `d = (T_a - T_a0) / T_ref`, both O(1), and
log_multiplier = ln_k_ref + d, T_a = T_a0 + d T_ref. A reaction with its rate alone is fitted as
its log_multiplier.
"""

from typing import NamedTuple

import diffrax
import jax
import jax.numpy as jnp
import numpy as np

from chemistry import GAS_CONSTANT
from snapo_ode import InputError, SolverSettings

from ._chain import PharmaChain
from ._experiments import LabData
from ._liquid import LiquidBatch
from ._profiles import ConstantTemperature


class FittedParameters(NamedTuple):
    """What a fit estimates: `reactions` (equation per fitted reaction, in the mechanism's order),
    `with_activation` (bool per reaction: its activation energy fitted too), `reference_temperature`
    [K]. `names()` are the coordinates' names, `to_rates` maps them to the mechanism's rates."""

    reactions: tuple[str, ...]
    with_activation: tuple[bool, ...]
    reference_temperature: float

    def names(self) -> list[str]:
        """The internal coordinates' names: ln_k_ref[eq] (or log_multiplier[eq]), then
        activation_shift[eq] for each reaction with its activation fitted."""
        names = [f"{'ln_k_ref' if a else 'log_multiplier'}[{eq}]"
                 for eq, a in zip(self.reactions, self.with_activation, strict=True)]
        return names + [f"activation_shift[{eq}]" for eq, a in zip(self.reactions, self.with_activation) if a]

    def to_rates(self, theta, rates, equations: tuple[str, ...]):
        """The mechanism's `rates` (`RateParameters`, all reactions, `equations` their order) with
        the fitted reactions' log_multiplier and activation_temperature set from `theta`."""
        n = len(self.reactions)
        log_multiplier, activation = rates.log_multiplier, rates.activation_temperature
        shifts = iter(range(n, len(self.names())))
        for k, (equation, fitted_activation) in enumerate(zip(self.reactions, self.with_activation, strict=True)):
            j = equations.index(equation)
            d = theta[next(shifts)] if fitted_activation else 0.0
            log_multiplier = log_multiplier.at[j].add(theta[k] + d)
            activation = activation.at[j].add(d * self.reference_temperature)
        return type(rates)(log_multiplier, rates.temperature_exponent, activation)

    def physical(self, theta: np.ndarray, covariance: np.ndarray, base_activation: np.ndarray):
        """The estimates and covariance in the reported units: ln_k_ref / log_multiplier [-] as
        fitted, E_a [kJ/mol] = R (T_a0 + d T_ref); returns (names, values, covariance)."""
        names, scale = self.names(), np.ones(len(theta))
        offset = np.zeros(len(theta))
        for k, eq in enumerate(names):
            if eq.startswith("activation_shift["):
                reaction = eq[len("activation_shift["):-1]
                scale[k] = GAS_CONSTANT * self.reference_temperature * 1e-6
                offset[k] = GAS_CONSTANT * base_activation[self.reactions.index(reaction)] * 1e-6
                names[k] = f"E_a[{reaction}]"
        return names, offset + scale * np.asarray(theta), covariance * np.outer(scale, scale)


def fitted_parameters(chain: PharmaChain, data: LabData, names: list[str] | None = None) -> FittedParameters:
    """The coordinates to fit: `names` (log_multiplier[eq] and/or activation_temperature[eq], or
    E_a[eq]), else every log_multiplier of the process's `uncertain` list among the reactions the
    experiments run, each with its activation energy when the experiments span two temperatures.

    **Raises:** `InputError` for a name that is no reaction's rate parameter or a reaction the
    scene leaves out."""
    equations = chain.mechanism.reaction_equations
    active = {equations[k] for k in chain.active_reactions}
    temperatures = np.array([e.temperature for e in data.experiments])
    several = np.ptp(temperatures) > 1.0
    if names:
        rate, activation = [], set()
        for name in names:
            field, _, rest = name.partition("[")
            equation = rest[:-1] if rest.endswith("]") else None
            if field not in ("log_multiplier", "activation_temperature", "E_a") or equation not in equations:
                raise InputError(f"--fit {name!r}: no such parameter; allowed: log_multiplier[EQ], "
                                 f"activation_temperature[EQ] or E_a[EQ] of a reaction: {', '.join(equations)}.")
            if equation not in active:
                raise InputError(f"--fit {name!r}: the reaction is left out of the scene (--without).")
            if field == "log_multiplier":
                rate.append(equation)
            else:
                activation.add(equation)
        missing = sorted(activation - set(rate))
        if missing:
            raise InputError(f"--fit: the activation energy of {missing[0]} is fitted with its rate constant; add "
                             f"log_multiplier[{missing[0]}].")
        chosen = [eq for eq in equations if eq in rate]
        with_activation = tuple(eq in activation for eq in chosen)
    else:
        chosen = [eq for eq in equations if f"log_multiplier[{eq}]" in chain.process.uncertain and eq in active]
        if not chosen:
            raise InputError("the process's uncertain list names no rate constant of an active reaction; name the "
                             "parameters to fit with --fit log_multiplier[EQ].")
        with_activation = (bool(several),) * len(chosen)
    reference = float(1.0 / np.mean(1.0 / temperatures))
    return FittedParameters(tuple(chosen), with_activation, reference)


class ExperimentModel(NamedTuple):
    """The batched simulation of every experiment (`predict(theta)` -> the model's value of each
    measurement [kmol/m^3], in the data's row order)."""

    chain: PharmaChain
    fitted: FittedParameters
    temperatures: np.ndarray  # (n_experiments,) [K]
    initial: np.ndarray  # (n_experiments, n_species) [kmol/m^3]
    durations: np.ndarray  # (n_experiments,) [s]
    slots: np.ndarray  # (n_experiments, n_times) normalised sample times in [0, 1]
    rows: tuple[np.ndarray, np.ndarray, np.ndarray]  # per measurement: experiment, slot, species index
    solver: SolverSettings

    def concentrations(self, theta):
        """(n_experiments, n_times, n_species) concentrations [kmol/m^3] at the sample slots."""
        inputs = self.chain.inputs(self.chain.cpps())
        mechanism, active = self.chain.active(inputs)
        rates = self.fitted.to_rates(theta, inputs.rates, self.chain.mechanism.reaction_equations)
        keep = np.asarray(self.chain.active_reactions)
        rates = jax.tree.map(lambda a: a[keep], rates)
        batch = LiquidBatch(mechanism, False)

        def one(temperature, amounts, duration, slots):
            solution = self.solver.solve(batch.rhs, 0.0, 1.0, amounts, (rates, ConstantTemperature(temperature),
                                                                       duration, 0.0), saveat=diffrax.SaveAt(ts=slots))
            states = solution.ys
            return states / (states @ mechanism.molar_volumes)[:, None]

        return jax.vmap(one)(jnp.asarray(self.temperatures), jnp.asarray(self.initial), jnp.asarray(self.durations),
                             jnp.asarray(self.slots))

    def predict(self, theta):
        experiment, slot, species = self.rows
        return self.concentrations(theta)[experiment, slot, species]


def experiment_model(chain: PharmaChain, data: LabData, fitted: FittedParameters,
                     differentiation: str = "forward") -> ExperimentModel:
    """The `ExperimentModel` of `data` on `chain` (its solver's method and tolerances; forward-mode
    differentiation, the Jacobian of few parameters and many measurements)."""
    volumes = np.asarray(chain.mechanism.molar_volumes)
    solvent = chain.roles.solvent
    n_species = chain.mechanism.n_species
    initial = np.zeros((len(data.experiments), n_species))
    for e, experiment in enumerate(data.experiments):
        for name, amount in experiment.charges.items():
            initial[e, chain.species_index(name)] = amount
        filled = initial[e] @ volumes - initial[e, solvent] * volumes[solvent]
        if filled >= 1.0:
            raise InputError(f"experiment {experiment.name!r}: the charges fill {filled:.3g} of the volume; allowed: < 1.")
        initial[e, solvent] = (1.0 - filled) / volumes[solvent]
    m = data.measurements
    times_by_experiment = [np.unique(m.time[m.experiment == e]) for e in range(len(data.experiments))]
    width = max(len(t) for t in times_by_experiment)
    durations = np.array([max(t[-1], 1e-3) for t in times_by_experiment]) * 60.0
    slots = np.stack([np.pad(t / t[-1] if t[-1] > 0 else t, (0, width - len(t)), mode="edge")
                      for t in times_by_experiment])
    slot = np.array([np.searchsorted(times_by_experiment[e], t) for e, t in zip(m.experiment, m.time)])
    species = np.array([chain.species_index(name) for name in m.species])
    s = chain.solver
    solver = SolverSettings(rtol=s.rtol, atol=s.atol, solver=s.solver, max_steps=s.max_steps,
                            differentiation=differentiation)
    return ExperimentModel(chain, fitted, np.array([e.temperature for e in data.experiments]), initial, durations,
                           slots, (m.experiment, slot, species), solver)
