"""Shared test scaffolding: float64 and the compilation cache on once for the whole session
(`snapo_ode.configure()`), Agg plotting, and a key fixture.

Each pytest-xdist worker compiles into a cache directory of its own (`SNAPO_CACHE_DIR`, unless
set: the default cache's `tests/WORKER`), inherited by the `snapo` processes its tests start: two
workers never read and write one cache at once (a worker died of a segmentation fault inside
JAX's cache read in a CI run with a shared directory; not reproduced since). The tests of
sharing one cache between processes make their own directories.

The worker processes themselves write no persistent cache entries (`jax_enable_compilation_cache`
off in-process; the `snapo` processes their tests start still use the worker's directory): a
long-lived worker that had compiled a few hundred programs twice died of a segmentation fault
inside XLA's executable serialisation (`put_executable_and_time`, pharma programs), and
pytest-xdist then hung until CI's limit. Each program compiles once per worker either way, and
JAX's in-memory caches serve repeats within the process; the cache itself is tested across
processes (`test_core_cache.py`, `test_reliability.py`).

After each test module the worker drops every compiled program (`jax.clear_caches()`), and
before each test once it holds half the kernel's memory-mapping limit (`relieve_mappings`, checked
when something compiled since): the
cause of those crashes, found later, is that every compiled CPU program stays mapped while JAX's
caches hold it (~1,700 mappings for a stiff solve and its gradient), and a worker that compiled
a few dozen reached Linux's 65,530 (`LLVM ERROR: Unable to allocate section memory` in one run).
Modules rarely share programs, so few recompile."""

import os

os.environ.setdefault("MPLBACKEND", "Agg")

import jax  # noqa: E402
import pytest  # noqa: E402

import snapo_ode  # noqa: E402
from snapo_ode._resources import relieve_mappings_after_compiles  # noqa: E402



def pytest_configure(config):
    workerinput = getattr(config, "workerinput", None)
    if workerinput is None and getattr(config.option, "numprocesses", None):
        return  # the xdist controller runs no test; its environment is the workers'
    worker = workerinput["workerid"] if workerinput else "main"
    os.environ.setdefault("SNAPO_CACHE_DIR", str(snapo_ode.default_cache_dir().parent / "tests" / worker))
    snapo_ode.configure()
    jax.config.update("jax_enable_compilation_cache", False)


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


@pytest.fixture
def run_notebook(monkeypatch):
    """Execute `notebooks/NAME` at its small size (`SNAPO_NOTEBOOK_SMALL=1`), after checking that
    it is committed without outputs. One test file per notebook, so xdist runs them in parallel."""
    import pathlib

    import nbformat
    from nbclient import NotebookClient

    def run(name: str, timeout: int) -> None:
        path = pathlib.Path(__file__).parent.parent / "notebooks" / name
        notebook = nbformat.read(path, as_version=4)
        assert all(not cell.get("outputs") for cell in notebook.cells if cell.cell_type == "code")
        monkeypatch.setenv("SNAPO_NOTEBOOK_SMALL", "1")
        monkeypatch.setenv("MPLBACKEND", "Agg")
        NotebookClient(notebook, timeout=timeout, kernel_name="python3",
                       resources={"metadata": {"path": str(path.parent)}}).execute()

    return run
