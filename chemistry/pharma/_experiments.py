"""A chemist's kinetic experiments and their measurements, read for a fit: the experiments file
(YAML: each run's name, the process's reactor it runs in, its temperature and its initial
charges) and the data file (CSV, long format `experiment, time, species, value` with an optional
`sd`, units in the header). Both go through the one reading path (`read_yaml`, `number_text`);
every refusal is one `InputError` line naming the file, the line, the field and what is allowed,
before any compile.

An experiment is an isothermal batch of the reactor's liquid (the unit's own reactions at the
stated temperature) from its charges, the rest of the volume solvent, sampled at the data's
times: the kinetic runs a process chemist makes in a lab reactor before the plant runs the unit.

Experiments file::

    experiments:
      - name: run_40C
        unit: r1                               # a reactor of the process
        temperature: 40 degC                   # or conditions: {r1_temperature: 313.15 K}
        charges: {A: 0.33 mol/L, B: 0.363 mol/L}
    error_model:                               # optional, per measured species
      P: {constant: 0.002 mol/L, proportional: 0.02}

Data file::

    experiment,time [min],species,value [mol/L],sd [mol/L]
    run_40C,5,P,0.0412,0.002
"""

import csv
import io
import math
from typing import NamedTuple

import numpy as np

from snapo_ode import MAX_YAML_BYTES, InputError, number_text, read_text, read_yaml

from ._process_file import ProcessSpec, _Where
from ._quantities import conversion, in_model_unit
from ._unit_catalogue import UNIT_ROLES

MAX_DATA_BYTES = 16 * 2**20  # a data file: 16 MiB (about 300,000 rows)
MAX_EXPERIMENTS = 1_000
CONCENTRATION_UNIT = "kmol/m^3"  # the model's (mol/L)
TIME_UNIT = "min"


class Experiment(NamedTuple):
    """One kinetic run: `name`, the reactor `unit` it runs in, its `temperature` [K] and its
    `charges` (species -> [kmol/m^3] at the start)."""

    name: str
    unit: str
    temperature: float
    charges: dict


class ErrorModel(NamedTuple):
    """The standard deviation of a species' measurement, sqrt(constant^2 + (proportional * value)^2):
    `constant` [kmol/m^3], `proportional` [-]."""

    constant: float
    proportional: float

    def sd(self, values: np.ndarray) -> np.ndarray:
        return np.sqrt(self.constant ** 2 + (self.proportional * values) ** 2)


class Measurements(NamedTuple):
    """The data, one row per measurement, sorted by experiment then time: `experiment` (index
    into the experiments), `time` [min], `species` (name), `value` [kmol/m^3], `sd` [kmol/m^3]
    (NaN where the file gives none) and `line` (the file's line, for messages)."""

    experiment: np.ndarray
    time: np.ndarray
    species: tuple[str, ...]
    value: np.ndarray
    sd: np.ndarray
    line: np.ndarray


class LabData(NamedTuple):
    """The experiments, the `error_model` (species -> `ErrorModel`) and the measurements."""

    experiments: tuple[Experiment, ...]
    error_model: dict
    measurements: Measurements

    def sd(self) -> np.ndarray:
        """Each measurement's standard deviation [kmol/m^3]: the file's `sd`, else the error
        model's at the measured value, else NaN (unknown: the fit estimates one common scale)."""
        m = self.measurements
        sd = m.sd.copy()
        for species, model in self.error_model.items():
            rows = np.flatnonzero(np.isnan(sd) & (np.asarray(m.species) == species))
            sd[rows] = model.sd(np.abs(m.value[rows]))
        return sd


def _temperature(entry: dict, unit: str, process: ProcessSpec, where) -> float:
    """The run's temperature [K]: `temperature`, or `conditions` naming the unit's temperature by
    a CPP's name or as unit.temperature (as `--set` takes them)."""
    conditions = entry.get("conditions") or {}
    if not isinstance(conditions, dict):
        raise InputError(f"{where('conditions')}: conditions = {conditions!r}; allowed: a mapping NAME: VALUE.")
    aliases = {cpp.name: cpp.target for cpp in process.cpps}
    items = list(conditions.items()) + ([("temperature", entry["temperature"])] if "temperature" in entry else [])
    temperature = None
    for name, value in items:
        target = f"{unit}.temperature" if name == "temperature" else aliases.get(name, name)
        if target != f"{unit}.temperature":
            raise InputError(f"{where(name)}: condition {name!r} is not the temperature of {unit}; an experiment sets "
                             f"{unit}.temperature (or the CPP that targets it: "
                             f"{', '.join(n for n, t in aliases.items() if t == f'{unit}.temperature') or 'none'}).")
        temperature = in_model_unit(value, "K", f"{where(name)}: experiments[{entry['name']}].{name}")
    if temperature is None:
        raise InputError(f"{where('name', entry.get('name'))}: experiment {entry.get('name')!r} states no temperature; "
                         "give temperature: (such as 40 degC).")
    if not 150.0 < temperature < 700.0:
        raise InputError(f"{where('temperature')}: temperature = {temperature:g} K; allowed: (150, 700) K.")
    return temperature


