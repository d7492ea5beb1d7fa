"""The pharma chain's ranges and specifications as plain data (no JAX): the CPPs with their normal
operating and proven acceptable ranges, the CQAs with their specifications, and the species and
reactions the chain needs. Light enough for the CLI to build its options without importing JAX.

The values are illustrative but literature-plausible (see `_parameters`); the solvent is ethanol
(freezing point 159 K, normal boiling point 351.4 K, ICH Q3C class 3 limit 5000 ppm).
"""

from typing import NamedTuple

import numpy as np

SOLVENT_FREEZING_POINT = 159.0  # ethanol [K]
SOLVENT_BOILING_POINT = 351.4  # ethanol at 1 atm [K]
# The liquid-phase species the chain needs, by role (names in the mechanism).
SPECIES = {"reactant": "A", "co_reactant": "B", "api": "P", "impurity": "I", "side_product": "X",
           "degradant": "D", "solvent": "S"}
# The reactions the chain needs, by role (equations as written in the mechanism), and the effect
# that switches each on ("" = always on).
REACTIONS = {"A + B => P": "", "P => I": "side_reactions", "A => X": "side_reactions",
             "X => A": "side_reactions", "P => D": "degradation"}


class ParameterRange(NamedTuple):
    """A CPP: `nominal`, normal operating range `nor`, proven acceptable range `par`, and the
    physical limits `physical` (open interval) outside which the model does not apply."""

    name: str
    unit: str
    nominal: float
    nor: tuple[float, float]
    par: tuple[float, float]
    physical: tuple[float, float]
    description: str


class Specification(NamedTuple):
    """A CQA and its specification: `low <= value <= high` (either may be infinite)."""

    name: str
    unit: str
    low: float
    high: float
    description: str

    def text(self) -> str:
        if np.isinf(self.low):
            return f"<= {self.high:g} {self.unit}"
        if np.isinf(self.high):
            return f">= {self.low:g} {self.unit}"
        return f"{self.low:g} - {self.high:g} {self.unit}"


CPP_RANGES = (
    ParameterRange("r1_temperature", "K", 313.15, (308.15, 318.15), (303.15, 323.15),
                   (SOLVENT_FREEZING_POINT, SOLVENT_BOILING_POINT),
                   "R1 jacket temperature (the feed enters at it)"),
    ParameterRange("r1_residence_time", "min", 30.0, (25.0, 35.0), (20.0, 40.0), (0.0, np.inf),
                   "R1 residence time (plug flow: the batch time of a fluid element)"),
    ParameterRange("cooling_rate", "K/min", 0.5, (0.4, 0.6), (0.25, 1.0), (0.0, np.inf),
                   "linear cooling rate of the crystallizer"),
    ParameterRange("dryer_temperature", "K", 318.15, (313.15, 323.15), (308.15, 328.15),
                   (SOLVENT_FREEZING_POINT, 423.15), "filter-dryer jacket temperature"),
)
CPP_NAMES = tuple(r.name for r in CPP_RANGES)

CQA_SPECS = (
    Specification("assay", "% w/w", 98.0, np.inf, "API in the dried product"),
    Specification("impurity", "% w/w", -np.inf, 0.15, "over-reaction impurity I in the dried product"),
    Specification("degradant", "% w/w", -np.inf, 0.15, "degradant D in the dried product"),
    Specification("mean_crystal_size", "um", 150.0, 300.0, "volume-weighted mean size D[4,3]"),
    Specification("residual_solvent", "ppm", -np.inf, 5000.0, "ethanol left in the product (ICH Q3C)"),
)
CQA_NAMES = tuple(s.name for s in CQA_SPECS)
