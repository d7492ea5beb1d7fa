"""A process described in a YAML file (`_process_schema`): read, converted to the model's units
and checked, before any compile; every error names the file, the line, the field, the value and
what is allowed. `read_process_file` needs neither Cantera nor JAX (the CLI's options come from
the built-in file); `load_process_spec` also checks the file against its mechanism (Cantera).
"""

import functools
import pathlib
import re
from importlib.resources import files
from typing import NamedTuple

from snapo_ode import MAX_YAML_BYTES, InputError, read_text, strict_yaml, validate

from ._process_schema import ProcessFile
from ._quantities import conversion, in_model_unit
from ._ranges import ParameterRange, Specification
from ._unit_catalogue import FLOWSHEET, UNIT_PARAMETERS, UNIT_ROLES, unit_parameter

BUILT_IN_PROCESS = pathlib.Path(str(files("chemistry.pharma") / "processes" / "api_chain.yaml"))
CQA_UNITS = {"assay": "%", "purity": "%", "mass_fraction": "%", "residual_solvent": "ppm", "loss_on_drying": "%",
             "d43": "um", "yield": "%", "yield_including_seed": "%"}
"""The unit each CQA of the vocabulary is computed in (a file's spec may use any unit that converts)."""
TRACKED_ROLES = ("api", "impurity", "degradant")
"""The roles whose mass in the product the units track one species each of (a CQA's mass_fraction)."""
SOLVENT_ROLES = ("solvent", "antisolvent")
"""The roles whose mass in the product a CQA's {residual_solvent: species} states, one each."""


class UnitSpec(NamedTuple):
    """One unit of a process: `name`, `type` and `parameters` in the model's units (those a CPP
    sets are not here), in the catalogue's order."""

    name: str
    type: str
    parameters: dict


class ProcessSpec(NamedTuple):
    """A process as its file states it, in the model's units: `name`, `description`, the file
    `path`, the `mechanism` (a path, or a name in Cantera's data path) and `phase`,
    `reaction_effects` (equation -> effect), `roles` (species -> role), `molar_masses` the file
    sets [kg/kmol], the `feed` [kmol/m^3] and its `equilibrium` pair, the `units`, the `cpps`
    (`ParameterRange`), the `cqas` (`Specification`) and the `uncertain` parameters."""

    name: str
    description: str
    path: str
    mechanism: str
    phase: str | None
    reaction_effects: dict
    roles: dict
    molar_masses: dict
    feed: dict
    equilibrium: tuple[str, str] | None
    units: tuple[UnitSpec, ...]
    cpps: tuple[ParameterRange, ...]
    cqas: tuple[Specification, ...]
    uncertain: tuple[str, ...]

    def __hash__(self):  # a static field of the chain (its dicts are not hashable)
        return hash(repr(self))

    def physical_defaults(self) -> dict[str, float]:
        """Every parameter no CPP sets, by input name ("feed.A", "crystallizer.growth_rate"), in
        the order of the chain's inputs."""
        values = {f"feed.{species}": value for species, value in self.feed.items()}
        for unit in self.units:
            values.update({f"{unit.name}.{name}": value for name, value in unit.parameters.items()})
        return values

    def species_with_role(self, role: str) -> list[str]:
        return [name for name, r in self.roles.items() if r == role]


class _Where:
    """Names a place of the process in errors: "process file F, line N" (a process given as a
    dict: "process NAME")."""

    def __init__(self, label: str, text: str | None):
        self.label, self.text = label, text

    def __call__(self, key: str, value: str | None = None) -> str:
        """The file and the line of the first `key:` (followed by `value` if given)."""
        if self.text is None:
            return self.label
        pattern = rf"""["']?{re.escape(key)}["']?\s*:""" + ("" if value is None else rf"""\s*["']?{re.escape(value)}\b""")
        match = re.search(pattern, self.text)
        line = "" if match is None else f", line {self.text.count(chr(10), 0, match.start()) + 1}"
        return f"{self.label}{line}"


def _flowsheet(units, where) -> None:
    roles = [UNIT_ROLES[unit.type] for unit in units]
    reactors = roles.index("crystallizer") if "crystallizer" in roles else -1
    expected = ["reactor"] * max(reactors, 0) + ["crystallizer", "filter"] + (["dryer"] if roles[-1:] == ["dryer"] else [])
    if reactors < 1 or roles != expected:
        raise InputError(f"{where('units')}: units = {' -> '.join(u.type for u in units)}; allowed: {FLOWSHEET}.")


