"""The process file's schema (pydantic, strict): its sections, their fields and types. Names,
units, ranges and the rules between sections are checked by `_process_file.load_process_spec`."""

from typing import Annotated, Literal

import pydantic

from snapo_ode import STRICT_SCHEMA, FiniteNumber

Name = pydantic.constr(pattern=r"^[A-Za-z][A-Za-z0-9_]{0,39}$")  # a unit's or a CPP's name
Value = FiniteNumber | pydantic.StrictStr  # a number in the model's unit, or "30 min"
Pair = pydantic.conlist(FiniteNumber, min_length=2, max_length=2)
ROLES = ("api", "impurity", "degradant", "solvent", "antisolvent", "reagent", "intermediate", "byproduct")


class _Section(pydantic.BaseModel):
    model_config = STRICT_SCHEMA


class MechanismSection(_Section):
    """The kinetics: a Cantera-YAML `file` (relative to the process file, or a name in Cantera's
    data path) and its `phase` (default: the file's first); `effects`: which effect switches
    each reaction (equations as written in the file; the others always run)."""

    file: pydantic.StrictStr
    phase: pydantic.StrictStr | None = None
    effects: dict[Literal["side_reactions", "degradation"], list[pydantic.StrictStr]] = {}


class SpeciesEntry(_Section):
    """A species' `role` in the process, and optionally its `molar_mass` (default: the
    mechanism's, from its elements)."""

    role: Literal[ROLES]
    molar_mass: Value | None = None


class EquilibriumPair(_Section):
    """A fast reversible pair written as two irreversible reactions."""

    forward: pydantic.StrictStr
    reverse: pydantic.StrictStr


class FeedSection(_Section):
    """The first reactor's feed: `concentrations` of the species fed [kmol/m^3] (the solvent fills
    the rest of the volume); `equilibrium`: a fast reversible pair, as two irreversible reactions
    ("forward", "reverse"), fed at its equilibrium when both reactions run."""

    concentrations: dict[pydantic.StrictStr, Value]
    equilibrium: EquilibriumPair | None = None


class UnitEntry(_Section):
    """One unit: its `name`, `type` and parameters (the other keys)."""

    model_config = pydantic.ConfigDict(strict=True, extra="allow", frozen=True)
    name: Name
    type: pydantic.StrictStr


class CPPEntry(_Section):
    """A critical process parameter: `name`, the unit parameter it sets (`target`,
    "unit.parameter"), `nominal`, normal operating range `nor`, proven acceptable range `par`,
    physical `limits` (open interval; default the target's), all in `unit`."""

    name: Name
    target: pydantic.StrictStr
    unit: pydantic.StrictStr
    nominal: FiniteNumber
    nor: Pair
    par: Pair
    limits: Pair | None = None
    description: pydantic.StrictStr = ""


class CQAEntry(_Section):
    """A critical quality attribute: `name`, its `definition` (a word of the vocabulary,
    {mass_fraction: species} or {residual_solvent: species}), its spec `low` and/or `high` and
    `unit`."""

    name: Name
    definition: (Literal["assay", "purity", "residual_solvent", "loss_on_drying", "d43", "yield",
                         "yield_including_seed"]
                  | Annotated[dict[Literal["mass_fraction", "residual_solvent"], pydantic.StrictStr],
                              pydantic.Field(min_length=1)])
    unit: pydantic.StrictStr
    low: FiniteNumber | None = None
    high: FiniteNumber | None = None
    description: pydantic.StrictStr = ""


class ProcessFile(_Section):
    """A process: `name`, `mechanism`, `species` (name -> role), `feed`, `units` in order, `cpps`,
    `cqas`, and the `uncertain` parameters of the design space (names as the sensitivities name
    them)."""

    name: pydantic.StrictStr
    description: pydantic.StrictStr = ""
    mechanism: MechanismSection
    species: dict[pydantic.StrictStr, SpeciesEntry]
    feed: FeedSection
    units: pydantic.conlist(UnitEntry, min_length=1, max_length=20)
    cpps: pydantic.conlist(CPPEntry, min_length=1, max_length=20)
    cqas: pydantic.conlist(CQAEntry, min_length=1, max_length=20)
    uncertain: list[pydantic.StrictStr] = []
