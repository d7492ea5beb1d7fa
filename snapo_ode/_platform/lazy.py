"""Lazy public surfaces: a package lists its public names by module, and each module is imported
on the first use of one of its names.

So `import snapo_ode`, `import finance.gas_storage` and the `snapo` CLI's plugin registration
cost no JAX import: `snapo --help` and argument errors answer at once, and the JAX start-up is
paid by the command that computes. Uses the module `__getattr__` of PEP 562.
"""

import importlib
import importlib.util
import sys
from collections.abc import Callable, Mapping, Sequence
from types import MappingProxyType


def lazy_exports(package: str, names_by_module: Mapping[str, Sequence[str]], submodules: Sequence[str] = ()
                 ) -> tuple[Callable, Callable, list[str]]:
    """`__getattr__`, `__dir__` and `__all__` for `package`.

    **Arguments:**
    - `package`: the package's `__name__`.
    - `names_by_module`: relative module (".\\_inputs") -> the public names it defines.
    - `submodules`: public submodules (e.g. "smooth"), imported as attributes.

    Assign all three in the package's `__init__.py`:
    `__getattr__, __dir__, __all__ = lazy_exports(__name__, {...})`. `__getattr__.modules` maps
    each name to the absolute name of its module, without importing it (the API reference reads it).
    """
    where = {name: module for module, names in names_by_module.items() for name in names}
    public = [*where, *submodules]

    def __getattr__(name: str):
        if name in submodules:
            return importlib.import_module(f".{name}", package)
        if name not in where:
            raise AttributeError(f"module {package!r} has no attribute {name!r}")
        value = getattr(importlib.import_module(where[name], package), name)
        setattr(sys.modules[package], name, value)  # the next access skips __getattr__
        return value

    def __dir__() -> list[str]:
        return sorted(public)

    __getattr__.modules = MappingProxyType({name: importlib.util.resolve_name(module, package)
                                            for name, module in where.items()})

    return __getattr__, __dir__, public