def _experiment(entry, process: ProcessSpec, species: tuple[str, ...], where) -> Experiment:
    if not isinstance(entry, dict) or not isinstance(entry.get("name"), str) or not entry["name"]:
        raise InputError(f"{where('experiments')}: an experiment = {entry!r}; allowed: a mapping with name, unit, "
                         "temperature and charges.")
    name = entry["name"]
    unknown = sorted(set(entry) - {"name", "unit", "temperature", "conditions", "charges", "description"})
    if unknown:
        raise InputError(f"{where(unknown[0])}: experiments[{name}].{unknown[0]} is not a field; allowed: name, unit, "
                         "temperature, conditions, charges, description.")
    reactors = [u.name for u in process.units if UNIT_ROLES[u.type] == "reactor"]
    unit = entry.get("unit", reactors[0] if reactors else None)
    if unit not in reactors:
        raise InputError(f"{where('unit', str(unit))}: experiments[{name}].unit = {unit!r}; allowed: a reactor of the "
                         f"process ({', '.join(reactors) or 'none'}).")
    charges = entry.get("charges")
    if not isinstance(charges, dict) or not charges:
        raise InputError(f"{where('name', name)}: experiments[{name}].charges = {charges!r}; allowed: a mapping "
                         "SPECIES: concentration (such as A: 0.33 mol/L).")
    amounts = {}
    for key, value in charges.items():
        if key not in species:
            raise InputError(f"{where(str(key))}: experiments[{name}].charges names {key!r}, no species of the "
                             f"mechanism; species: {', '.join(species)}.")
        amount = in_model_unit(value, CONCENTRATION_UNIT, f"{where(str(key))}: experiments[{name}].charges.{key}")
        if not 0.0 <= amount < 100.0:
            raise InputError(f"{where(str(key))}: experiments[{name}].charges.{key} = {amount:g} kmol/m^3; allowed: "
                             "[0, 100) kmol/m^3 (mol/L).")
        amounts[key] = amount
    return Experiment(name, unit, _temperature(entry, unit, process, where), amounts)


def _error_model(raw, species: tuple[str, ...], where) -> dict:
    if raw is None:
        return {}
    if not isinstance(raw, dict):
        raise InputError(f"{where('error_model')}: error_model = {raw!r}; allowed: SPECIES: {{constant, proportional}}.")
    models = {}
    for key, entry in raw.items():
        at = where(str(key))
        if key not in species:
            raise InputError(f"{at}: error_model names {key!r}, no species; species: {', '.join(species)}.")
        if not isinstance(entry, dict) or not entry or set(entry) - {"constant", "proportional"}:
            raise InputError(f"{at}: error_model.{key} = {entry!r}; allowed: constant (a concentration) and/or "
                             "proportional (a fraction).")
        constant = in_model_unit(entry.get("constant", 0.0), CONCENTRATION_UNIT, f"{at}: error_model.{key}.constant")
        proportional = in_model_unit(entry.get("proportional", 0.0), "", f"{at}: error_model.{key}.proportional")
        if constant < 0 or not 0 <= proportional < 1 or constant + proportional == 0:
            raise InputError(f"{at}: error_model.{key}: constant = {constant:g} kmol/m^3, proportional = "
                             f"{proportional:g}; allowed: both >= 0, proportional < 1, not both 0.")
        models[key] = ErrorModel(constant, proportional)
    return models


def read_experiments(path, process: ProcessSpec, species: tuple[str, ...]) -> tuple[tuple[Experiment, ...], dict]:
    """The experiments and the error model of the experiments file at `path`, checked against
    `process` and the mechanism's `species`.

    **Raises:** `InputError` (file and line) for a file that is not one, an unknown field, unit,
    species or condition, a temperature or charge out of range, or a name given twice."""
    label = f"experiments file {path}"
    text = read_text(path, "experiments", MAX_YAML_BYTES)
    data = read_yaml(text, label)
    where = _Where(label, text)
    if not isinstance(data, dict) or not isinstance(data.get("experiments"), list) or not data["experiments"]:
        raise InputError(f"{label}: expected a mapping with a non-empty list 'experiments' (docs/pharma_fit.md).")
    unknown = sorted(set(data) - {"experiments", "error_model", "description"})
    if unknown:
        raise InputError(f"{where(unknown[0])}: {unknown[0]!r} is not a field; allowed: experiments, error_model, "
                         "description.")
    if len(data["experiments"]) > MAX_EXPERIMENTS:
        raise InputError(f"{label}: {len(data['experiments']):,} experiments; allowed: at most {MAX_EXPERIMENTS:,}.")
    experiments = tuple(_experiment(entry, process, species, where) for entry in data["experiments"])
    names = [e.name for e in experiments]
    twice = next((n for n in names if names.count(n) > 1), None)
    if twice is not None:
        raise InputError(f"{where('name', twice)}: experiment name {twice!r} is used twice.")
    return experiments, _error_model(data.get("error_model"), species, where)


