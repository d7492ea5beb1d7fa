"""A process as one differentiable function: its units (`_unit.AbstractUnit`) in the order its
file states them, each outlet feeding the next, so gradients flow across units; the built-in is
R1 (jacketed plug flow) -> R2 (hold) -> cooling crystallizer -> filter (algebraic) -> dryer.
Assembled from named effects: an effect left out is a unit or a reaction that is not built, not
one multiplied by zero."""

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
from snapo_ode import EffectCatalogue, Scene, Solver, SolverSettings, solver_from_name

from ..kinetics._types import Scalar, Vector
from ._crystallizer import CrystallizerOutlet, SpeciesRoles, seed_mass
from ._parameters import ChainInputs, CPPs, PhysicalParameters
from ._process import check_mechanism, make_cpps, molar_masses, physical_parameters
from ._process_file import ProcessSpec, load_process
from ._profiles import AbstractTemperatureProfile
from ._unit import AbstractUnit, Liquid, Solids

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
"""The built-in process's mechanism."""


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
docs/dev/pharma_notes.md, Measurements behind the design), Tsit5 for the crystallizer and the dryer (below
~20 per unit duration at every PAR corner, tested), rtol 1e-8 / atol 1e-10 on the scaled states
(concentrations [kmol/m^3], T / 300 K, moments scaled to O(1)), 4,096 steps per unit. Other
methods by name: `chain_method`."""


class ChainResult(NamedTuple):
    """Every unit's outlet.

    - `outlets`: unit name -> its outlet (a reactor's `Liquid`, amounts per m^3 of the first
      reactor's feed volume; the crystallizer's `Slurry`; the filter's and the dryer's `Solids`).
    - `liquor`: molar concentrations entering the crystallizer [kmol/m^3], shape (n_species,).
    - `crystallizer`: `CrystallizerOutlet` (per m^3 of liquor).
    - `cake`: the filter's `Solids` [kg per m^3 of liquor].
    - `product`: the dried `Solids` [kg per m^3 of liquor] (the cake without a dryer or the
      drying effect).
    - `api_yield` [%]: API made and isolated over the first fed species, in moles: the API in
      the product less the seed crystals charged (API the process did not make).
    - `api_yield_including_seed` [%]: the API in the product, seeds included, over the first
      fed species, in moles.
    """

    outlets: dict
    liquor: Vector
    crystallizer: CrystallizerOutlet
    cake: Solids
    product: Solids
    api_yield: Scalar
    api_yield_including_seed: Scalar


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


def _process(process) -> ProcessSpec:
    return process if isinstance(process, ProcessSpec) else load_process(process)


class PharmaChain(eqx.Module):
    """A process as one differentiable function of its `ChainInputs` (CPPs, rate parameters,
    physical parameters).

    **Arguments:**
    - `mechanism`: the kinetics (default: the process's mechanism file), or a path.
    - `scene`: the active effects (default: all of `PHARMA_EFFECTS`).
    - `solver`: `SolverSettings` of every unit (default `CHAIN_SOLVER`).
    - `process`: a `ProcessSpec` or the path of a process file (default: the built-in
      `chemistry/pharma/processes/api_chain.yaml`).

    **Raises:** `InputError` naming the process file where the mechanism lacks a species or a
    reaction the process names, or has a species without a role.
    """

    mechanism: Mechanism
    process: ProcessSpec = eqx.field(static=True)
    scene: Scene = eqx.field(static=True)
    solver: SolverSettings = eqx.field(static=True)
    species: tuple[tuple[str, int], ...] = eqx.field(static=True)
    active_reactions: tuple[int, ...] = eqx.field(static=True)
    equilibrium_species: tuple[int, int] | None = eqx.field(static=True)
    masses: tuple[float, ...] = eqx.field(static=True)

    def __init__(self, mechanism: Mechanism | str | Path | None = None, scene: Scene | None = None,
                 solver: SolverSettings | None = None, *, process: ProcessSpec | str | Path | None = None,
                 masses: tuple[float, ...] | None = None):
        self.process = _process(process)
        if not isinstance(mechanism, Mechanism):
            mechanism = Mechanism.from_yaml(self.process.mechanism if mechanism is None else mechanism,
                                            self.process.phase)
        self.mechanism = mechanism
        check_mechanism(self.process, mechanism.species_names, mechanism.reaction_equations, mechanism.thermo_model)
        self.species = tuple((name, k) for k, name in enumerate(mechanism.species_names))
        self.scene = PHARMA_EFFECTS.scene() if scene is None else scene
        self.solver = CHAIN_SOLVER if solver is None else solver
        effects = self.process.reaction_effects
        self.active_reactions = tuple(k for k, equation in enumerate(mechanism.reaction_equations)
                                      if equation not in effects or self.scene.has(effects[equation]))
        self.equilibrium_species = None
        if self.process.equilibrium is not None:  # the forward reaction's reactant and product
            row = np.asarray(mechanism.net_stoichiometry[mechanism.reaction_equations.index(self.process.equilibrium[0])])
            self.equilibrium_species = (int(np.argmin(row)), int(np.argmax(row)))
        if masses is None:
            table = molar_masses(self.process)
            masses = tuple(table[name] for name in mechanism.species_names)
        self.masses = masses

    def with_solver(self, solver: SolverSettings) -> "PharmaChain":
        return PharmaChain(self.mechanism, self.scene, solver, process=self.process, masses=self.masses)

    def with_scene(self, scene: Scene) -> "PharmaChain":
        return PharmaChain(self.mechanism, scene, self.solver, process=self.process, masses=self.masses)

    @property
    def molar_masses(self) -> Vector:
        """[kg/kmol] of each species, in the mechanism's order (`masses` as an array)."""
        return jnp.asarray(self.masses)

    @property
    def rate_parameters(self) -> RateParameters:
        """The mechanism's own rate parameters (all reactions, in the file's order)."""
        return self.mechanism.parameters

    @property
    def cpp_ranges(self):
        return self.process.cpps

    @property
    def cpp_names(self) -> tuple[str, ...]:
        return tuple(spec.name for spec in self.process.cpps)

    @property
    def cqa_specs(self):
        return self.process.cqas

    @property
    def cqa_names(self) -> tuple[str, ...]:
        return tuple(spec.name for spec in self.process.cqas)

    def species_index(self, name: str) -> int:
        return dict(self.species)[name]

    def role_species(self, role: str) -> str:
        """The species with `role` (one of the roles the units track: api, impurity, degradant, solvent)."""
        return self.process.species_with_role(role)[0]

    def cpps(self, **values: float) -> CPPs:
        """The process's CPPs (`make_cpps`): the nominal values, with `values` by name."""
        return make_cpps(self.process, **values)

    def physical(self, **overrides: float) -> PhysicalParameters:
        """The process's physical parameters (`physical_parameters`), with `overrides` by name."""
        return physical_parameters(self.process, **overrides)

    def inputs(self, cpps: CPPs, rates: RateParameters | None = None,
               physical: PhysicalParameters | None = None) -> ChainInputs:
        """The `ChainInputs` at `cpps`, with the mechanism's rates and the process file's physical
        parameters unless given."""
        return ChainInputs(cpps, self.rate_parameters if rates is None else rates,
                           self.physical() if physical is None else physical)

    @property
    def roles(self) -> SpeciesRoles:
        antisolvent = self.process.species_with_role("antisolvent")
        return SpeciesRoles(*(self.species_index(self.role_species(role)) for role in ("api", "impurity", "degradant",
                                                                                          "solvent")),
                            self.species_index(antisolvent[0]) if antisolvent else -1)

    def active(self, inputs: ChainInputs) -> tuple[Mechanism, ChainInputs]:
        """The mechanism reduced to the reactions of the active effects, and `inputs` with their
        rates only (what the reactors see)."""
        keep = np.asarray(self.active_reactions)
        return (_reduce(self.mechanism, self.active_reactions),
                inputs._replace(rates=jax.tree.map(lambda a: a[keep], inputs.rates)))

    def unit_parameters(self, inputs: ChainInputs) -> dict[str, dict]:
        """unit name -> parameter -> value: the physical parameters ("unit.parameter") and the
        CPPs at their targets."""
        parameters = {unit.name: {} for unit in self.process.units}
        for name, value in (*zip(inputs.physical.names, inputs.physical.values, strict=True),
                            *((spec.target, inputs.cpps[spec.name]) for spec in self.process.cpps)):
            unit, _, parameter = name.partition(".")
            if unit != "feed":
                parameters[unit][parameter] = value
        return parameters

    def feed(self, inputs: ChainInputs) -> Liquid:
        """The first reactor's feed [kmol/m^3] at its temperature: the fed species (the
        process's equilibrium pair split at its equilibrium when both its reactions run), and
        solvent filling the volume."""
        mechanism, active = self.active(inputs)
        first = self.process.units[0].name
        temperature = self.unit_parameters(inputs)[first]["temperature"]
        amounts = jnp.zeros(self.mechanism.n_species)
        for name in self.process.feed:
            amounts = amounts.at[self.species_index(name)].set(inputs.physical[f"feed.{name}"])
        pair = self.process.equilibrium
        if pair is not None and all(equation in mechanism.reaction_equations for equation in pair):
            forward, _ = mechanism.rates_of_progress(temperature, jnp.ones(self.mechanism.n_species), active.rates)
            names = mechanism.reaction_equations
            constant = forward[names.index(pair[0])] / forward[names.index(pair[1])]
            a, x = self.equilibrium_species
            fed = inputs.physical[f"feed.{self.mechanism.species_names[a]}"]
            amounts = amounts.at[a].set(fed / (1 + constant)).at[x].set(fed * constant / (1 + constant))
        volumes, solvent = self.mechanism.molar_volumes, self.roles.solvent
        return Liquid(amounts.at[solvent].set((1 - amounts @ volumes) / volumes[solvent]), temperature)

    def units(self, inputs: ChainInputs, profiles: dict | None = None) -> tuple[tuple[str, AbstractUnit], ...]:
        """(name, unit) in the process's order, built for the scene (a dryer without the drying
        effect is left out); `profiles`: unit name -> a temperature profile (a reactor's
        jacket, a crystallizer's cooling)."""
        from ._process_units import build_unit

        mechanism, _ = self.active(inputs)
        built = ((unit.name, build_unit(self, unit, mechanism, (profiles or {}).get(unit.name)))
                 for unit in self.process.units)
        return tuple((name, unit) for name, unit in built if unit is not None)

    def r1(self, inputs: ChainInputs, *, jacket: AbstractTemperatureProfile | None = None):
        """The first unit (a reactor; `inputs` as `active` returns them)."""
        first = self.process.units[0].name
        return dict(self.units(inputs, {first: jacket}))[first]

    def simulate(self, inputs: ChainInputs | CPPs, *, profiles: dict | None = None,
                 r1_jacket: AbstractTemperatureProfile | None = None,
                 cooling: AbstractTemperatureProfile | None = None) -> ChainResult:
        """Run the process at `inputs` (`PharmaChain.inputs`; or `CPPs` alone, with the
        mechanism's rates and the process file's physical parameters). `profiles` (unit name ->
        profile; default: each reactor's jacket constant at its temperature, each cooling the
        linear ramp from the inlet's to the final temperature) may be learned ones; `r1_jacket`
        and `cooling` set the first reactor's and the crystallizer's."""
        if isinstance(inputs, CPPs):
            inputs = self.inputs(inputs)
        profiles = dict(profiles or {})
        kinds = {unit.type: unit.name for unit in reversed(self.process.units)}
        for profile, kind in ((r1_jacket, "plug_flow_reactor"), (cooling, "cooling_crystallizer")):
            if profile is not None:
                profiles[kinds[kind]] = profile
        _, active = self.active(inputs)
        parameters, stream, outlets = self.unit_parameters(inputs), self.feed(inputs), {}
        liquid, seeds = stream, 0.0
        for name, unit in self.units(inputs, profiles):
            liquid = stream if isinstance(stream, Liquid) else liquid
            stream = outlets[name] = unit(stream, parameters[name], active.rates, self.solver)
            seeds = seed_mass(unit, parameters[name]) if hasattr(stream, "crystals") else seeds
        slurry = next(o for o in outlets.values() if hasattr(o, "crystals"))
        cake = next(o for o in outlets.values() if isinstance(o, Solids))
        volumes, api = self.mechanism.molar_volumes, self.roles.api
        # [kmol per m^3 of the crystallizer's liquor]: the first fed species, and the API isolated.
        fed = inputs.physical[f"feed.{next(iter(self.process.feed))}"] / (liquid.amounts @ volumes)
        isolated = stream.api / self.molar_masses[api]
        return ChainResult(outlets, slurry.liquor, slurry.crystals, cake, stream,
                           100 * (isolated - seeds / self.molar_masses[api]) / fed, 100 * isolated / fed)