def _units(data, cpp_targets: dict, where) -> tuple[UnitSpec, ...]:
    """The units with their parameters in model units, checked against the catalogue."""
    units, names = [], set()
    for unit in data.units:
        if unit.name in names or unit.name == "feed":
            raise InputError(f"{where('name', unit.name)}: unit name {unit.name!r} is used twice (or is 'feed'); "
                             "every unit needs its own name.")
        names.add(unit.name)
        catalogue, given = UNIT_PARAMETERS[unit.type], dict(unit.model_extra)
        unknown = sorted(set(given) - set(catalogue))
        if unknown:
            raise InputError(f"{where(unknown[0])}: {unit.name}.{unknown[0]} is no parameter of a {unit.type}; "
                             f"parameters: {', '.join(catalogue)}.")
        parameters = {}
        for name, info in catalogue.items():
            field = f"{unit.name}.{name}"
            if field in cpp_targets:
                if name in given:
                    raise InputError(f"{where(name)}: {field} is set by the CPP {cpp_targets[field]!r}; give its "
                                     "nominal value there, not here.")
                continue
            if name not in given:
                raise InputError(f"{where('name', unit.name)}: {field} [{info.unit or '-'}] is missing ({info.description}).")
            value = in_model_unit(given[name], info.unit, f"{where(name)}: {field}")
            if not info.low < value < info.high:
                raise InputError(f"{where(name)}: {field} = {value:g} {info.unit}; allowed: ({info.low:g}, {info.high:g}) "
                                 f"{info.unit}, open interval.")
            parameters[name] = value
        units.append(UnitSpec(unit.name, unit.type, parameters))
    return tuple(units)


def _cpps(data, where) -> tuple[ParameterRange, ...]:
    """The CPPs in their targets' model units, each range inside the next."""
    types = {unit.name: unit.type for unit in data.units}
    ranges, names, targets = [], set(), set()
    for cpp in data.cpps:
        at = where("name", cpp.name)
        info = unit_parameter(types, cpp.target)
        if info is None:
            raise InputError(f"{at}: cpps[{cpp.name}].target = {cpp.target!r} is no unit parameter; allowed: "
                             f"unit.parameter of {', '.join(types)}.")
        if cpp.name in names or cpp.target in targets:
            raise InputError(f"{at}: CPP {cpp.name!r} (target {cpp.target}) repeats a name or a target.")
        names.add(cpp.name), targets.add(cpp.target)

        def convert(value, field):
            return in_model_unit(f"{value!r} {cpp.unit}", info.unit, f"{at}: cpps[{cpp.name}].{field}")

        nominal = convert(cpp.nominal, "nominal")
        nor, par = tuple(convert(v, "nor") for v in cpp.nor), tuple(convert(v, "par") for v in cpp.par)
        limits = (info.low, info.high) if cpp.limits is None else tuple(convert(v, "limits") for v in cpp.limits)
        for inner, outer, label in ((nor, par, "nor inside par"), (par, limits, "par inside limits")):
            if not (outer[0] <= inner[0] < inner[1] <= outer[1]):
                raise InputError(f"{at}: cpps[{cpp.name}]: nor = {list(nor)}, par = {list(par)}, limits = "
                                 f"{list(limits)} {info.unit}; allowed: low < high and {label}.")
        if not (nor[0] <= nominal <= nor[1]) or not (limits[0] < nominal < limits[1]):
            raise InputError(f"{at}: cpps[{cpp.name}].nominal = {cpp.nominal:g} {cpp.unit}; allowed: inside the NOR "
                             f"{list(cpp.nor)}.")
        ranges.append(ParameterRange(cpp.name, info.unit, nominal, nor, par, limits, cpp.description or info.description,
                                     cpp.target))
    return tuple(ranges)


def _cqas(data, roles: dict, where) -> tuple[Specification, ...]:
    specs, names = [], set()
    for cqa in data.cqas:
        at = where("name", cqa.name)
        if cqa.name in names:
            raise InputError(f"{at}: CQA name {cqa.name!r} is used twice.")
        names.add(cqa.name)
        if isinstance(cqa.definition, dict) and len(cqa.definition) != 1:
            raise InputError(f"{at}: cqas[{cqa.name}].definition = {cqa.definition}; allowed: one of mass_fraction or "
                             "residual_solvent, with one species.")
        definition = cqa.definition if isinstance(cqa.definition, str) else next(iter(cqa.definition.items()))
        allowed = {"mass_fraction": TRACKED_ROLES, "residual_solvent": SOLVENT_ROLES}
        if isinstance(definition, tuple) and roles.get(definition[1]) not in allowed[definition[0]]:
            raise InputError(f"{at}: cqas[{cqa.name}].definition = {{{definition[0]}: {definition[1]}}}: the species "
                             f"has no role of {', '.join(allowed[definition[0]])} (known: {', '.join(roles)}).")
        word = definition if isinstance(definition, str) else definition[0]
        factor = conversion(CQA_UNITS[word], cqa.unit, f"{at}: cqas[{cqa.name}].unit")
        low, high = (-float("inf") if cqa.low is None else cqa.low), (float("inf") if cqa.high is None else cqa.high)
        if not low < high:
            raise InputError(f"{at}: cqas[{cqa.name}]: low = {cqa.low}, high = {cqa.high}; allowed: at least one, "
                             "low < high.")
        specs.append(Specification(cqa.name, cqa.unit, low, high, cqa.description, definition, factor))
    return tuple(specs)


