"""Physical quantities in process files (pint): a number in the model's unit, or a string with
its own unit ("30 min", "40 kJ/mol", "45 degC"), converted to the model's unit. Mass fractions
may be written "% w/w" (the "w/w" is a label pint does not read)."""

import functools
import math
import re

from snapo_ode import DECIMAL, InputError


@functools.cache
def registry():
    """pint's registry, imported on first use: a value in the model's own unit needs no pint (the
    CLI reads the built-in file to build its options)."""
    import pint

    return pint.UnitRegistry()


def _same(unit: str, model_unit: str) -> bool:
    """Whether `unit` is spelt as `model_unit` (the "w/w" label aside)."""
    return unit.replace("w/w", "").replace(" ", "") == model_unit.replace("w/w", "").replace(" ", "")


def _unit(text: str, field: str):
    try:
        return registry().Quantity(1.0, text.replace("w/w", "").strip() or "")
    except Exception as error:  # pint's parser raises many types (undefined units, tokens, division by zero)
        raise InputError(f"{field}: {text!r} is not a unit ({type(error).__name__}: {error}).") from None


def conversion(unit: str, model_unit: str, field: str) -> float:
    """The factor that converts a value in `unit` to `model_unit` (both as pint spells them).

    **Raises:** `InputError` naming `field` where `unit` is not a unit or not of `model_unit`'s
    dimension."""
    if _same(unit, model_unit):
        return 1.0
    import pint

    quantity = _unit(unit, field)
    target = _unit(model_unit, field).units  # either side may be a user's text (a CQA's unit is the target)
    try:
        return float(quantity.to(target).magnitude)
    except pint.DimensionalityError:
        raise InputError(f"{field}: {unit!r} does not convert to {model_unit or 'a plain number'!r}.") from None
    except pint.OffsetUnitCalculusError:
        raise InputError(f"{field}: {unit!r} mixes an offset temperature into a rate; write K (or delta_degC).") from None


def in_model_unit(value, model_unit: str, field: str) -> float:
    """`value` (a number in `model_unit`, or "number unit") in `model_unit`.

    **Raises:** `InputError` naming `field` for a string that is not "number unit", an unknown
    unit, or one that does not convert."""
    if isinstance(value, bool) or not isinstance(value, (int, float, str)) or (
            not isinstance(value, str) and not math.isfinite(value)):
        raise InputError(f"{field} = {value!r}: expected a finite number, optionally with a unit as a string "
                         f"('30 min'); the model's unit is {model_unit or 'none'!r}.")
    if not isinstance(value, str):
        return float(value)
    match = re.match(rf"\s*(?P<number>{DECIMAL.pattern})\s*(?P<unit>.*?)\s*$", value)
    if match is None:
        raise InputError(f"{field} = {value!r}: expected a number, optionally with a unit ('30 min'); the model's "
                         f"unit is {model_unit or 'none'!r}.")
    number, unit = float(match["number"]), match["unit"]
    if not math.isfinite(number):
        raise InputError(f"{field} = {value!r}: not a finite number.")
    if not unit or _same(unit, model_unit):
        return number
    import pint

    quantity = _unit(unit, f"{field} = {value!r}")
    try:
        if quantity.units == registry().Quantity(1.0, model_unit or "").units:
            return number  # the model's own unit: the number as written, not a product with 1.0
        return float(registry().Quantity(number, quantity.units).to(model_unit or "dimensionless").magnitude)
    except pint.DimensionalityError:
        raise InputError(f"{field} = {value!r} does not convert to {model_unit or 'a plain number'!r}.") from None
    except pint.OffsetUnitCalculusError:
        raise InputError(f"{field} = {value!r} mixes an offset temperature into a rate; write K (or delta_degC).") from None
