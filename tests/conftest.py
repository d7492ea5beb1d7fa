"""Shared test scaffolding: float64 and the compilation cache on once for the whole session
(`snapo_ode.configure()`), Agg plotting, and a key fixture."""

import os

os.environ.setdefault("MPLBACKEND", "Agg")

import jax  # noqa: E402
import pytest  # noqa: E402

import snapo_ode  # noqa: E402

snapo_ode.configure()


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