def _header(fields: list[str], label: str) -> dict:
    """column -> (index, unit) from the header `experiment, time [min], species, value [mol/L], sd`."""
    columns = {}
    for index, field in enumerate(fields):
        name, _, rest = field.strip().partition("[")
        name = name.strip().lower()
        if name not in ("experiment", "time", "species", "value", "sd") or name in columns:
            raise InputError(f"{label}, line 1: column {field.strip()!r}; allowed: experiment, time [unit], species, "
                             "value [unit], sd [unit] (optional), each once.")
        if rest and not rest.rstrip().endswith("]"):
            raise InputError(f"{label}, line 1: column {field.strip()!r}: a unit is written in brackets, such as "
                             "time [min].")
        columns[name] = (index, rest.rstrip()[:-1].strip() if rest else None)
    missing = [name for name in ("experiment", "time", "species", "value") if name not in columns]
    if missing:
        raise InputError(f"{label}, line 1: no column {missing[0]!r}; the columns are experiment, time [unit], "
                         "species, value [unit] and optionally sd [unit].")
    return columns


def read_measurements(path, experiments: tuple[Experiment, ...], species: tuple[str, ...]) -> Measurements:
    """The data file at `path` in the model's units (time [min], concentrations [kmol/m^3]).

    **Raises:** `InputError` naming the file and line for a missing or unknown column, a unit that
    does not convert, an unknown experiment or species, a cell that is not a decimal number, a
    negative time or sd, times not increasing within an experiment and species, or an experiment
    without data."""
    label = f"data file {path}"
    text = read_text(path, "data", MAX_DATA_BYTES)
    rows = list(csv.reader(io.StringIO(text)))
    if not rows:
        raise InputError(f"{label}: empty; expected a header experiment, time [min], species, value [mol/L].")
    columns = _header(rows[0], label)
    factors = {name: conversion(unit or ("min" if name == "time" else CONCENTRATION_UNIT),
                                TIME_UNIT if name == "time" else CONCENTRATION_UNIT, f"{label}, line 1: {name}")
               for name, (_, unit) in columns.items() if name in ("time", "value", "sd")}
    if any(unit is None for name, (_, unit) in columns.items() if name in ("time", "value", "sd")):
        name = next(n for n, (_, u) in columns.items() if n in ("time", "value", "sd") and u is None)
        raise InputError(f"{label}, line 1: column {name!r} states no unit; write it as {name} [unit] "
                         f"(such as {'time [min]' if name == 'time' else name + ' [mol/L]'}).")
    index = {e.name: k for k, e in enumerate(experiments)}
    out = {"experiment": [], "time": [], "species": [], "value": [], "sd": [], "line": []}
    last: dict = {}
    for line, row in enumerate(rows[1:], start=2):
        if not row or all(not cell.strip() for cell in row):
            continue
        at = f"{label}, line {line}"
        if len(row) != len(rows[0]):
            raise InputError(f"{at}: {len(row)} cells; the header has {len(rows[0])}.")
        cell = {name: row[i].strip() for name, (i, _) in columns.items()}
        if cell["experiment"] not in index:
            raise InputError(f"{at}: experiment = {cell['experiment']!r} is not in the experiments file; known: "
                             f"{', '.join(index)}.")
        if cell["species"] not in species:
            raise InputError(f"{at}: species = {cell['species']!r} is no species of the mechanism; species: "
                             f"{', '.join(species)}.")
        time = number_text(cell["time"], at, "time") * factors["time"]
        value = number_text(cell["value"], at, "value") * factors["value"]
        sd = number_text(cell["sd"], at, "sd") * factors["sd"] if cell.get("sd") else math.nan
        if time < 0:
            raise InputError(f"{at}: time = {cell['time']}; allowed: >= 0.")
        if not (sd > 0 or math.isnan(sd)):
            raise InputError(f"{at}: sd = {cell['sd']}; allowed: > 0.")
        key = (cell["experiment"], cell["species"])
        if key in last and time <= last[key]:
            raise InputError(f"{at}: time = {cell['time']} is not after the previous sample of {key[1]} in "
                             f"{key[0]}; times increase within an experiment and species.")
        last[key] = time
        for name, item in (("experiment", index[cell["experiment"]]), ("time", time), ("species", cell["species"]),
                           ("value", value), ("sd", sd), ("line", line)):
            out[name].append(item)
    silent = [e.name for e in experiments if index[e.name] not in set(out["experiment"])]
    if silent:
        raise InputError(f"{label}: experiment {silent[0]!r} has no data; give its samples or leave it out of the "
                         "experiments file.")
    order = np.lexsort((np.asarray(out["time"]), np.asarray(out["experiment"])))
    return Measurements(np.asarray(out["experiment"])[order], np.asarray(out["time"], float)[order],
                        tuple(np.asarray(out["species"])[order]), np.asarray(out["value"], float)[order],
                        np.asarray(out["sd"], float)[order], np.asarray(out["line"])[order])


def read_lab_data(experiments_path, data_path, process: ProcessSpec, species: tuple[str, ...]) -> LabData:
    """The experiments file and the data file together (`read_experiments`, `read_measurements`)."""
    experiments, error_model = read_experiments(experiments_path, process, species)
    return LabData(experiments, error_model, read_measurements(data_path, experiments, species))
