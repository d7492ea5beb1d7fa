"""The versions of this package and of the stack its results depend on, read from the installed
distributions (no import of JAX): for `snapo --version`, checkpoint fingerprints and export keys."""

import functools
import importlib.metadata

STACK = ("snapo-ode", "jax", "jaxlib", "equinox", "diffrax", "lineax", "optimistix", "optax", "numpy")


@functools.cache
def versions() -> dict[str, str | None]:
    """Distribution -> installed version (None where it is not installed), for `STACK`."""
    def version(name: str) -> str | None:
        try:
            return importlib.metadata.version(name)
        except importlib.metadata.PackageNotFoundError:
            return None
    return {name: version(name) for name in STACK}


def in_words() -> str:
    """`"snapo-ode 0.1.0, jax 0.10.2, ..."`."""
    return ", ".join(f"{name} {number or '(not installed)'}" for name, number in versions().items())
