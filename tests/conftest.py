"""Shared test scaffolding: float64 and the compilation cache on once for the whole session
(`snapo_ode.configure()`), Agg plotting, and a key fixture.

Every test process, the pytest-xdist workers and the `snapo` processes their tests start, compiles
through one persistent cache (`SNAPO_CACHE_DIR`, unless set: the default cache's `tests`): a
program that several tests build (the gas sample's valuation, the pharma chain's solves, a CLI
verb run in-process three times) compiles once per run, and a second run of the suite reads what
the first compiled. Entries are written atomically and read whole (`snapo_ode._platform.cache_trust`),
so the two workers share the directory safely. The tests of the cache itself (sharing one
between processes, swapped and corrupt entries) make their own directories.

After each test module the worker drops every compiled program from memory
(`jax.clear_caches()`), and before each test, once it holds half the kernel's memory-mapping
limit, it relieves the mappings (`relieve_mappings`, checked when something compiled since):
every compiled CPU program stays mapped while JAX's caches hold it (~1,700 mappings for a stiff
solve and its gradient), and a worker that compiled a few dozen reached Linux's 65,530 (`LLVM
ERROR: Unable to allocate section memory`, and segmentation faults inside XLA's executable
serialisation, before this relief)."""

import os

os.environ.setdefault("MPLBACKEND", "Agg")
# Compile time is most of the suite's time: every test process (and the `snapo` processes the tests
# start, which inherit it) compiles with XLA's elemental emitters at LLVM level 1, the options of
# `snapo_ode.QUICK_COMPILE`, which change no result beyond round-off and cut compile-bound tests by
# about a fifth (test_ignition and test_pharma_design on an empty cache, 2026-11-27: 226 -> 184 s).
# The benches, `make demo`, `make docs` and users' runs keep XLA's defaults.
os.environ["XLA_FLAGS"] = " ".join(filter(None, [os.environ.get("XLA_FLAGS"), "--xla_cpu_use_fusion_emitters=false",
                                                 "--xla_backend_optimization_level=1"]))

import jax  # noqa: E402
import pytest  # noqa: E402

import snapo_ode  # noqa: E402
from snapo_ode._platform.resources import relieve_mappings_after_compiles  # noqa: E402


def pytest_configure(config):
    workerinput = getattr(config, "workerinput", None)
    if workerinput is None and getattr(config.option, "numprocesses", None):
        return  # the xdist controller runs no test; its environment is the workers'
    os.environ.setdefault("SNAPO_CACHE_DIR", str(snapo_ode.default_cache_dir().parent / "tests"))
    snapo_ode.configure()


@pytest.fixture(autouse=True, scope="module")
def _fresh_programs_per_module():
    yield
    jax.clear_caches()


@pytest.fixture(autouse=True)
def _mappings_below_the_limit():
    relieve_mappings_after_compiles()


@pytest.fixture
def key():
    return jax.random.key(0)
