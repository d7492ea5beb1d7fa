"""Units a fund's files write (pint): money amounts per time, converted to the model's million
(of the fund's currency) per month. Currencies are not converted: a unit naming another
currency than the fund's is refused; "thousand", "million" and "billion" are the only scales."""

import functools
import re

import pint

from snapo_ode import InputError

CURRENCIES = ("EUR", "USD", "GBP", "CHF", "JPY", "CAD", "AUD", "SEK", "NOK", "DKK")
SCALES = {"thousand": 1e3, "million": 1e6, "billion": 1e9}


@functools.cache
def _registry() -> pint.UnitRegistry:
    registry = pint.UnitRegistry()
    registry.define("money = [money]")
    for code in (*CURRENCIES, "currency"):
        registry.define(f"{code} = money")
    for word, factor in SCALES.items():
        registry.define(f"{word} = {factor:g}")
    return registry


def _quantity(unit: str, field: str, currency: str, allowed: str):
    """`unit` parsed, after refusing another currency or a dimensionless word that is no scale."""
    words = re.findall(r"[A-Za-z_]+", unit)
    foreign = [w for w in words if w in CURRENCIES and w != currency]
    if foreign:
        raise InputError(f"{field} = {unit!r} names {foreign[0]}; the fund's currency is {currency} (amounts are not "
                         "converted between currencies).")
    registry = _registry()
    if re.fullmatch(r"[A-Z]{3}", currency) and currency not in registry:
        registry.define(f"{currency} = money")  # a fund's own currency code
    try:
        for word in words:
            if word not in SCALES and registry.Quantity(1.0, word).dimensionless:
                raise InputError(f"{field} = {unit!r}: {word!r} is no amount of money; the scales are "
                                 f"{', '.join(SCALES)}; allowed: {allowed}.")
        return registry.Quantity(1.0, unit)
    except InputError:
        raise
    except Exception as error:  # pint's parser raises many types (undefined units, tokens, division by zero)
        raise InputError(f"{field} = {unit!r} is not a unit ({type(error).__name__}: {error}); allowed: {allowed}.") from None


def per_month_in_millions(unit: str, field: str, currency: str = "EUR") -> float:
    """The factor that converts an amount in `unit` (money per time, such as "million EUR /
    year", "thousand / month"; a bare scale such as "million" counts as the fund's `currency`) to
    million per month. `field` names the setting in errors.

    **Raises:** `InputError` naming `field` for an unknown unit, another currency, or one that
    is not money per time."""
    allowed = "money per time, such as 'million / month' or 'thousand EUR / year'"
    quantity = _quantity(unit, field, currency, allowed)
    if quantity.check("[money] / [time]"):
        return float(quantity.to("money / month").magnitude) / 1e6
    if quantity.check("1 / [time]"):  # a bare scale: the fund's currency is implied
        return float(quantity.to("1 / month").magnitude) / 1e6
    raise InputError(f"{field} = {unit!r} is not money per time; allowed: {allowed}.")


def in_millions(unit: str, field: str, currency: str = "EUR") -> float:
    """The factor that converts an amount in `unit` ("million", "thousand EUR", "EUR") to millions.

    **Raises:** `InputError` naming `field` for an unknown unit, another currency, or one that
    is not money."""
    allowed = "money, such as 'million' or 'thousand EUR'"
    quantity = _quantity(unit, field, currency, allowed)
    if quantity.check("[money]"):
        return float(quantity.to("money").magnitude) / 1e6
    if quantity.dimensionless:
        return float(quantity.to("dimensionless").magnitude) / 1e6
    raise InputError(f"{field} = {unit!r} is not an amount of money; allowed: {allowed}.")
