"""A CPP's ranges and a CQA's specification as plain data (no JAX): `ParameterRange` and
`Specification`. A process file states them (`_process_file`); the built-in process's are
`CPP_RANGES` and `CQA_SPECS` there, a chain's `PharmaChain.cpp_ranges` and `cqa_specs`.
"""

from typing import NamedTuple

import numpy as np


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
    target: str = ""


class Specification(NamedTuple):
    """A CQA and its specification: `low <= value <= high` (either may be infinite), in `unit`;
    `definition`: a word of the CQA vocabulary ("assay", "residual_solvent", "d43", "yield", ...) or
    ("mass_fraction", species) or ("residual_solvent", species); `factor`: from the vocabulary's unit to `unit`."""

    name: str
    unit: str
    low: float
    high: float
    description: str
    definition: str | tuple[str, str] = ""
    factor: float = 1.0

    def text(self) -> str:
        if np.isinf(self.low):
            return f"<= {self.high:g} {self.unit}"
        if np.isinf(self.high):
            return f">= {self.low:g} {self.unit}"
        return f"{self.low:g} - {self.high:g} {self.unit}"
