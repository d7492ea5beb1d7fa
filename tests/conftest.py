"""Shared test scaffolding: float64 on once for the whole session (importing snapo_ode does it),
Agg plotting, and a key fixture."""

import os

os.environ.setdefault("MPLBACKEND", "Agg")

import jax  # noqa: E402
import pytest  # noqa: E402

import snapo_ode  # noqa: E402,F401  (turns on float64 and the compilation cache)


@pytest.fixture
def key():
    return jax.random.key(0)
