"""Neural temperature profiles: an MLP jacket profile for R1 and an MLP deviation from the linear
cooling ramp of the crystallizer, trained to maximise the API yield with the CQA specs as smooth
penalties, then evaluated with hard spec checks."""

import dataclasses

import equinox as eqx
import jax
import jax.numpy as jnp

from snapo_ode import InputError, MLPPolicy, Result, call_checked, field, train

from ._chain import PharmaChain
from ._cqa import cqa_dict, cqa_vector, meets_specs, spec_margins, spec_penalty
from ._parameters import CPPs, PhysicalParameters
from ._profiles import AbstractTemperatureProfile, NeuralTemperature


class NeuralCooling(AbstractTemperatureProfile):
    """T(s) = start + (end - start) s + 4 s (1 - s) `amplitude` tanh(MLP(s)) [K]: the linear
    ramp's end points are kept (not trained), the path between them is learned (within
    +-`amplitude`)."""

    policy: MLPPolicy
    start: jax.Array
    end: jax.Array
    amplitude: float = eqx.field(static=True)

    def __call__(self, s):
        deviation = jnp.tanh(self.policy(jnp.reshape(s, (1,)))[0])
        start, end = jax.lax.stop_gradient(self.start), jax.lax.stop_gradient(self.end)
        return start + (end - start) * s + 4 * s * (1 - s) * self.amplitude * deviation


class Profiles(eqx.Module):
    """The trainable profiles: `r1_jacket` (`NeuralTemperature` within the proven acceptable range
    of the temperature of `jacket_unit`, the first plug-flow or batch reactor whose temperature is
    a CPP) and `cooling` (`NeuralCooling` of `cooling_unit`, a cooling crystallizer; None
    without one)."""

    r1_jacket: NeuralTemperature
    cooling: NeuralCooling | None
    jacket_unit: str = eqx.field(static=True)
    cooling_unit: str | None = eqx.field(static=True)

    def by_unit(self) -> dict:
        """unit name -> profile, as `PharmaChain.simulate` takes them."""
        return {self.jacket_unit: self.r1_jacket, **({} if self.cooling is None else {self.cooling_unit: self.cooling})}


def make_profiles(chain: PharmaChain, cpps: CPPs, physical: PhysicalParameters, *, key, width: int = 16,
                  amplitude: float = 5.0) -> Profiles:
    """The profiles at their start: the jacket within the PAR of the CPP that sets the first
    plug-flow or batch reactor's temperature, the cooling (where the process has a cooling
    crystallizer) between its inlet temperature (the unit before it) and its final temperature.

    **Raises:** `InputError` for a process without a plug-flow or batch reactor whose temperature
    is a CPP."""
    units, ranges = chain.process.units, {r.target: r for r in chain.cpp_ranges}
    reactor = next((u.name for u in units if u.type in ("plug_flow_reactor", "batch_reactor")
                    and f"{u.name}.temperature" in ranges), None)
    if reactor is None:
        raise InputError(f"process {chain.process.name!r}: training needs a plug_flow_reactor or batch_reactor whose "
                         "temperature is a CPP (its jacket profile is what is trained).")
    r1 = ranges[f"{reactor}.temperature"]
    r1_key, cooling_key = jax.random.split(key)
    jacket = NeuralTemperature(MLPPolicy(1, 1, key=r1_key, width=width, depth=2, action_low=r1.par[0],
                                         action_high=r1.par[1], feature_offset=0.5, feature_scale=0.5))
    crystallizer = next((k for k, u in enumerate(units) if u.type == "cooling_crystallizer"), None)
    if crystallizer is None:
        return Profiles(jacket, None, reactor, None)
    parameters = chain.unit_parameters(chain.inputs(cpps, physical=physical))
    start = parameters[units[crystallizer - 1].name]["temperature"]
    cooling = NeuralCooling(MLPPolicy(1, 1, key=cooling_key, width=width, depth=2, feature_offset=0.5,
                                      feature_scale=0.5), start, parameters[units[crystallizer].name]["final_temperature"],
                            amplitude)
    return Profiles(jacket, cooling, reactor, units[crystallizer].name)


def profile_objective(chain: PharmaChain, cpps: CPPs, physical: PhysicalParameters, *, penalty_weight: float,
                      sharpness: float):
    """profiles -> (loss, metrics): loss = -yield / 100 + penalty_weight * smooth spec penalty."""

    def loss(profiles: Profiles):
        result = chain.simulate(chain.inputs(cpps, physical=physical), profiles=profiles.by_unit())
        cqas = cqa_vector(result, chain.process)
        penalty = spec_penalty(cqas, sharpness, chain.process)
        return -result.api_yield / 100 + penalty_weight * penalty, {"value": result.api_yield, "penalty": penalty}

    return loss


def constant_profiles(profiles: Profiles) -> Profiles:
    """The baseline as the same structure: last layers zeroed, so the R1 jacket sits at the middle
    of its PAR (for the built-in, the nominal r1_temperature) and the cooling is the linear ramp,
    exactly."""

    def zero_last(policy: MLPPolicy) -> MLPPolicy:
        last = policy.mlp.layers[-1]
        return eqx.tree_at(lambda p: (p.mlp.layers[-1].weight, p.mlp.layers[-1].bias), policy,
                           (jnp.zeros_like(last.weight), jnp.zeros_like(last.bias)))

    profiles = eqx.tree_at(lambda p: p.r1_jacket.policy, profiles, zero_last(profiles.r1_jacket.policy))
    if profiles.cooling is None:
        return profiles
    return eqx.tree_at(lambda p: p.cooling.policy, profiles, zero_last(profiles.cooling.policy))


