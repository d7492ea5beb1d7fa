"""The seeded cooling crystallizer: van't Hoff solubility, power-law secondary nucleation and
size-independent growth, the method of moments (mu_0 .. mu_4), and impurity incorporation by a
partition coefficient (an effect); without the crystallization effect, isolation at the
solubility equilibrium.

Per m^3 of liquor (its volume taken constant). Scaled state: [c_P [kmol/m^3], m_0 .. m_4] with
mu_j = N_REF L_REF^j m_j, then (with incorporation) the impurity and degradant taken up by the
crystals [kmol/m^3].
"""

from typing import NamedTuple

import equinox as eqx
import jax.numpy as jnp

from chemistry import GAS_CONSTANT
from snapo_ode import SolverSettings

from chemistry import RateParameters

from ..kinetics._types import Scalar, Vector
from ._parameters import arrhenius
from ._profiles import AbstractTemperatureProfile, ConstantTemperature, LinearRamp
from ._unit import AbstractUnit, Liquid


N_REF = 1e10  # [1/m^3]
L_REF = 1e-4  # [m]


def solubility(temperature, parameters: dict):
    """C*(T) [kmol/m^3], van't Hoff, from a crystallizer's `parameters`."""
    inverse = 1 / temperature - 1 / parameters["solubility_ref_temperature"]
    return parameters["solubility_ref"] * jnp.exp(-parameters["solubility_enthalpy"] / GAS_CONSTANT * inverse)


def _power_of_positive(x, power):
    """max(x, 0) ** power, with exact zero gradients (also in `power`) where x <= 0."""
    positive = x > 0
    return jnp.where(positive, jnp.where(positive, x, 1.0) ** power, 0.0)


class CrystallizerOutlet(NamedTuple):
    """`api` [kmol/m^3] dissolved at the end; `moments` mu_0 .. mu_4 [m^j/m^3], shape (5,);
    `impurity_solid`, `degradant_solid` [kmol/m^3] incorporated in the crystals; `temperature` [K];
    `crystal_mass` [kg/m^3] of liquor (density x shape factor x mu_3)."""

    api: Scalar
    moments: Vector
    impurity_solid: Scalar
    degradant_solid: Scalar
    temperature: Scalar
    crystal_mass: Scalar

    def mean_size(self):
        """Volume-weighted mean size D[4,3] = mu_4 / mu_3 [m]."""
        return self.moments[4] / self.moments[3]


class Slurry(NamedTuple):
    """The crystallizer's outlet: the `liquor` it was fed (molar concentrations [kmol/m^3], shape
    (n_species,)) and the `crystals` grown from it."""

    liquor: Vector
    crystals: CrystallizerOutlet

    def final_liquor(self, roles: "SpeciesRoles") -> Vector:
        """The liquor at the end [kmol per m^3 of liquor]: the fed liquor less what the crystals
        took (the API down to what stays dissolved, the impurity and degradant they took up)."""
        crystals = self.crystals
        return (self.liquor.at[roles.api].set(crystals.api).at[roles.impurity].add(-crystals.impurity_solid)
                .at[roles.degradant].add(-crystals.degradant_solid))

    def crystal_masses(self, molar_masses: Vector, roles: "SpeciesRoles") -> Vector:
        """What the crystals hold [kg per m^3 of liquor] by species, shape (n_species,): the
        impurity and degradant they took up, the API the rest of their mass."""
        crystals = self.crystals
        impurity = molar_masses[roles.impurity] * crystals.impurity_solid
        degradant = molar_masses[roles.degradant] * crystals.degradant_solid
        return (jnp.zeros_like(molar_masses).at[roles.api].set(crystals.crystal_mass - impurity - degradant)
                .at[roles.impurity].set(impurity).at[roles.degradant].set(degradant))


class SpeciesRoles(NamedTuple):
    """Where the API `api`, the impurity `impurity`, the degradant `degradant`, the `solvent` and
    the `antisolvent` (-1: none) sit in the mechanism's species."""

    api: int
    impurity: int
    degradant: int
    solvent: int
    antisolvent: int = -1

    @property
    def solvents(self) -> tuple[int, ...]:
        """The solvent and the antisolvent, if any: what a dryer removes and loss on drying counts."""
        return (self.solvent,) if self.antisolvent < 0 else (self.solvent, self.antisolvent)