def _roles(data, where) -> dict:
    roles = {name: entry.role for name, entry in data.species.items()}
    for role in ("api", "solvent", "impurity", "degradant", "antisolvent"):
        count = list(roles.values()).count(role)
        if count != 1 and (role != "antisolvent" or count > 1):
            raise InputError(f"{where('species')}: {count} species with the role {role!r}; the units track exactly one "
                             "API, one solvent, one impurity and one degradant, and at most one antisolvent (more "
                             "reagents, intermediates and byproducts may run).")
    if "antisolvent" not in roles.values() and any(u.type == "antisolvent_crystallizer" for u in data.units):
        raise InputError(f"{where('species')}: an antisolvent_crystallizer needs a species with the role 'antisolvent'.")
    return roles


def read_process_file(path) -> ProcessSpec:
    """The process file at `path`, converted and checked, without its mechanism (no Cantera).

    **Raises:** `InputError` naming the file, the line, the field, the value and what is allowed."""
    path = pathlib.Path(path)
    text = read_text(path, "process", MAX_YAML_BYTES)
    label = f"process file {path}"
    return _process(strict_yaml(text, label), label, text, str(path), path.parent)


def process_from_dict(data: dict, *, name: str = "<python>", directory=".") -> ProcessSpec:
    """A process written in Python: `data` holds the file's sections (plain dicts, lists, numbers
    and strings; a mechanism file relative to `directory`), checked as a file is.

    **Raises:** `InputError` naming the process `name`, the field, the value and what is allowed."""
    return _process(data, f"process {name}", None, name, pathlib.Path(directory))


def _process(raw, label: str, text: str | None, source: str, directory: pathlib.Path) -> ProcessSpec:
    where = _Where(label, text)
    data = validate(ProcessFile, raw, label, text)
    roles = _roles(data, where)
    for name in data.feed.concentrations:
        if name not in roles:
            raise InputError(f"{where('concentrations')}: feed.concentrations names {name!r}, which has no entry in "
                             f"species (known: {', '.join(roles)}).")
    for unit in data.units:
        if unit.type not in UNIT_PARAMETERS:
            raise InputError(f"{where('type', unit.type)}: units[{unit.name}].type = {unit.type!r}; allowed: "
                             f"{', '.join(UNIT_PARAMETERS)}.")
    cpps = _cpps(data, where)
    units = _units(data, {c.target: c.name for c in cpps}, where)
    _flowsheet(units, where)
    feed = {name: in_model_unit(value, "kmol/m^3", f"{where(name)}: feed.concentrations.{name}")
            for name, value in data.feed.concentrations.items()}
    masses = {name: in_model_unit(entry.molar_mass, "kg/kmol", f"{where(name)}: species.{name}.molar_mass")
              for name, entry in data.species.items() if entry.molar_mass is not None}
    effects = {equation: effect for effect, equations in data.mechanism.effects.items() for equation in equations}
    pair = data.feed.equilibrium
    mechanism = data.mechanism.file
    if (directory / mechanism).is_file():
        mechanism = str((directory / mechanism).resolve())
    spec = ProcessSpec(data.name, data.description, source, mechanism, data.mechanism.phase, effects, roles, masses, feed,
                       None if pair is None else (pair.forward, pair.reverse), units, cpps, _cqas(data, roles, where),
                       tuple(data.uncertain))
    known = set(spec.physical_defaults())
    for name in spec.uncertain:
        if not name.startswith("log_multiplier[") and name not in known:
            raise InputError(f"{where('uncertain')}: uncertain names {name!r}; allowed: log_multiplier[equation] or a "
                             "unit parameter no CPP sets (unit.parameter).")
    return spec


@functools.cache
def built_in_process() -> ProcessSpec:
    return read_process_file(BUILT_IN_PROCESS)


def load_process(path=None) -> ProcessSpec:
    """The process file at `path` (default: the built-in `processes/api_chain.yaml`; the name of a
    shipped process, such as "antisolvent_route", is found in `chemistry/pharma/processes`), read
    and checked (`read_process_file`); its mechanism is checked when the chain is built."""
    shipped = BUILT_IN_PROCESS.parent / f"{path}.yaml"
    if path is not None and not pathlib.Path(path).exists() and shipped.is_file():
        path = shipped
    if path is None or pathlib.Path(path).resolve() == BUILT_IN_PROCESS.resolve():
        return built_in_process()
    return read_process_file(path)


BUILT_IN = built_in_process()
CPP_RANGES = BUILT_IN.cpps
"""The built-in process's CPPs (`ParameterRange`), read from its file without Cantera or JAX (the
CLI builds its options from them)."""
CPP_NAMES = tuple(spec.name for spec in CPP_RANGES)
CQA_SPECS = BUILT_IN.cqas
"""The built-in process's CQAs (`Specification`)."""
CQA_NAMES = tuple(spec.name for spec in CQA_SPECS)
