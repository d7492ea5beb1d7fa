"""Every number of the pharma chain in one place: the CPPs with their ranges, the CQAs with their
specifications, and the physical parameters of the four units, with units and sources.

Kinetics live in `chemistry/mechanisms/pharma.yaml` (read by `chemistry.Mechanism`); everything
else is here. The values are illustrative but literature-plausible: the synthesis rate constant,
the crystal density, molar masses and the 4-hour cooling scale follow PharmaPy's example
flowsheet; the solvent is ethanol (molar volume 0.0584 m^3/kmol, freezing point 159 K, normal
boiling point 351.4 K, ICH Q3C class 3 limit 5000 ppm).
"""

from typing import NamedTuple

import equinox as eqx
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, Float

from snapo_ode import InputError, check_range

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


class CPPs(eqx.Module):
    """The critical process parameters, each a float scalar (differentiable).

    - `r1_temperature` [K], `r1_residence_time` [min], `cooling_rate` [K/min],
      `dryer_temperature` [K].
    """

    r1_temperature: Float[Array, ""]
    r1_residence_time: Float[Array, ""]
    cooling_rate: Float[Array, ""]
    dryer_temperature: Float[Array, ""]

    def as_dict(self) -> dict[str, float]:
        return {name: float(getattr(self, name)) for name in CPP_NAMES}


def make_cpps(**values: float) -> CPPs:
    """CPPs from keyword values (the others at nominal), checked against the physical limits.

    **Raises:** `InputError` naming the field for an unknown name or a value outside its physical
    limits (negative times, temperatures at or below the solvent's freezing point, R1 at or above
    its boiling point). A value outside the proven acceptable range is allowed (see
    `outside_par`) and reported as a warning.
    """
    unknown = sorted(set(values) - set(CPP_NAMES))
    if unknown:
        raise InputError(f"unknown CPP {unknown[0]!r}; CPPs: {', '.join(CPP_NAMES)}.")
    chosen = {}
    for spec in CPP_RANGES:
        value = values.get(spec.name, spec.nominal)
        check_range(f"{spec.name} [{spec.unit}]", value, *spec.physical, low_open=True, high_open=True)
        chosen[spec.name] = jnp.asarray(float(value))
    return CPPs(**chosen)


def outside_par(cpps: CPPs) -> list[str]:
    """Warnings, one per CPP outside its proven acceptable range."""
    warnings = []
    for spec in CPP_RANGES:
        value = float(getattr(cpps, spec.name))
        if not spec.par[0] <= value <= spec.par[1]:
            warnings.append(f"{spec.name} = {value:g} {spec.unit} is outside its proven acceptable range "
                            f"[{spec.par[0]:g}, {spec.par[1]:g}]: the model is extrapolating.")
    return warnings


def check_cqa_names(names) -> tuple[str, ...]:
    """Raise `InputError` for a name that is not a CQA."""
    for name in names:
        if name not in CQA_NAMES:
            raise InputError(f"unknown CQA {name!r}; CQAs: {', '.join(CQA_NAMES)}.")
    return tuple(names)