class Crystallizer(eqx.Module):
    """The cooling crystallizer's physics; `impurity_incorporation`: whether impurity and
    degradant enter the crystals (partition coefficients), else the crystals are pure API.
    `incorporated_molar_masses`: the impurity's and the degradant's [kg/kmol].

    The crystals' mass grows as their volume (density x shape factor x d mu_3); the growing layer
    holds x_j = partition_j c_j / c_API moles of impurity or degradant j per mole of API, so that
    of a mass growth m' the API is m' / (M_API + sum_j x_j M_j) moles and j is x_j times that:
    each leaves the liquor as it enters the crystals."""

    api_molar_mass: float = eqx.field(static=True)
    impurity_incorporation: bool = eqx.field(static=True)
    incorporated_molar_masses: tuple[float, float] = eqx.field(static=True, default=(0.0, 0.0))

    def rhs(self, s, state, args):
        profile, duration, p, impurity0, degradant0, addition = args
        temperature = profile(s)
        api, scaled = state[0], state[1:6]
        if addition is None:
            supersaturation = api / solubility(temperature, p) - 1
        else:  # api per m^3 of the initial liquor, in a volume that grows as the antisolvent comes in
            supersaturation = api / addition.volume(s) / (solubility(temperature, p) * addition.solubility_factor(s, p)) - 1
        growth = (arrhenius(p["growth_rate"], p["growth_activation"], temperature, p["solubility_ref_temperature"])
                  * _power_of_positive(supersaturation, p["growth_order"]))
        crystal_volume = p["shape_factor"] * N_REF * L_REF**3 * scaled[3]  # [m^3/m^3]
        nucleation = p["nucleation_rate"] * _power_of_positive(supersaturation, p["nucleation_order"]) * crystal_volume
        d_moments = jnp.concatenate([
            jnp.reshape(nucleation / N_REF, (1,)),
            jnp.arange(1, 5) * (growth / L_REF) * scaled[:4],
        ])
        # [kg/m^3/s] into the crystals (nuclei have negligible volume).
        growing = p["crystal_density"] * p["shape_factor"] * N_REF * L_REF**3 * d_moments[3]
        if not self.impurity_incorporation:
            return duration * jnp.concatenate([jnp.reshape(-growing / self.api_molar_mass, (1,)), d_moments])
        ratios = jnp.stack([p["partition_impurity"] * (impurity0 - state[6]),
                            p["partition_degradant"] * (degradant0 - state[7])]) / api  # [mol per mol API]
        crystallizing = growing / (self.api_molar_mass + ratios @ jnp.asarray(self.incorporated_molar_masses))
        return duration * jnp.concatenate([jnp.reshape(-crystallizing, (1,)), d_moments, crystallizing * ratios])

    def __call__(self, api, impurity, degradant, profile: AbstractTemperatureProfile, duration, parameters: dict,
                 solver: SolverSettings, addition: "AntisolventAddition | None" = None) -> CrystallizerOutlet:
        """Crystallize from liquor with `api`, `impurity`, `degradant` [kmol/m^3] over `duration`
        [s] along the temperature `profile`, seeded with `seed_loading` [kg/m^3] of crystals of
        `seed_size` [m] (the crystallizer's `parameters`); with an antisolvent `addition`, every
        amount is per m^3 of the initial liquor."""
        p = parameters
        seed_count = p["seed_loading"] / (p["crystal_density"] * p["shape_factor"] * p["seed_size"]**3)
        seed_moments = seed_count / N_REF * (p["seed_size"] / L_REF) ** jnp.arange(5)
        state = jnp.concatenate([jnp.reshape(api, (1,)), seed_moments])
        if self.impurity_incorporation:
            state = jnp.concatenate([state, jnp.zeros(2)])
        end = solver.solve(self.rhs, 0.0, 1.0, state, (profile, duration, p, impurity, degradant, addition),
                           stiff=False).ys[-1]
        moments = end[1:6] * N_REF * L_REF ** jnp.arange(5)
        solid = end[6:8] if self.impurity_incorporation else jnp.zeros(2)
        return CrystallizerOutlet(end[0], moments, solid[0], solid[1], profile(1.0),
                                  p["crystal_density"] * p["shape_factor"] * moments[3])


def seed_mass(unit: AbstractUnit, parameters: dict):
    """The seed crystals [kg per m^3 of liquor] the crystallizer `unit` is charged with: its
    `seed_loading`, none for `EquilibriumIsolation` (no seeds: the solid comes out at the seed
    size, but from the liquor) or a unit without the parameter. Seeds are API the process did
    not make: the crystals' mass balance and the net yield take them out."""
    if isinstance(unit, EquilibriumIsolation):
        return 0.0
    return parameters.get("seed_loading", 0.0)


