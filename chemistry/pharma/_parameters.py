"""The pharma chain's differentiable inputs: the CPPs (their ranges and the CQA specifications
are in `_ranges`) and the physical parameters of the units, with units and sources.

Kinetics live in `chemistry/mechanisms/pharma.yaml` (read by `chemistry.Mechanism`); everything
else is here or in `_ranges`. The values are illustrative but literature-plausible: the synthesis rate constant,
the crystal density, molar masses and the 4-hour cooling scale follow PharmaPy's example
flowsheet; the solvent is ethanol (molar volume 0.0584 m^3/kmol, freezing point 159 K, normal
boiling point 351.4 K, ICH Q3C class 3 limit 5000 ppm).
"""

from typing import NamedTuple

import equinox as eqx
import jax.numpy as jnp
import numpy as np

from chemistry import GAS_CONSTANT, RateParameters
from snapo_ode import InputError, check_range

from ..kinetics._types import Scalar
from ._ranges import CPP_NAMES, CPP_RANGES


class CPPs(eqx.Module):
    """The critical process parameters, each a float scalar (differentiable).

    - `r1_temperature` [K], `r1_residence_time` [min], `cooling_rate` [K/min],
      `dryer_temperature` [K].
    """

    r1_temperature: Scalar
    r1_residence_time: Scalar
    cooling_rate: Scalar
    dryer_temperature: Scalar

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

    feed_a: Scalar
    feed_b: Scalar
    jacket_ua: Scalar
    hold_temperature: Scalar
    hold_time: Scalar
    final_temperature: Scalar
    solubility_ref: Scalar
    solubility_ref_temperature: Scalar
    solubility_enthalpy: Scalar
    growth_rate: Scalar
    growth_order: Scalar
    growth_activation: Scalar
    nucleation_rate: Scalar
    nucleation_order: Scalar
    seed_loading: Scalar
    seed_size: Scalar
    crystal_density: Scalar
    shape_factor: Scalar
    partition_impurity: Scalar
    partition_degradant: Scalar
    cake_liquor: Scalar
    wash_residue: Scalar
    drying_time: Scalar
    drying_rate: Scalar
    dryer_ref_temperature: Scalar
    drying_activation: Scalar
    solid_degradation_rate: Scalar
    solid_degradation_activation: Scalar


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


def arrhenius(rate, activation, temperature, reference_temperature):
    """`rate` at `temperature` [K], given at `reference_temperature` [K] with activation energy
    `activation` [J/kmol]: rate exp(-E/R (1/T - 1/T_ref)), in the units of `rate`. The form of
    every temperature-dependent physical rate of the chain (growth, drying, solid degradation)."""
    return rate * jnp.exp(-activation / GAS_CONSTANT * (1 / temperature - 1 / reference_temperature))


class ChainInputs(NamedTuple):
    """Everything the chain's outputs depend on, one differentiable pytree: `cpps`, the `rates`
    (per-reaction log-multipliers, temperature exponents and activation temperatures [K]) and the
    `physical` parameters. Its flat order (CPPs, then rates, then physical parameters) is the
    column order of every sensitivity matrix."""

    cpps: CPPs
    rates: RateParameters
    physical: PhysicalParameters
