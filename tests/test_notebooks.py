"""The six notebooks: committed without outputs, each with its small size (`SNAPO_NOTEBOOK_SMALL`),
checked by `make test`; run end to end at that size by `make docs` (which CI runs after
`make test`: a cell that raises fails the site's build) and by `make test-slow`."""

import json
import pathlib

import pytest

NOTEBOOKS = pathlib.Path(__file__).resolve().parent.parent / "notebooks"
NAMES = sorted(path.name for path in NOTEBOOKS.glob("*.ipynb"))


def test_the_notebooks_are_committed_without_outputs_and_have_a_small_size():
    assert len(NAMES) == 6
    for name in NAMES:
        cells = [cell for cell in json.loads((NOTEBOOKS / name).read_text())["cells"] if cell["cell_type"] == "code"]
        assert all(not cell.get("outputs") and cell.get("execution_count") is None for cell in cells), name
        assert any('os.environ.get("SNAPO_NOTEBOOK_SMALL") == "1"' in "".join(cell["source"]) for cell in cells), name


@pytest.mark.slow
@pytest.mark.parametrize("name", NAMES)
def test_the_notebook_runs_end_to_end_at_its_small_size(name, monkeypatch):
    import nbformat
    from nbclient import NotebookClient

    monkeypatch.setenv("SNAPO_NOTEBOOK_SMALL", "1")
    monkeypatch.setenv("MPLBACKEND", "Agg")
    notebook = nbformat.read(NOTEBOOKS / name, as_version=4)
    NotebookClient(notebook, timeout=300, kernel_name="python3", resources={"metadata": {"path": str(NOTEBOOKS)}}).execute()
