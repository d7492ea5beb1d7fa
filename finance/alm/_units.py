"""Units a fund's files write (pint): money amounts per time, converted to the model's million
(of the fund's currency) per month. Currencies are not converted: any currency code is the
fund's own money."""

import functools

import pint

from snapo_ode import InputError


@functools.cache
def _registry() -> pint.UnitRegistry:
    registry = pint.UnitRegistry()
    registry.define("money = [money]")
    for code in ("EUR", "USD", "GBP", "CHF", "JPY", "CAD", "AUD", "SEK", "NOK", "DKK", "currency"):
        registry.define(f"{code} = money")
    for word, factor in (("thousand", 1e3), ("million", 1e6), ("billion", 1e9)):
        registry.define(f"{word} = {factor:g}")
    return registry


def per_month_in_millions(unit: str, field: str) -> float:
    """The factor that converts an amount in `unit` (money per time, such as "million EUR /
    year", "thousand / month"; a bare scale such as "million" counts as the fund's currency) to
    million per month. `field` names the setting in errors.

    **Raises:** `InputError` naming `field` for an unknown unit or one that is not money per time."""
    registry = _registry()
    try:
        quantity = registry.Quantity(1.0, unit)
        if quantity.check("[money] / [time]"):
            return float(quantity.to("money / month").magnitude) / 1e6
        if quantity.check("1 / [time]"):  # a bare scale: the fund's currency is implied
            return float(quantity.to("1 / month").magnitude) / 1e6
    except (pint.errors.PintError, AttributeError, TypeError, ValueError, SyntaxError) as error:
        raise InputError(f"{field} = {unit!r} is not a unit ({error}); allowed: money per time, such as "
                         "'million / month' or 'thousand EUR / year'.") from None
    raise InputError(f"{field} = {unit!r} is not money per time; allowed: such as 'million / month' or "
                     "'thousand EUR / year'.")


def in_millions(unit: str, field: str) -> float:
    """The factor that converts an amount in `unit` ("million", "thousand EUR", "EUR") to millions.

    **Raises:** `InputError` naming `field` for an unknown unit or one that is not money."""
    registry = _registry()
    try:
        quantity = registry.Quantity(1.0, unit)
        if quantity.check("[money]"):
            return float(quantity.to("money").magnitude) / 1e6
        if quantity.dimensionless:
            return float(quantity.to("dimensionless").magnitude) / 1e6
    except (pint.errors.PintError, AttributeError, TypeError, ValueError, SyntaxError) as error:
        raise InputError(f"{field} = {unit!r} is not a unit ({error}); allowed: money, such as 'million' or "
                         "'thousand EUR'.") from None
    raise InputError(f"{field} = {unit!r} is not an amount of money; allowed: such as 'million' or 'thousand EUR'.")
