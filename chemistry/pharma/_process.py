"""A process checked against its mechanism (Cantera): every species has a role and every role a
species, the reactions the file names exist, the phase is a liquid; the molar masses come from
the mechanism's elements unless the file states one. And the process's inputs: its CPPs
(`make_cpps`) and physical parameters (`physical_parameters`), checked before any compile."""

import pathlib

import cantera
import jax.numpy as jnp
import numpy as np

from snapo_ode import InputError, check_range, line_of

from ..kinetics._sources import checked_file
from ._parameters import CPPs, PhysicalParameters
from ._process_file import ProcessSpec, built_in_process


def _solution(spec: ProcessSpec):
    where = f"process {spec.path}: mechanism {spec.mechanism!r}"
    try:
        return cantera.Solution(str(checked_file(spec.mechanism)), spec.phase or "")
    except cantera.CanteraError as error:
        message = " ".join(str(error).split())[:300]
        raise InputError(f"{where} does not load in Cantera ({message}).") from None


def _where(spec: ProcessSpec, key: str) -> str:
    """"process file F, line N" of the first `key:` in the process's file (a process given as a
    dict: "process NAME")."""
    path = pathlib.Path(spec.path)
    if not path.is_file():
        return f"process {spec.path}"
    return f"process file {path}{line_of(path.read_text(errors='replace'), [key])}"


def check_mechanism(spec: ProcessSpec, species_names, reaction_equations, thermo_model: str) -> None:
    """Refuse a process whose mechanism lacks what the file names, or names a species without a
    role. **Raises:** `InputError` naming the process file, the line and the species or reaction
    (the file is read again only to name the line of an error)."""
    for name in species_names:
        if name not in spec.roles:
            raise InputError(f"{_where(spec, 'species')}: species {name!r} of the mechanism has no role; give it one "
                             "under species (api, impurity, degradant, solvent, reagent, byproduct).")
    for name in spec.roles:
        if name not in species_names:
            raise InputError(f"{_where(spec, 'species')}: species {name!r} is not in the mechanism (species: "
                             f"{', '.join(species_names)}).")
    named = [*spec.reaction_effects, *(spec.equilibrium or ())]
    named += [n[len("log_multiplier["):-1] for n in spec.uncertain if n.startswith("log_multiplier[")]
    for equation in named:
        if equation not in reaction_equations:
            raise InputError(f"{_where(spec, 'mechanism')}: reaction {equation!r} is not in the mechanism (reactions: "
                             f"{'; '.join(reaction_equations)}).")
    if thermo_model != "ideal-condensed":
        raise InputError(f"{_where(spec, 'mechanism')}: the mechanism's thermo is {thermo_model!r}; a process is a "
                         "liquid: 'ideal-condensed'.")


def molar_masses(spec: ProcessSpec) -> dict[str, float]:
    """Every species' molar mass [kg/kmol]: the file's where it gives one, else Cantera's from
    the mechanism's elements."""
    solution = _solution(spec)
    return {name: spec.molar_masses.get(name, float(mass))
            for name, mass in zip(solution.species_names, solution.molecular_weights, strict=True)}


def make_cpps(process: ProcessSpec | None = None, **values: float) -> CPPs:
    """The CPPs of `process` (default: the built-in) from keyword values, the others at their
    nominal, checked against the physical limits.

    **Raises:** `InputError` naming the field for an unknown name or a value outside its
    physical limits (for the built-in: negative times, temperatures at or below the solvent's
    freezing point, R1 at or above its boiling point). A value outside the proven acceptable
    range is allowed (see `outside_par`) and reported as a warning."""
    ranges = (process or built_in_process()).cpps
    names = tuple(spec.name for spec in ranges)
    unknown = sorted(set(values) - set(names))
    if unknown:
        raise InputError(f"unknown CPP {unknown[0]!r}; CPPs: {', '.join(names)}.")
    chosen = []
    for spec in ranges:
        value = values.get(spec.name, spec.nominal)
        check_range(f"{spec.name} [{spec.unit}]", value, *spec.physical, low_open=True, high_open=True)
        chosen.append(jnp.asarray(float(value)))
    return CPPs(names, tuple(chosen))


def outside_par(cpps: CPPs, process: ProcessSpec | None = None) -> list[str]:
    """Warnings, one per CPP outside its proven acceptable range."""
    warnings = []
    for spec in (process or built_in_process()).cpps:
        value = float(cpps[spec.name])
        if not spec.par[0] <= value <= spec.par[1]:
            warnings.append(f"{spec.name} = {value:g} {spec.unit} is outside its proven acceptable range "
                            f"[{spec.par[0]:g}, {spec.par[1]:g}]: the model is extrapolating.")
    return warnings


def physical_parameters(process: ProcessSpec | None = None, **overrides: float) -> PhysicalParameters:
    """The physical parameters of `process` (default: the built-in) as its file gives them, with
    `overrides` by input name ("crystallizer.growth_rate"; checked: positive, finite).

    **Raises:** `InputError` for an unknown name or a value that is not a positive number."""
    values = (process or built_in_process()).physical_defaults()
    for name, value in overrides.items():
        if name not in values:
            raise InputError(f"unknown physical parameter {name!r}; parameters: {', '.join(values)}.")
        check_range(name, value, 0.0, np.inf, low_open=True)
        values[name] = float(value)
    return PhysicalParameters(tuple(values), tuple(jnp.asarray(value) for value in values.values()))


def default_physical_parameters(**overrides: float) -> PhysicalParameters:
    """The built-in process's physical parameters, with `overrides` (`physical_parameters`)."""
    return physical_parameters(None, **overrides)
