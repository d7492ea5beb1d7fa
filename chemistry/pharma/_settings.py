"""`--set NAME=VALUE` and the built-in chain's CPP flags as a process's CPP values and physical
parameters (no JAX): a CPP by its name or its target ("r1_temperature", "r1.temperature"), a
physical parameter by its input name ("crystallizer.growth_rate", "feed.A"); a value may carry a
unit ("0.5 h"), converted to the model's."""

from snapo_ode import InputError

from ._process_file import ProcessSpec
from ._quantities import in_model_unit
from ._unit_catalogue import unit_parameter


def _model_unit(process: ProcessSpec, name: str) -> str:
    if name.startswith("feed."):
        return "kmol/m^3"
    return unit_parameter({u.name: u.type for u in process.units}, name).unit


def settings_values(process: ProcessSpec, flags: dict, settings: list[str]) -> tuple[dict, dict]:
    """(CPP values by name, physical parameters by name) from the CPP `flags` (name -> value,
    the built-in chain's `--r1-temperature` ...) and the `--set` `settings`.

    **Raises:** `InputError` naming the setting for one without '=', an unknown name, a flag of a
    CPP the process does not have, a value set twice, or a value that does not convert."""
    cpps = {spec.name: spec for spec in process.cpps}
    targets = {spec.target: spec.name for spec in process.cpps}
    physical = set(process.physical_defaults())
    cpp_values, physical_values = {}, {}
    for name, value in flags.items():
        if name not in cpps:
            raise InputError(f"--{name.replace('_', '-')}: process {process.name!r} has no CPP {name!r}; its CPPs: "
                             f"{', '.join(cpps)} (set them with --set NAME=VALUE).")
        cpp_values[name] = value
    for setting in settings:
        name, equals, text = setting.partition("=")
        name = name.strip()
        if not equals:
            raise InputError(f"--set {setting!r}: expected NAME=VALUE, e.g. r1.temperature=315.")
        field = f"--set {name}"
        if name in cpps or name in targets:
            cpp = cpps[targets.get(name, name)]
            if cpp.name in cpp_values:
                raise InputError(f"{field}: the CPP {cpp.name!r} is set twice.")
            cpp_values[cpp.name] = in_model_unit(text.strip(), cpp.unit, field)
        elif name in physical:
            if name in physical_values:
                raise InputError(f"{field}: {name!r} is set twice.")
            physical_values[name] = in_model_unit(text.strip(), _model_unit(process, name), field)
        else:
            raise InputError(f"{field}: no CPP (by name or target) or physical parameter of process {process.name!r} "
                             f"is called {name!r}; CPPs: {', '.join(cpps)}; targets: {', '.join(targets)}; physical "
                             "parameters: unit.parameter as the sensitivities name them.")
    return cpp_values, physical_values
