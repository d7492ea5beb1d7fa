"""Units of a Cantera YAML file, converted to Cantera's SI base: kmol, m, s, J, K, Pa, kg.

A number without units takes the file's default for its dimension (the `units:` mapping); a string
such as `"1.0e13 cm^3/mol/s"` or `"-285.8 kJ/mol"` carries its own.
"""

import re
from collections.abc import Mapping

import numpy as np

from snapo_ode import InputError

# Exact constants, as Cantera defines them (ct.gas_constant, ct.one_atm, ct.avogadro).
GAS_CONSTANT = 8314.46261815324  # [J/kmol/K]
ONE_ATM = 101325.0  # [Pa]
AVOGADRO = 6.02214076e26  # [1/kmol]
ELECTRON_VOLT = 1.602176634e-19  # [J]

_FACTORS = {
    "m": 1.0, "cm": 1e-2, "mm": 1e-3, "um": 1e-6, "nm": 1e-9, "dm": 0.1, "km": 1e3,
    "L": 1e-3, "l": 1e-3, "cc": 1e-6,
    "kmol": 1.0, "mol": 1e-3, "molec": 1.0 / AVOGADRO,
    "s": 1.0, "ms": 1e-3, "us": 1e-6, "ns": 1e-9, "min": 60.0, "h": 3600.0, "hr": 3600.0,
    "J": 1.0, "kJ": 1e3, "MJ": 1e6, "cal": 4.184, "kcal": 4184.0, "eV": ELECTRON_VOLT,
    "K": 1.0,
    "Pa": 1.0, "kPa": 1e3, "MPa": 1e6, "bar": 1e5, "atm": ONE_ATM,
    "kg": 1.0, "g": 1e-3,
}
_DEFAULTS = {
    "length": "m", "quantity": "kmol", "time": "s", "energy": "J",
    "activation-energy": "J/kmol", "temperature": "K", "pressure": "Pa", "mass": "kg",
}


def unit_factor(expression: str) -> float:
    """The SI factor of a unit expression such as `cm^3/mol/s` or `J/mol/K`."""
    factor = 1.0
    text = expression.replace(" ", "*")
    for sign, token in re.findall(r"([*/]?)([^*/]+)", text):
        name, _, power = token.partition("^")
        if name not in _FACTORS:
            raise InputError(f"unit {name!r} in {expression!r} is not known; known units: "
                             f"{', '.join(sorted(_FACTORS))}.")
        exponent = float(power) if power else 1.0
        factor *= _FACTORS[name] ** (-exponent if sign == "/" else exponent)
    return factor


class UnitSystem:
    """The default units of one file (its top-level `units:` mapping)."""

    def __init__(self, units: Mapping[str, str] | None = None):
        self.units = dict(_DEFAULTS)
        for name, value in (units or {}).items():
            if name not in _DEFAULTS:
                raise InputError(f"units: {name!r} is not a unit dimension; allowed: "
                                 f"{', '.join(sorted(_DEFAULTS))}.")
            unit_factor(str(value))
            self.units[name] = str(value)

    def within(self, node) -> "UnitSystem":
        """The units inside `node`: these, under the node's own `units:` mapping if it has one
        (Cantera lets any mapping set the units of what it holds)."""
        local = node.get("units") if isinstance(node, Mapping) else None
        return UnitSystem({**self.units, **local}) if local else self

    def factor(self, dimension: str) -> float:
        """The SI factor of a product of dimensions such as `energy/quantity/temperature`."""
        factor = 1.0
        for sign, token in re.findall(r"([*/]?)([a-z-]+(?:\^-?[0-9.]+)?)", dimension):
            name, _, power = token.partition("^")
            exponent = float(power) if power else 1.0
            base = unit_factor(self.units[name])
            factor *= base ** (-exponent if sign == "/" else exponent)
        return factor

    def convert(self, field: str, value, dimension: str) -> float:
        """`value` in SI: a bare number in the default units of `dimension`, or a string with its
        own units."""
        if isinstance(value, str):
            number, _, unit = value.strip().partition(" ")
            try:
                magnitude = float(number)
            except ValueError:
                raise InputError(f"{field} = {value!r} is not a number with units.") from None
            return magnitude * (unit_factor(unit.strip()) if unit.strip() else self.factor(dimension))
        return float(value) * self.factor(dimension)

    def activation_temperature(self, field: str, value) -> float:
        """An activation energy as Ea/R [K], from any energy unit or from a temperature."""
        if isinstance(value, str):
            number, _, unit = value.strip().partition(" ")
            unit = unit.strip() or self.units["activation-energy"]
            value = float(number)
        else:
            unit = self.units["activation-energy"]
        if unit == "K":
            return float(value)
        return float(value) * unit_factor(unit) / GAS_CONSTANT if "/" in unit else (
            float(value) * unit_factor(unit) * AVOGADRO / GAS_CONSTANT)


def rate_constant_factor(units: UnitSystem, order: float, concentration_scaled: bool = True) -> float:
    """SI factor for a pre-exponential factor of a rate of `order` in concentration, whose units
    are concentration^(1-order)/time (just 1/time where activities are dimensionless)."""
    time = units.factor("time")
    if not concentration_scaled:
        return 1.0 / time
    concentration = units.factor("quantity") / units.factor("length") ** 3
    return float(np.power(concentration, 1.0 - order)) / time
