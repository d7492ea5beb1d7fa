"""The unit types a process file may name, and the parameters of each, as plain data (no JAX):
the unit the model computes in, what the parameter is, and the open interval it must lie in.

A process file gives each parameter as a number in the model's unit or as a string with its own
unit ("30 min", "40 kJ/mol"), converted by pint (`_quantities`). The unit classes that run them
are in `_liquid`, `_crystallizer`, `_filter` and `_dryer` (`UNIT_CLASSES` in `_process`).
"""

from typing import NamedTuple

import numpy as np


class Parameter(NamedTuple):
    """A unit parameter: its model `unit` (pint's spelling), `description`, and the open interval
    (`low`, `high`) it must lie in."""

    unit: str
    description: str
    low: float = 0.0
    high: float = np.inf


POSITIVE_FRACTION = (0.0, 1.0)

SOLUBILITY = {
    "solubility_ref": Parameter("kmol/m^3", "the API's solubility at solubility_ref_temperature (van 't Hoff; without "
                                "antisolvent)"),
    "solubility_ref_temperature": Parameter("K", "reference temperature of the solubility and growth rate"),
    "solubility_enthalpy": Parameter("J/kmol", "van 't Hoff enthalpy of dissolution"),
}
CRYSTALS = {
    "growth_rate": Parameter("m/s", "growth rate constant k_g at the reference temperature"),
    "growth_order": Parameter("", "growth order g in G = k_g S^g"),
    "growth_activation": Parameter("J/kmol", "growth activation energy"),
    "nucleation_rate": Parameter("1/s", "secondary nucleation k_b (per m^3 of crystals per m^3)"),
    "nucleation_order": Parameter("", "nucleation order b in B = k_b S^b k_v mu_3"),
    "seed_loading": Parameter("kg/m^3", "seed crystals per volume of liquor"),
    "seed_size": Parameter("m", "seed crystal size"),
    "crystal_density": Parameter("kg/m^3", "crystal density"),
    "shape_factor": Parameter("", "volume shape factor k_v (spheres: pi/6)"),
    "partition_impurity": Parameter("", "impurity/API mole ratio in the growing crystal over that in the liquor"),
    "partition_degradant": Parameter("", "degradant/API mole ratio in the growing crystal over that in the liquor"),
}
"""The crystallizers' shared parameters: solubility, growth and nucleation laws, seeds, crystals."""

UNIT_PARAMETERS = {
    "plug_flow_reactor": {
        "temperature": Parameter("K", "jacket temperature (the liquid enters at the upstream stream's temperature; "
                                 "the process feed at the first reactor's jacket temperature)"),
        "residence_time": Parameter("min", "residence time (the batch time of a fluid element)"),
        "jacket_ua": Parameter("W/m^3/K", "U a: heat-transfer coefficient times jacket area per m^3 of the reactor "
                               "(a fluid element of inlet volume V_in exchanges U a V_in (T_jacket - T))"),
    },
    "batch_reactor": {
        "temperature": Parameter("K", "isothermal hold temperature"),
        "time": Parameter("s", "hold time"),
    },
    "cstr": {
        "temperature": Parameter("K", "jacket temperature (isothermal)"),
        "residence_time": Parameter("min", "residence time: hold-up mass over mass flow"),
    },
    "cooling_crystallizer": {
        "final_temperature": Parameter("K", "temperature at the end of the cooling (from the inlet's)"),
        "cooling_rate": Parameter("K/min", "linear cooling rate"),
        **SOLUBILITY, **CRYSTALS,
    },
    "antisolvent_crystallizer": {
        "temperature": Parameter("K", "crystallizer temperature"),
        "antisolvent_ratio": Parameter("", "m^3 of antisolvent added per m^3 of liquor"),
        "addition_time": Parameter("min", "time over which the antisolvent is added, at a constant rate"),
        **SOLUBILITY,
        "antisolvent_linear": Parameter("", "a in C* = C*(T) exp(-(a w + b w^2)), w the antisolvent's volume fraction",
                                        -np.inf),
        "antisolvent_quadratic": Parameter("", "b in C* = C*(T) exp(-(a w + b w^2))", -np.inf),
        **CRYSTALS,
    },
    "filter": {
        "cake_liquor": Parameter("", "kg of liquor the cake keeps per kg of crystals"),
        "wash_residue": Parameter("", "fraction of the liquor's solutes the displacement wash leaves",
                                  *POSITIVE_FRACTION),
    },
    "dryer": {
        "temperature": Parameter("K", "jacket temperature"),
        "time": Parameter("s", "drying time"),
        "drying_rate": Parameter("1/s", "first-order solvent removal rate at reference_temperature"),
        "reference_temperature": Parameter("K", "reference temperature of the drying and degradation rates"),
        "drying_activation": Parameter("J/kmol", "drying activation energy"),
        "degradation_rate": Parameter("1/s", "API -> degradant rate in the solid at reference_temperature"),
        "degradation_activation": Parameter("J/kmol", "activation energy of the degradation in the solid"),
    },
}
"""type -> parameter name -> `Parameter`, in the order of the chain's inputs."""

def unit_parameter(unit_types: dict[str, str], name: str) -> Parameter | None:
    """The `Parameter` a process's "unit.parameter" `name` stands for, given its units' types
    (unit name -> type), or None where no unit of the process has it."""
    unit, _, parameter = name.partition(".")
    return UNIT_PARAMETERS.get(unit_types.get(unit), {}).get(parameter)


UNIT_ROLES = {"plug_flow_reactor": "reactor", "batch_reactor": "reactor", "cstr": "reactor",
              "cooling_crystallizer": "crystallizer", "antisolvent_crystallizer": "crystallizer", "filter": "filter",
              "dryer": "dryer"}
"""What each unit type does in the flowsheet: reactors take and give a liquid, a crystallizer
gives a slurry, a filter a cake, a dryer a dried cake."""

FLOWSHEET = ("one or more reactors, then one crystallizer, one filter and at most one dryer, in that order")
"""The sequences of unit types a process may have (the streams between them: a liquid, a slurry,
a cake)."""
