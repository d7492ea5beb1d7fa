"""The unit types of the catalogue (`_unit_catalogue`) as the chain builds them for a scene:
`build_unit` returns the unit module a process file's entry stands for, or None for a unit the
scene leaves out (a dryer without the drying effect)."""

from chemistry import Mechanism

from ._crystallizer import CoolingCrystallizer, Crystallizer, EquilibriumIsolation
from ._dryer import Dryer
from ._filter import Filter
from ._liquid import HoldReactor, LiquidBatch, SynthesisReactor
from ._unit import AbstractUnit


def build_unit(chain, unit, mechanism: Mechanism, profile=None) -> AbstractUnit | None:
    """The unit `unit` (a `UnitSpec`) of `chain`'s process on the reduced `mechanism`, with a
    learned temperature `profile` where one is given (a plug-flow reactor's jacket, a
    crystallizer's cooling)."""
    scene, roles = chain.scene, chain.roles
    if unit.type == "plug_flow_reactor":
        return SynthesisReactor(LiquidBatch(mechanism, scene.has("energy_balance")), profile)
    if unit.type == "batch_reactor":
        return HoldReactor(LiquidBatch(mechanism, False))
    if unit.type == "cooling_crystallizer":
        api_molar_mass = chain.masses[roles.api]
        volumes = chain.mechanism.molar_volumes
        if scene.has("crystallization"):
            incorporated = (chain.masses[roles.impurity], chain.masses[roles.degradant])
            physics = Crystallizer(api_molar_mass, scene.has("impurity_incorporation"), incorporated)
            return CoolingCrystallizer(physics, volumes, roles, profile)
        return EquilibriumIsolation(api_molar_mass, volumes, roles)
    if unit.type == "filter":
        return Filter(chain.molar_masses, roles)
    if unit.type == "dryer":
        return Dryer(scene.has("degradation")) if scene.has("drying") else None
    raise ValueError(f"unit type {unit.type!r} has no builder")  # the loader refuses unknown types first
