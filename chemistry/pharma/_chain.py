"""The four-unit chain: R1 (jacketed plug-flow synthesis) -> R2 (hold) -> cooling crystallizer ->
filter (algebraic) -> dryer, each unit a stiff Diffrax solve whose outlet feeds the next, so
gradients flow across units. Assembled from named effects."""

import dataclasses
from pathlib import Path
from typing import NamedTuple

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, Float

from chemistry import MECHANISMS, Mechanism, RateParameters
from snapo_ode import EffectCatalogue, InputError, Scene

from ._crystallizer import Crystallizer, CrystallizerOutlet, solubility
from ._dryer import Dryer, DryerOutlet
from ._liquid import LiquidBatch, LiquidOutlet
from ._parameters import CPPs, MOLAR_MASSES, REACTIONS, SPECIES, PhysicalParameters
from ._profiles import AbstractTemperatureProfile, ConstantTemperature, LinearRamp
from ._solver import ChainSolver

PHARMA_EFFECTS = EffectCatalogue(
    "pharma chain",
    effects={
        "energy_balance": "R1 temperature from the heat of reaction and the jacket (else isothermal at the jacket)",
        "side_reactions": "over-reaction P -> I and the fast side equilibrium A <=> X (the stiff part)",
        "degradation": "thermal degradation P -> D in R1, R2 and in the dryer's solid",
        "crystallization": "seeded cooling crystallizer by the method of moments (else isolation at "
                           "solubility equilibrium, crystal size not modelled: the seed size)",
        "impurity_incorporation": "impurity and degradant taken into the crystals by partition coefficients",
        "drying": "filter-dryer: solvent removal (else the wet cake is the product)",
    },
    requires={"impurity_incorporation": ("crystallization",)},
)
DEFAULT_MECHANISM = MECHANISMS / "pharma.yaml"


class ChainResult(NamedTuple):
    """Every unit's outlet, the cake entering the dryer and the product.

    - `r1`, `r2`: `LiquidOutlet`s (amounts per m^3 of R1's feed volume).
    - `liquor`: molar concentrations entering the crystallizer [kmol/m^3], shape (n_species,).
    - `crystallizer`: `CrystallizerOutlet` (per m^3 of liquor).
    - `cake`: dict of masses entering the dryer [kg per m^3 of liquor]: api, impurity,
      degradant, other (retained A, B, X), solvent.
    - `dryer`: `DryerOutlet` (per kg of cake solids).
    - `product`: dict of masses in the dried product [kg per m^3 of liquor], same keys as `cake`.
    - `api_yield` [%]: API in the product over A fed, in moles.
    """

    r1: LiquidOutlet
    r2: LiquidOutlet
    liquor: Float[Array, " s"]
    crystallizer: CrystallizerOutlet
    cake: dict
    dryer: DryerOutlet | None
    product: dict
    api_yield: Float[Array, ""]


def _reduce(mechanism: Mechanism, keep: tuple[int, ...]) -> Mechanism:
    """The mechanism with only the reactions `keep` (irreversible, elementary ones)."""
    index = np.asarray(keep)
    return dataclasses.replace(
        mechanism,
        reaction_equations=tuple(mechanism.reaction_equations[i] for i in keep),
        pre_exponential=mechanism.pre_exponential[index],
        net_stoichiometry=mechanism.net_stoichiometry[index],
        changed_species=mechanism.changed_species[index],
        forward=dataclasses.replace(mechanism.forward, index=mechanism.forward.index[index],
                                    order=mechanism.forward.order[index]),
        parameters=jax.tree.map(lambda a: a[index], mechanism.parameters),
    )


def check_mechanism(mechanism: Mechanism, path) -> dict[str, int]:
    """The indices of the species and reactions the chain needs.

    **Raises:** `InputError` naming the missing species or reaction (and the file).
    """
    species = {}
    for role, name in SPECIES.items():
        if name not in mechanism.species_names:
            raise InputError(f"mechanism {path}: species {name!r} ({role}) is missing; the pharma chain "
                             f"needs {', '.join(SPECIES.values())}.")
        species[name] = mechanism.species_index(name)
    for equation in REACTIONS:
        if equation not in mechanism.reaction_equations:
            raise InputError(f"mechanism {path}: reaction {equation!r} is missing; the pharma chain needs "
                             f"{', '.join(map(repr, REACTIONS))}.")
    if mechanism.thermo_model != "ideal-condensed":
        raise InputError(f"mechanism {path}: thermo = {mechanism.thermo_model!r}; the pharma chain is a "
                         "liquid: 'ideal-condensed'.")
    return species


