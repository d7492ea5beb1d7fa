"""The unit operations of the chain and the streams between them.

Every unit is a final `equinox.Module` deriving from `AbstractUnit`:
`unit(inlet, parameters, rates, solver) -> outlet`, with `parameters` the unit's own (name ->
float scalar, in the unit catalogue's model units; a CPP's value where a CPP sets one), `rates`
the rate parameters of the active reactions and `solver` the `SolverSettings` of its solve. A
process is then the composition of its units (`PharmaChain.simulate`), e.g. the built-in:

    feed (Liquid) -> r1 -> Liquid -> r2 -> Liquid -> crystallizer -> Slurry -> filter -> Solids
                  -> dryer -> Solids
"""

import abc
from typing import NamedTuple

import equinox as eqx

from snapo_ode import SolverSettings

from chemistry import RateParameters

from ..kinetics._types import Scalar, Vector


class Liquid(NamedTuple):
    """A liquid stream: `amounts` y_k [kmol per m^3 of the unit's initial volume], shape
    (n_species,); `temperature` [K]."""

    amounts: Vector
    temperature: Scalar

    def concentrations(self, molar_volumes) -> Vector:
        """Molar concentrations [kmol/m^3] (the volume from the ideal-condensed mixing rule)."""
        return self.amounts / (self.amounts @ molar_volumes)


class Solids(NamedTuple):
    """A cake or a dried product, masses [kg per m^3 of liquor]: `api`, `impurity`, `degradant`,
    `other` (retained reagents, intermediates, byproducts) and `solvent` (the solvent and the
    antisolvent); `by_solvent`: `solvent` split by species, in the order of
    `SpeciesRoles.solvents` (the solvent, then the antisolvent), shape (1,) or (2,), or None
    where the unit that made it does not track the split."""

    api: Scalar
    impurity: Scalar
    degradant: Scalar
    other: Scalar
    solvent: Scalar
    by_solvent: Vector | None = None

    @property
    def solids(self) -> Scalar:
        """Everything but the solvent [kg per m^3 of liquor]."""
        return self.api + self.impurity + self.degradant + self.other

    @property
    def total(self) -> Scalar:
        return self.solids + self.solvent


class AbstractUnit(eqx.Module):
    """A unit operation: `unit(inlet, parameters, rates, solver) -> outlet`."""

    @abc.abstractmethod
    def __call__(self, inlet, parameters: dict, rates: RateParameters, solver: SolverSettings):
        """The outlet stream of `inlet` with the unit's `parameters` (name -> scalar) and the
        active reactions' `rates`, integrated with `solver`."""
