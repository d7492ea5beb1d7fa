"""Chemistry on snapo_ode: Cantera-YAML kinetics in JAX, stiff reactors in Diffrax, the pharma chain.

Public names load on first use (see `snapo_ode.lazy_exports`)."""

from pathlib import Path

from snapo_ode import lazy_exports

MECHANISMS = Path(__file__).parent / "mechanisms"
"""The directory of the mechanisms that ship with this package [`reaction_types.yaml`, `pharma.yaml`]."""

from .kinetics import __all__ as _kinetics

__getattr__, __dir__, __all__ = lazy_exports(__name__, {".kinetics": tuple(_kinetics), "snapo_ode": ("SolverSettings",)},
                                             submodules=("kinetics", "pharma"))
__all__.append("MECHANISMS")