class PharmaChain(eqx.Module):
    """The chain as one differentiable function of (CPPs, rate parameters, physical parameters).

    **Arguments:**
    - `mechanism`: the kinetics (default: `chemistry/mechanisms/pharma.yaml`), or a path.
    - `scene`: the active effects (default: all of `PHARMA_EFFECTS`).
    - `solver`: `ChainSolver` (tolerances, solver, differentiation mode).
    """

    mechanism: Mechanism
    scene: Scene = eqx.field(static=True)
    solver: ChainSolver = eqx.field(static=True)
    species: tuple[tuple[str, int], ...] = eqx.field(static=True)
    active_reactions: tuple[int, ...] = eqx.field(static=True)
    molar_masses: Float[Array, " s"]

    def __init__(self, mechanism: Mechanism | str | Path | None = None, scene: Scene | None = None,
                 solver: ChainSolver | None = None):
        path = DEFAULT_MECHANISM if mechanism is None else mechanism
        self.mechanism = mechanism if isinstance(mechanism, Mechanism) else Mechanism.from_yaml(path)
        self.species = tuple(check_mechanism(self.mechanism, path).items())
        self.scene = PHARMA_EFFECTS.scene() if scene is None else scene
        self.solver = ChainSolver() if solver is None else solver
        self.active_reactions = tuple(
            self.mechanism.reaction_equations.index(equation) for equation, effect in REACTIONS.items()
            if not effect or self.scene.has(effect))
        self.molar_masses = jnp.asarray([MOLAR_MASSES[name] for name in self.mechanism.species_names])

    def with_solver(self, solver: ChainSolver) -> "PharmaChain":
        return PharmaChain(self.mechanism, self.scene, solver)

    def with_scene(self, scene: Scene) -> "PharmaChain":
        return PharmaChain(self.mechanism, scene, self.solver)

    @property
    def rate_parameters(self) -> RateParameters:
        """The mechanism's own rate parameters (all reactions, in the file's order)."""
        return self.mechanism.parameters

    def species_index(self, name: str) -> int:
        return dict(self.species)[name]

    def feed(self, temperature, rates: RateParameters, physical: PhysicalParameters, mechanism: Mechanism):
        """R1's feed [kmol/m^3]: A (split with X at the side equilibrium when it is active), B, and
        solvent filling the volume."""
        a, x, b, solvent = (self.species_index(n) for n in ("A", "X", "B", "S"))
        amounts = jnp.zeros(self.mechanism.n_species).at[b].set(physical.feed_b)
        if self.scene.has("side_reactions"):
            forward, _ = mechanism.rates_of_progress(temperature, jnp.ones(self.mechanism.n_species), rates)
            names = mechanism.reaction_equations
            constant = forward[names.index("A => X")] / forward[names.index("X => A")]
            amounts = amounts.at[a].set(physical.feed_a / (1 + constant)).at[x].set(
                physical.feed_a * constant / (1 + constant))
        else:
            amounts = amounts.at[a].set(physical.feed_a)
        volumes = self.mechanism.molar_volumes
        return amounts.at[solvent].set((1 - amounts @ volumes) / volumes[solvent])

    def active_kinetics(self, rates: RateParameters) -> tuple[Mechanism, RateParameters]:
        """The mechanism reduced to the reactions of the active effects, and their rates."""
        keep = np.asarray(self.active_reactions)
        return _reduce(self.mechanism, self.active_reactions), jax.tree.map(lambda a: a[keep], rates)

    def run_r1(self, cpps: CPPs, rates: RateParameters, physical: PhysicalParameters, *,
               r1_jacket: AbstractTemperatureProfile | None = None, steps: bool = False):
        """R1, the jacketed plug-flow reactor (residence time [min] -> [s]): its `LiquidOutlet`,
        or with `steps` the `diffrax.Solution` at every step (amounts [kmol/m^3], then T / 300 K
        with the energy balance)."""
        mechanism, active_rates = self.active_kinetics(rates)
        jacket = ConstantTemperature(cpps.r1_temperature) if r1_jacket is None else r1_jacket
        feed = self.feed(cpps.r1_temperature, active_rates, physical, mechanism)
        return LiquidBatch(mechanism, self.scene.has("energy_balance"))(
            feed, cpps.r1_temperature, jacket, 60.0 * cpps.r1_residence_time, active_rates, physical.jacket_ua,
            self.solver, steps=steps)

    def simulate(self, cpps: CPPs, rates: RateParameters | None = None, physical: PhysicalParameters | None = None,
                 *, r1_jacket: AbstractTemperatureProfile | None = None,
                 cooling: AbstractTemperatureProfile | None = None) -> ChainResult:
        """Run the chain. `rates` default to the mechanism's; `physical` to the defaults;
        `r1_jacket` (default: constant at `cpps.r1_temperature`) and `cooling` (default: the
        linear ramp from the hold to the final temperature at `cpps.cooling_rate`) may be
        learned profiles."""
        from ._parameters import default_physical_parameters

        rates = self.mechanism.parameters if rates is None else rates
        physical = default_physical_parameters() if physical is None else physical
        mechanism, active_rates = self.active_kinetics(rates)
        volumes = self.mechanism.molar_volumes
        r1 = self.run_r1(cpps, rates, physical, r1_jacket=r1_jacket)
        # R2: isothermal hold.
        r2 = LiquidBatch(mechanism, False)(
            r1.amounts, physical.hold_temperature, ConstantTemperature(physical.hold_temperature),
            physical.hold_time, active_rates, physical.jacket_ua, self.solver)
        liquor = r2.concentrations(volumes)
        p, i, d, s = (self.species_index(n) for n in ("P", "I", "D", "S"))

        # Crystallizer (or equilibrium isolation).
        if self.scene.has("crystallization"):
            profile = LinearRamp(physical.hold_temperature, physical.final_temperature) if cooling is None else cooling
            duration = 60.0 * (physical.hold_temperature - physical.final_temperature) / cpps.cooling_rate
            crystallizer = Crystallizer(MOLAR_MASSES["P"], self.scene.has("impurity_incorporation"))(
                liquor[p], liquor[i], liquor[d], profile, duration, physical, self.solver)
        else:
            crystallizer = _equilibrium_isolation(liquor[p], physical)
        crystal_mass = crystallizer.crystal_mass(physical)

        # Filter: the cake keeps `cake_liquor` kg of liquid per kg of crystals; the wash leaves
        # `wash_residue` of the liquor's solutes and replaces the rest with solvent.
        final_liquor = (liquor.at[p].set(crystallizer.api)
                        .at[i].add(-crystallizer.impurity_solid).at[d].add(-crystallizer.degradant_solid))
        liquor_masses = final_liquor * self.molar_masses
        retained = physical.wash_residue * physical.cake_liquor * crystal_mass * liquor_masses / jnp.sum(liquor_masses)
        masses = self.molar_masses
        impurity_solid = masses[i] * crystallizer.impurity_solid
        degradant_solid = masses[d] * crystallizer.degradant_solid
        cake = {
            "api": crystal_mass - impurity_solid - degradant_solid + retained[p],
            "impurity": impurity_solid + retained[i],
            "degradant": degradant_solid + retained[d],
            "other": jnp.sum(retained) - retained[p] - retained[i] - retained[d] - retained[s],
            "solvent": physical.cake_liquor * crystal_mass,
        }
        solids = cake["api"] + cake["impurity"] + cake["degradant"] + cake["other"]

        if self.scene.has("drying"):
            dryer = Dryer(self.scene.has("degradation"))(
                cake["solvent"] / solids, cake["api"] / solids, cpps.dryer_temperature, physical, self.solver)
            product = dict(cake, api=solids * dryer.api, degradant=cake["degradant"] + solids * dryer.degradant_formed,
                           solvent=solids * dryer.solvent)
        else:
            dryer, product = None, dict(cake)
        fed = physical.feed_a / (r2.amounts @ volumes)  # [kmol A per m^3 of liquor]
        api_yield = 100 * product["api"] / masses[p] / fed
        return ChainResult(r1, r2, liquor, crystallizer, cake, dryer, product, api_yield)


def _equilibrium_isolation(api, physical) -> CrystallizerOutlet:
    """Without the crystallization effect: the API above its solubility at the final
    temperature comes out as solid of the seed size (no kinetics, no incorporation)."""
    solid = jnp.maximum(api - solubility(physical.final_temperature, physical), 0.0)
    volume = solid * MOLAR_MASSES["P"] / physical.crystal_density  # [m^3/m^3]
    count = volume / (physical.shape_factor * physical.seed_size**3)
    moments = count * physical.seed_size ** jnp.arange(5)
    zero = jnp.zeros_like(api)
    return CrystallizerOutlet(api - solid, moments, zero, zero, physical.final_temperature)
