"""The four-unit chain: R1 (jacketed plug-flow synthesis) -> R2 (hold) -> cooling crystallizer ->
filter (algebraic) -> dryer, each a unit (`_unit.AbstractUnit`) whose outlet feeds the next, so
gradients flow across units. Assembled from named effects: an effect left out is a unit or a
reaction that is not built, not one multiplied by zero."""

import dataclasses
from pathlib import Path
from typing import NamedTuple

import diffrax
import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
import optimistix as optx

from chemistry import MECHANISMS, Mechanism, RateParameters
from snapo_ode import EffectCatalogue, InputError, Scene, Solver, SolverSettings, solver_from_name

from ..kinetics._types import Scalar, Vector
from ._crystallizer import (
    Crystallizer, CrystallizerOutlet, CoolingCrystallizer, EquilibriumIsolation, SpeciesRoles)
from ._dryer import Dryer
from ._filter import Filter
from ._liquid import HoldReactor, LiquidBatch, SynthesisReactor
from ._parameters import MOLAR_MASSES, ChainInputs, CPPs, PhysicalParameters, default_physical_parameters
from ._profiles import AbstractTemperatureProfile
from ._ranges import REACTIONS, SPECIES
from ._unit import Liquid, Solids

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


STAGE_ROOT_FINDER = optx.Newton(rtol=1e-6, atol=1e-9)
"""How the chain's ESDIRK methods (Kvaerno) solve their stage equations: Newton at rtol 1e-6 /
atol 1e-9, looser than the step's, because Newton converges quadratically and asking the step's
tolerance of it on a stiff system (R1's condition number ~ h * 4e5) meets round-off, fails and
rejects steps."""


def chain_method(name: str, field: str = "solver") -> Solver:
    """The solver registered as `name` (a CLI flag, a bench's row) as the chain runs it: an ESDIRK
    method with `STAGE_ROOT_FINDER`, any other with its defaults."""
    method = solver_from_name(name, field)
    if isinstance(method, diffrax.AbstractImplicitSolver):
        return dataclasses.replace(method, root_finder=STAGE_ROOT_FINDER)
    return method


CHAIN_SOLVER = SolverSettings(solver="rodas5", max_steps=4096)
"""The chain's default `SolverSettings`: Rodas5 for R1 and R2 (their Jacobians' largest
eigenvalue is ~1e5-1e6 per unit duration; Rodas5 takes fewer steps than Rodas4 and gives the
sensitivities faster at the same error, which the crystallizer and dryer's Tsit5 set:
docs/pharma.md, Measurements behind the design), Tsit5 for the crystallizer and the dryer (below
~20 per unit duration at every PAR corner, tested), rtol 1e-8 / atol 1e-10 on the scaled states
(concentrations [kmol/m^3], T / 300 K, moments scaled to O(1)), 4,096 steps per unit. Other
methods by name: `chain_method`."""


class ChainResult(NamedTuple):
    """Every unit's outlet.

    - `r1`, `r2`: `Liquid` (amounts per m^3 of R1's feed volume).
    - `liquor`: molar concentrations entering the crystallizer [kmol/m^3], shape (n_species,).
    - `crystallizer`: `CrystallizerOutlet` (per m^3 of liquor).
    - `cake`: the `Solids` entering the dryer [kg per m^3 of liquor].
    - `product`: the dried `Solids` [kg per m^3 of liquor] (the cake without the drying effect).
    - `api_yield` [%]: API in the product over A fed, in moles.
    """

    r1: Liquid
    r2: Liquid
    liquor: Vector
    crystallizer: CrystallizerOutlet
    cake: Solids
    product: Solids
    api_yield: Scalar


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


