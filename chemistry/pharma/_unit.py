"""The unit operations of the chain and the streams between them.

Every unit is a final `equinox.Module` deriving from `AbstractUnit`:
`unit(inlet, inputs, solver) -> outlet`, with `inputs` the chain's `ChainInputs` (CPPs, rate
parameters of the active reactions, physical parameters) and `solver` the `SolverSettings` of
its solve. The chain is then the composition of its units (`PharmaChain.simulate`):

    feed (Liquid) -> R1 -> Liquid -> R2 -> Liquid -> crystallizer -> Slurry -> filter -> Solids
                  -> dryer -> Solids
"""

import abc
from typing import NamedTuple

import equinox as eqx

from snapo_ode import SolverSettings

from ..kinetics._types import Scalar, Vector
from ._parameters import ChainInputs


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
    `other` (retained A, B, X) and `solvent`."""

    api: Scalar
    impurity: Scalar
    degradant: Scalar
    other: Scalar
    solvent: Scalar

    @property
    def solids(self) -> Scalar:
        """Everything but the solvent [kg per m^3 of liquor]."""
        return self.api + self.impurity + self.degradant + self.other

    @property
    def total(self) -> Scalar:
        return self.solids + self.solvent


class AbstractUnit(eqx.Module):
    """A unit operation: `unit(inlet, inputs, solver) -> outlet`."""

    @abc.abstractmethod
    def __call__(self, inlet, inputs: ChainInputs, solver: SolverSettings):
        """The outlet stream of `inlet` at `inputs`, integrated with `solver`."""