@eqx.filter_jit
def _simulate_with(chain: PharmaChain, cpps: CPPs, physical: PhysicalParameters, profiles: Profiles):
    result = chain.simulate(chain.inputs(cpps, physical=physical), profiles=profiles.by_unit())
    return result.api_yield, cqa_vector(result, chain.process)


def evaluate_hard(chain: PharmaChain, cpps: CPPs, physical: PhysicalParameters, profiles: Profiles, *,
                  penalty_weight: float, sharpness: float) -> dict:
    """The yield with hard spec checks (each CQA against its limits), next to the smooth objective
    the training saw; `gap` = yield - smooth objective (the penalty's share)."""
    api_yield, cqas = call_checked(_simulate_with, chain, cpps, physical, profiles,
                                   what="the chain with the profiles")
    process = chain.process
    smooth = float(api_yield) - 100 * penalty_weight * float(spec_penalty(cqas, sharpness, process))
    return {"api_yield": float(api_yield), "cqas": cqa_dict(cqas, process),
            "meets_all_specs": bool(meets_specs(cqas, process)),
            "spec_margins": dict(zip(cqa_dict(cqas, process), map(float, spec_margins(cqas, process)), strict=True)),
            "smooth_objective": smooth, "gap": float(api_yield) - smooth}


@dataclasses.dataclass(frozen=True, kw_only=True)
class ProfileStudy(Result):
    """Trained temperature profiles against the baseline (the jacket of `jacket_unit`, the built-in's
    R1, constant at the middle of its PAR, and the linear cooling ramp of `cooling_unit`, if any),
    both evaluated with hard spec checks (`evaluate_hard`);
    the profiles sampled at `profile_times`; the training's steps, seconds and loss history; and
    the trained `profiles` (not in the JSON).

    The JSON names each sampled profile by its unit: "profiles" maps unit name -> the samples
    (`profiles_by_unit`). "r1_jacket_profile" and "cooling_profile" are the same samples under
    their first names, kept as deprecated aliases (the jacket's is whichever reactor's
    `jacket_unit` names, not necessarily one called r1)."""

    baseline: dict
    trained: dict
    jacket_unit: str
    cooling_unit: str | None
    r1_jacket_profile: list
    cooling_profile: list | None
    profile_times: list
    train_steps: int
    train_seconds: float
    compile_seconds: float
    loss_history: list
    penalty_weight: float
    sharpness: float
    profiles: Profiles = field(json=False)

    def profiles_by_unit(self) -> dict[str, list]:
        """unit name -> its trained profile sampled at `profile_times` [K]."""
        cooling = {} if self.cooling_profile is None else {self.cooling_unit: self.cooling_profile}
        return {self.jacket_unit: self.r1_jacket_profile, **cooling}

    def to_json(self) -> dict:
        return {**super().to_json(), "profiles": self.profiles_by_unit()}

    def summary(self) -> str:
        return "\n".join(
            f"{name:<9} yield {row['api_yield']:.2f}%  all specs met (hard): {row['meets_all_specs']}  "
            f"smooth objective {row['smooth_objective']:.2f}  gap {row['gap']:.3f}"
            for name, row in (("baseline", self.baseline), ("trained", self.trained)))


def train_profiles(chain: PharmaChain, cpps: CPPs, physical: PhysicalParameters | None = None, *, steps: int = 60,
                   learning_rate: float = 3e-2, penalty_weight: float = 1.0, sharpness: float = 50.0, seed: int = 0,
                   progress: bool = True, checkpoint_path=None, resume: bool = False) -> ProfileStudy:
    """Train both profiles for yield with the specs as smooth penalties; evaluate the baseline and
    the trained profiles hard."""
    physical = chain.physical() if physical is None else physical
    profiles = make_profiles(chain, cpps, physical, key=jax.random.key(seed))
    loss = profile_objective(chain, cpps, physical, penalty_weight=penalty_weight, sharpness=sharpness)
    trained = train(loss, profiles, steps=steps, learning_rate=learning_rate, progress=progress,
                    description="pharma profiles", checkpoint_path=checkpoint_path, checkpoint_every=10,
                    resume=resume, fingerprint={"chain": chain, "cpps": cpps, "physical": physical,
                                                "objective": (penalty_weight, sharpness)})
    settings = dict(penalty_weight=penalty_weight, sharpness=sharpness)
    samples = jnp.linspace(0.0, 1.0, 11)
    return ProfileStudy(
        baseline=evaluate_hard(chain, cpps, physical, constant_profiles(profiles), **settings),
        trained=evaluate_hard(chain, cpps, physical, trained.params, **settings),
        jacket_unit=trained.params.jacket_unit, cooling_unit=trained.params.cooling_unit,
        r1_jacket_profile=[float(trained.params.r1_jacket(s)) for s in samples],
        cooling_profile=None if trained.params.cooling is None else [float(trained.params.cooling(s)) for s in samples],
        profile_times=[float(s) for s in samples], train_steps=trained.steps_run, train_seconds=trained.seconds,
        compile_seconds=trained.compile_seconds, loss_history=trained.history.get("loss", []),
        profiles=trained.params, **settings)