def chain_species(mechanism: Mechanism, path) -> dict[str, int]:
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
    """The chain as one differentiable function of its `ChainInputs` (CPPs, rate parameters,
    physical parameters).

    **Arguments:**
    - `mechanism`: the kinetics (default: `chemistry/mechanisms/pharma.yaml`), or a path.
    - `scene`: the active effects (default: all of `PHARMA_EFFECTS`).
    - `solver`: `SolverSettings` of every unit (default `CHAIN_SOLVER`).
    """

    mechanism: Mechanism
    scene: Scene = eqx.field(static=True)
    solver: SolverSettings = eqx.field(static=True)
    species: tuple[tuple[str, int], ...] = eqx.field(static=True)
    active_reactions: tuple[int, ...] = eqx.field(static=True)
    molar_masses: Vector

    def __init__(self, mechanism: Mechanism | str | Path | None = None, scene: Scene | None = None,
                 solver: SolverSettings | None = None):
        path = DEFAULT_MECHANISM if mechanism is None else mechanism
        self.mechanism = mechanism if isinstance(mechanism, Mechanism) else Mechanism.from_yaml(path)
        self.species = tuple(chain_species(self.mechanism, path).items())
        self.scene = PHARMA_EFFECTS.scene() if scene is None else scene
        self.solver = CHAIN_SOLVER if solver is None else solver
        self.active_reactions = tuple(
            self.mechanism.reaction_equations.index(equation) for equation, effect in REACTIONS.items()
            if not effect or self.scene.has(effect))
        self.molar_masses = jnp.asarray([MOLAR_MASSES[name] for name in self.mechanism.species_names])

    def with_solver(self, solver: SolverSettings) -> "PharmaChain":
        return PharmaChain(self.mechanism, self.scene, solver)

    def with_scene(self, scene: Scene) -> "PharmaChain":
        return PharmaChain(self.mechanism, scene, self.solver)

    @property
    def rate_parameters(self) -> RateParameters:
        """The mechanism's own rate parameters (all reactions, in the file's order)."""
        return self.mechanism.parameters

    def species_index(self, name: str) -> int:
        return dict(self.species)[name]

    def inputs(self, cpps: CPPs, rates: RateParameters | None = None,
               physical: PhysicalParameters | None = None) -> ChainInputs:
        """The `ChainInputs` at `cpps`, with the mechanism's rates and the default physical
        parameters unless given."""
        return ChainInputs(cpps, self.rate_parameters if rates is None else rates,
                           default_physical_parameters() if physical is None else physical)

    @property
    def roles(self) -> SpeciesRoles:
        return SpeciesRoles(*(self.species_index(name) for name in ("P", "I", "D", "S")))

    def active(self, inputs: ChainInputs) -> tuple[Mechanism, ChainInputs]:
        """The mechanism reduced to the reactions of the active effects, and `inputs` with their
        rates only (what R1 and R2 see)."""
        keep = np.asarray(self.active_reactions)
        return (_reduce(self.mechanism, self.active_reactions),
                inputs._replace(rates=jax.tree.map(lambda a: a[keep], inputs.rates)))

    def feed(self, inputs: ChainInputs) -> Liquid:
        """R1's feed [kmol/m^3] at the R1 temperature: A (split with X at the side equilibrium
        when it is active), B, and solvent filling the volume."""
        mechanism, active = self.active(inputs)
        temperature, physical = inputs.cpps.r1_temperature, inputs.physical
        a, x, b, solvent = (self.species_index(n) for n in ("A", "X", "B", "S"))
        amounts = jnp.zeros(self.mechanism.n_species).at[b].set(physical.feed_b)
        if self.scene.has("side_reactions"):
            forward, _ = mechanism.rates_of_progress(temperature, jnp.ones(self.mechanism.n_species), active.rates)
            names = mechanism.reaction_equations
            constant = forward[names.index("A => X")] / forward[names.index("X => A")]
            amounts = amounts.at[a].set(physical.feed_a / (1 + constant)).at[x].set(
                physical.feed_a * constant / (1 + constant))
        else:
            amounts = amounts.at[a].set(physical.feed_a)
        volumes = self.mechanism.molar_volumes
        return Liquid(amounts.at[solvent].set((1 - amounts @ volumes) / volumes[solvent]), temperature)

    def r1(self, inputs: ChainInputs, *, jacket: AbstractTemperatureProfile | None = None) -> SynthesisReactor:
        """The R1 unit (on the active reactions; `inputs` as `active` returns them)."""
        mechanism, _ = self.active(inputs)
        return SynthesisReactor(LiquidBatch(mechanism, self.scene.has("energy_balance")), jacket)

    def simulate(self, inputs: ChainInputs | CPPs, *, r1_jacket: AbstractTemperatureProfile | None = None,
                 cooling: AbstractTemperatureProfile | None = None) -> ChainResult:
        """Run the chain at `inputs` (`PharmaChain.inputs`; or `CPPs` alone, with the default
        rates and physical parameters). `r1_jacket` (default: constant at `cpps.r1_temperature`)
        and `cooling` (default: the linear ramp from the hold to the final temperature at
        `cpps.cooling_rate`) may be learned profiles."""
        if isinstance(inputs, CPPs):
            inputs = self.inputs(inputs)
        mechanism, active = self.active(inputs)
        volumes, roles = self.mechanism.molar_volumes, self.roles
        r1 = self.r1(inputs, jacket=r1_jacket)(self.feed(inputs), active, self.solver)
        r2 = HoldReactor(LiquidBatch(mechanism, False))(r1, active, self.solver)
        if self.scene.has("crystallization"):
            physics = Crystallizer(MOLAR_MASSES["P"], self.scene.has("impurity_incorporation"))
            crystallizer = CoolingCrystallizer(physics, volumes, roles, cooling)
        else:
            crystallizer = EquilibriumIsolation(MOLAR_MASSES["P"], volumes, roles)
        slurry = crystallizer(r2, inputs, self.solver)
        cake = Filter(self.molar_masses, roles)(slurry, inputs, self.solver)
        product = Dryer(self.scene.has("degradation"))(cake, inputs, self.solver) if self.scene.has("drying") else cake
        fed = inputs.physical.feed_a / (r2.amounts @ volumes)  # [kmol A per m^3 of liquor]
        api_yield = 100 * product.api / self.molar_masses[roles.api] / fed
        return ChainResult(r1, r2, slurry.liquor, slurry.crystals, cake, product, api_yield)
