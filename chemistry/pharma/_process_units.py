"""The unit types a process may name, as the chain builds them for a scene: `build_unit` returns
the unit module a process's entry stands for, or None for a unit the scene leaves out (a dryer
without the drying effect). `register_unit_type` adds a type from outside the package: a user's
own `AbstractUnit` class with its parameters, in a process file or a `process_from_dict`."""

from typing import Callable

from chemistry import Mechanism
from snapo_ode import InputError

from ._crystallizer import AntisolventCrystallizer, CoolingCrystallizer, Crystallizer, EquilibriumIsolation
from ._cstr import SteadyStateCSTR
from ._dryer import Dryer
from ._filter import Filter
from ._liquid import HoldReactor, LiquidBatch, SynthesisReactor
from ._unit import AbstractUnit
from ._unit_catalogue import UNIT_PARAMETERS, UNIT_ROLES, Parameter


def _plug_flow(chain, unit, mechanism, profile):
    return SynthesisReactor(LiquidBatch(mechanism, chain.scene.has("energy_balance")), profile)


def _batch(chain, unit, mechanism, profile):
    return HoldReactor(LiquidBatch(mechanism, False), profile)


def _cstr(chain, unit, mechanism, profile):
    return SteadyStateCSTR(mechanism)


def _cooling_crystallizer(chain, unit, mechanism, profile):
    roles, scene = chain.roles, chain.scene
    api_molar_mass, volumes = chain.masses[roles.api], chain.mechanism.molar_volumes
    if not scene.has("crystallization"):
        return EquilibriumIsolation(api_molar_mass, volumes, roles)
    incorporated = (chain.masses[roles.impurity], chain.masses[roles.degradant])
    return CoolingCrystallizer(Crystallizer(api_molar_mass, scene.has("impurity_incorporation"), incorporated), volumes,
                               roles, profile)


def _antisolvent_crystallizer(chain, unit, mechanism, profile):
    roles, scene = chain.roles, chain.scene
    incorporated = (chain.masses[roles.impurity], chain.masses[roles.degradant])
    physics = Crystallizer(chain.masses[roles.api], scene.has("impurity_incorporation"), incorporated)
    return AntisolventCrystallizer(physics, chain.mechanism.molar_volumes, roles, roles.antisolvent, profile)


def _filter(chain, unit, mechanism, profile):
    return Filter(chain.molar_masses, chain.roles)


def _dryer(chain, unit, mechanism, profile):
    return Dryer(chain.scene.has("degradation")) if chain.scene.has("drying") else None


BUILDERS: dict[str, Callable] = {"plug_flow_reactor": _plug_flow, "batch_reactor": _batch, "cstr": _cstr,
                                 "cooling_crystallizer": _cooling_crystallizer,
                                 "antisolvent_crystallizer": _antisolvent_crystallizer, "filter": _filter, "dryer": _dryer}
"""type -> build(chain, unit, mechanism, profile) -> the unit (or None: left out of the scene)."""


def register_unit_type(name: str, parameters: dict[str, Parameter], role: str, build: Callable) -> None:
    """Add the unit type `name`: its `parameters` (name -> `Parameter`: model unit, description,
    open interval), its `role` in the flowsheet ("reactor": a `Liquid` in and out, "crystallizer",
    "filter" or "dryer") and `build(chain, unit, mechanism, profile)`, which returns the
    `AbstractUnit` for a process's entry `unit` (a `UnitSpec`) on the active reactions'
    `mechanism`, or None to leave it out.

    **Raises:** `InputError` for a name already registered or an unknown role."""
    if name in UNIT_PARAMETERS:
        raise InputError(f"unit type {name!r} is registered already; types: {', '.join(UNIT_PARAMETERS)}.")
    if role not in set(UNIT_ROLES.values()):
        raise InputError(f"role = {role!r}; allowed: {', '.join(sorted(set(UNIT_ROLES.values())))}.")
    UNIT_PARAMETERS[name], UNIT_ROLES[name], BUILDERS[name] = dict(parameters), role, build


def build_unit(chain, unit, mechanism: Mechanism, profile=None) -> AbstractUnit | None:
    """The unit `unit` (a `UnitSpec`) of `chain`'s process on the reduced `mechanism`, with a
    learned temperature `profile` where one is given (a plug-flow reactor's jacket, a
    crystallizer's cooling)."""
    return BUILDERS[unit.type](chain, unit, mechanism, profile)  # the loader refuses unknown types first