class AntisolventAddition(eqx.Module):
    """Antisolvent added at a constant rate over the crystallization: `ratio` m^3 of it per m^3 of
    the initial liquor in all. At normalised time s the volume is 1 + ratio s [m^3 per m^3 of the
    initial liquor], the antisolvent's volume fraction w = ratio s / (1 + ratio s), and the
    solubility falls by exp(-(a w + b w^2)) (`antisolvent_linear` a, `antisolvent_quadratic` b)."""

    ratio: Scalar

    def volume(self, s):
        return 1 + self.ratio * s

    def solubility_factor(self, s, parameters: dict):
        fraction = self.ratio * s / self.volume(s)
        return jnp.exp(-(parameters["antisolvent_linear"] + parameters["antisolvent_quadratic"] * fraction) * fraction)


class CoolingCrystallizer(AbstractUnit):
    """The crystallizer as a unit (type `cooling_crystallizer`): the liquor of `inlet` cooled from
    the inlet's temperature to `final_temperature` [K] at `cooling_rate` [K/min] (linearly, or
    along a learned `cooling` profile between the same end points)."""

    physics: Crystallizer
    molar_volumes: Vector
    roles: SpeciesRoles = eqx.field(static=True)
    cooling: AbstractTemperatureProfile | None = None

    def __call__(self, inlet: Liquid, parameters: dict, rates: RateParameters, solver: SolverSettings) -> Slurry:
        roles, final = self.roles, parameters["final_temperature"]
        liquor = inlet.concentrations(self.molar_volumes)
        profile = LinearRamp(inlet.temperature, final) if self.cooling is None else self.cooling
        duration = 60.0 * (inlet.temperature - final) / parameters["cooling_rate"]
        crystals = self.physics(liquor[roles.api], liquor[roles.impurity], liquor[roles.degradant], profile,
                                duration, parameters, solver)
        return Slurry(liquor, crystals)


class EquilibriumIsolation(AbstractUnit):
    """Without the crystallization effect: the API above its solubility at the final temperature
    comes out as solid of the seed size (no kinetics, no incorporation)."""

    api_molar_mass: float = eqx.field(static=True)
    molar_volumes: Vector
    roles: SpeciesRoles = eqx.field(static=True)

    def __call__(self, inlet: Liquid, parameters: dict, rates: RateParameters, solver: SolverSettings) -> Slurry:
        p = parameters
        liquor = inlet.concentrations(self.molar_volumes)
        api = liquor[self.roles.api]
        solid = jnp.maximum(api - solubility(p["final_temperature"], p), 0.0)
        volume = solid * self.api_molar_mass / p["crystal_density"]  # [m^3/m^3]
        count = volume / (p["shape_factor"] * p["seed_size"]**3)
        moments = count * p["seed_size"] ** jnp.arange(5)
        zero = jnp.zeros_like(api)
        mass = p["crystal_density"] * p["shape_factor"] * moments[3]
        return Slurry(liquor, CrystallizerOutlet(api - solid, moments, zero, zero, p["final_temperature"], mass))


class AntisolventCrystallizer(AbstractUnit):
    """The antisolvent crystallizer (type `antisolvent_crystallizer`): at `temperature` [K] (or
    along a learned `profile`), `antisolvent_ratio` m^3 of the `antisolvent` species per m^3 of
    liquor added at a constant rate over `addition_time` [min] (semi-batch); the slurry's liquor
    is per m^3 of the liquor fed, the antisolvent in it."""

    physics: Crystallizer
    molar_volumes: Vector
    roles: SpeciesRoles = eqx.field(static=True)
    antisolvent: int = eqx.field(static=True)
    profile: AbstractTemperatureProfile | None = None

    def __call__(self, inlet: Liquid, parameters: dict, rates: RateParameters, solver: SolverSettings) -> Slurry:
        roles, ratio = self.roles, parameters["antisolvent_ratio"]
        liquor = inlet.concentrations(self.molar_volumes)
        profile = ConstantTemperature(parameters["temperature"]) if self.profile is None else self.profile
        crystals = self.physics(liquor[roles.api], liquor[roles.impurity], liquor[roles.degradant], profile,
                                60.0 * parameters["addition_time"], parameters, solver, AntisolventAddition(ratio))
        return Slurry(liquor.at[self.antisolvent].add(ratio / self.molar_volumes[self.antisolvent]), crystals)
