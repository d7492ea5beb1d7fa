"""Parsing of a reaction equation such as `H + CH3 (+M) <=> CH4 (+M)` or `2 O + M <=> O2 + M`."""

import re
from typing import NamedTuple

_FALLOFF_COLLIDER = re.compile(r"\(\+\s*([^)\s]+)\s*\)")


class Equation(NamedTuple):
    """`reactants`/`products`: species -> stoichiometric coefficient; `reversible`; `collider`:
    "M" for a generic third body, a species name for a specific one, None for none;
    `falloff`: whether the collider is written `(+M)`."""

    reactants: dict[str, float]
    products: dict[str, float]
    reversible: bool
    collider: str | None
    falloff: bool


def _side(text: str) -> tuple[dict[str, float], list[str]]:
    species: dict[str, float] = {}
    colliders = []
    for term in re.split(r"\s\+\s", f" {text.strip()} "):
        term = term.strip()
        if not term:
            continue
        parts = term.split()
        coefficient = 1.0
        if len(parts) == 2:
            coefficient, name = float(parts[0]), parts[1]
        elif len(parts) == 1:
            name = parts[0]
        else:
            raise ValueError(f"cannot read the term {term!r}")
        if name == "M":
            colliders.append("M")
            continue
        species[name] = species.get(name, 0.0) + coefficient
    return species, colliders


def parse_equation(equation: str) -> Equation:
    """Split an equation into its two sides, the direction and the third body.

    **Raises:** `ValueError` if the text has no `=>`, `<=>` or `=`, or a term cannot be read.
    """
    falloff_colliders = _FALLOFF_COLLIDER.findall(equation)
    text = _FALLOFF_COLLIDER.sub(" ", equation)
    for arrow, reversible in (("<=>", True), ("=>", False), ("=", True)):
        if arrow in text:
            left, right = text.split(arrow, 1)
            break
    else:
        raise ValueError("no '<=>', '=>' or '=' in the equation")
    reactants, left_m = _side(left)
    products, right_m = _side(right)
    collider = None
    if falloff_colliders:
        collider = falloff_colliders[0]
    elif left_m or right_m:
        collider = "M"
    return Equation(reactants, products, reversible, collider, bool(falloff_colliders))