class PhysicalParameters(eqx.Module):
    """The non-kinetic parameters of the chain, each a float scalar (differentiable).

    Feed and R1 (plug flow, jacketed):
    - `feed_a`, `feed_b` [kmol/m^3]: feed concentrations of A and B (B in 10% excess).
    - `jacket_ua` [W/m^3/K]: U a, heat-transfer coefficient times jacket area per reactor volume
      (U = 500 W/m^2/K on a 0.1 m tube: a = 40 m^2/m^3).
    R2 hold:
    - `hold_temperature` [K], `hold_time` [s].
    Cooling crystallizer (seeded, from `hold_temperature` to `final_temperature`):
    - `final_temperature` [K].
    - `solubility_ref` [kmol/m^3] at `solubility_ref_temperature` [K], `solubility_enthalpy` [J/kmol]:
      van't Hoff C*(T) = C*_ref exp(-dH/R (1/T - 1/T_ref)).
    - `growth_rate` [m/s] at T_ref, `growth_order` [-], `growth_activation` [J/kmol]:
      G = k_g exp(-E_g/R (1/T - 1/T_ref)) S^g with S = c/C* - 1.
    - `nucleation_rate` [1/m^3/s per m^3/m^3 of crystals], `nucleation_order` [-]: secondary
      nucleation B = k_b S^b (k_v mu_3).
    - `seed_loading` [kg/m^3], `seed_size` [m].
    - `crystal_density` [kg/m^3], `shape_factor` k_v [-] (spheres: pi/6).
    - `partition_impurity`, `partition_degradant` [-]: mole ratio (impurity/API) in the growing
      crystal over that in the liquor.
    Filter:
    - `cake_liquor` [kg liquor / kg crystals] retained by the cake; `wash_residue` [-]: fraction of
      its solutes left after the displacement wash (the wash solvent replaces the liquor).
    Dryer:
    - `drying_time` [s]; `drying_rate` [1/s] at `dryer_ref_temperature` [K], `drying_activation`
      [J/kmol]: first-order solvent removal; `solid_degradation_rate` [1/s] at the same reference,
      `solid_degradation_activation` [J/kmol]: P -> D in the solid.
    """

    feed_a: Float[Array, ""]
    feed_b: Float[Array, ""]
    jacket_ua: Float[Array, ""]
    hold_temperature: Float[Array, ""]
    hold_time: Float[Array, ""]
    final_temperature: Float[Array, ""]
    solubility_ref: Float[Array, ""]
    solubility_ref_temperature: Float[Array, ""]
    solubility_enthalpy: Float[Array, ""]
    growth_rate: Float[Array, ""]
    growth_order: Float[Array, ""]
    growth_activation: Float[Array, ""]
    nucleation_rate: Float[Array, ""]
    nucleation_order: Float[Array, ""]
    seed_loading: Float[Array, ""]
    seed_size: Float[Array, ""]
    crystal_density: Float[Array, ""]
    shape_factor: Float[Array, ""]
    partition_impurity: Float[Array, ""]
    partition_degradant: Float[Array, ""]
    cake_liquor: Float[Array, ""]
    wash_residue: Float[Array, ""]
    drying_time: Float[Array, ""]
    drying_rate: Float[Array, ""]
    dryer_ref_temperature: Float[Array, ""]
    drying_activation: Float[Array, ""]
    solid_degradation_rate: Float[Array, ""]
    solid_degradation_activation: Float[Array, ""]


_PHYSICAL_DEFAULTS = dict(
    feed_a=0.33, feed_b=0.363, jacket_ua=2.0e4,
    hold_temperature=318.15, hold_time=3600.0,
    final_temperature=278.15,
    solubility_ref=0.30, solubility_ref_temperature=318.15, solubility_enthalpy=4.0e7,
    growth_rate=5.0e-8, growth_order=1.5, growth_activation=2.0e7,
    nucleation_rate=1.0e9, nucleation_order=2.0,
    seed_loading=0.2, seed_size=4.0e-5,
    crystal_density=1200.0, shape_factor=float(np.pi / 6),
    partition_impurity=0.03, partition_degradant=0.03,
    cake_liquor=0.3, wash_residue=0.03,
    drying_time=8 * 3600.0, drying_rate=2.7e-4, dryer_ref_temperature=318.15, drying_activation=5.0e7,
    solid_degradation_rate=1.5e-8, solid_degradation_activation=1.2e8,
)
# [kg/kmol], as Cantera computes them from the mechanism's elements (tested).
MOLAR_MASSES = {"A": 100.0, "B": 50.0, "P": 150.0, "I": 150.0, "X": 100.0, "D": 150.0, "S": 46.07}


def default_physical_parameters(**overrides: float) -> PhysicalParameters:
    """The default `PhysicalParameters`, with `overrides` by name (checked: positive, finite).

    **Raises:** `InputError` for an unknown name or a value that is not a positive number.
    """
    values = dict(_PHYSICAL_DEFAULTS)
    for name, value in overrides.items():
        if name not in values:
            raise InputError(f"unknown physical parameter {name!r}; parameters: {', '.join(values)}.")
        check_range(name, value, 0.0, np.inf, low_open=True)
        values[name] = float(value)
    return PhysicalParameters(**{name: jnp.asarray(value) for name, value in values.items()})


PHYSICAL_NAMES = tuple(_PHYSICAL_DEFAULTS)
