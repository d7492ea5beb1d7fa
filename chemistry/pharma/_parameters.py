"""The pharma chain's differentiable inputs: the CPPs and the physical parameters of a process
(`Process`), each a named sequence of float scalars in the order the process states them, and
`ChainInputs`, the pytree every sensitivity differentiates.

Kinetics live in the process's mechanism (a Cantera-YAML file read by `chemistry.Mechanism`); the
rest in the process file (the built-in: `chemistry/pharma/processes/api_chain.yaml`).
"""

from typing import NamedTuple

import equinox as eqx
import jax.numpy as jnp

from chemistry import GAS_CONSTANT, RateParameters

from ..kinetics._types import Scalar


class NamedValues(eqx.Module):
    """Float scalars by name, flattened in the order of `names`: `values[k]` is `names[k]`; read
    one as `x["name"]` (or `x.name` where the name is an identifier)."""

    names: tuple[str, ...] = eqx.field(static=True)
    values: tuple[Scalar, ...]

    def __getitem__(self, name: str) -> Scalar:
        return self.values[self.names.index(name)]

    def __getattr__(self, name: str):
        if name.startswith("__") or name in ("names", "values"):
            raise AttributeError(name)
        names = object.__getattribute__(self, "names")
        if name not in names:
            raise AttributeError(f"{type(self).__name__} has no {name!r}; names: {', '.join(names)}")
        return self.values[names.index(name)]

    def as_dict(self) -> dict[str, float]:
        return {name: float(value) for name, value in zip(self.names, self.values, strict=True)}

    def replace(self, **values) -> "NamedValues":
        """A copy with the named values replaced (floats or arrays)."""
        return type(self)(self.names, tuple(jnp.asarray(values[name]) if name in values else value
                                            for name, value in zip(self.names, self.values, strict=True)))


class CPPs(NamedValues):
    """The critical process parameters by name, each in its target's model unit (the built-in:
    `r1_temperature` [K], `r1_residence_time` [min], `cooling_rate` [K/min], `dryer_temperature`
    [K]). Build them with `Process.cpps` (checked against the physical limits)."""


class PhysicalParameters(NamedValues):
    """The parameters no CPP sets, by input name: "feed.<species>" [kmol/m^3] and
    "<unit>.<parameter>" in the unit catalogue's model units (`_unit_catalogue`). Build them with
    `Process.physical`."""


def arrhenius(rate, activation, temperature, reference_temperature):
    """`rate` at `temperature` [K], given at `reference_temperature` [K] with activation energy
    `activation` [J/kmol]: rate exp(-E/R (1/T - 1/T_ref)), in the units of `rate`. The form of
    every temperature-dependent physical rate of the chain (growth, drying, solid degradation)."""
    return rate * jnp.exp(-activation / GAS_CONSTANT * (1 / temperature - 1 / reference_temperature))


class ChainInputs(NamedTuple):
    """Everything the chain's outputs depend on, one differentiable pytree: `cpps`, the `rates`
    (per-reaction log-multipliers, temperature exponents and activation temperatures [K]) and the
    `physical` parameters. Its flat order (CPPs, then rates, then physical parameters, each in the
    process's order) is the column order of every sensitivity matrix."""

    cpps: CPPs
    rates: RateParameters
    physical: PhysicalParameters
