"""The seven notebooks: committed without outputs, each with its small size (`SNAPO_NOTEBOOK_SMALL`),
checked by `make test`; run end to end at that size by `make docs` (which CI runs after
`make test`: a cell that raises fails the site's build, a page without a figure or with output on
stderr too) and by `make test-slow`, in the kernels' environment of the site's build."""

import importlib.util
import json
import pathlib

import pytest

NOTEBOOKS = pathlib.Path(__file__).resolve().parent.parent / "notebooks"
NAMES = sorted(path.name for path in NOTEBOOKS.glob("*.ipynb"))


def test_the_notebooks_are_committed_without_outputs_and_have_a_small_size():
    assert len(NAMES) == 7
    for name in NAMES:
        cells = [cell for cell in json.loads((NOTEBOOKS / name).read_text())["cells"] if cell["cell_type"] == "code"]
        assert all(not cell.get("outputs") and cell.get("execution_count") is None for cell in cells), name
        assert any('os.environ.get("SNAPO_NOTEBOOK_SMALL") == "1"' in "".join(cell["source"]) for cell in cells), name


@pytest.mark.slow
@pytest.mark.parametrize("name", NAMES)
def test_the_notebook_runs_end_to_end_at_its_small_size(name, monkeypatch):
    import nbformat
    from nbclient import NotebookClient

    spec = importlib.util.spec_from_file_location("notebook_env", NOTEBOOKS.parent / "docs" / "hooks" / "notebook_env.py")
    hook = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(hook)
    monkeypatch.setenv("SNAPO_NOTEBOOK_SMALL", "1")
    for variable, value in hook.KERNEL_ENVIRONMENT.items():
        monkeypatch.setenv(variable, value)
    notebook = nbformat.read(NOTEBOOKS / name, as_version=4)
    NotebookClient(notebook, timeout=300, kernel_name="python3", resources={"metadata": {"path": str(NOTEBOOKS)}}).execute()
    outputs = [output for cell in notebook.cells if cell.cell_type == "code" for output in cell.outputs]
    assert any("image/png" in output.get("data", {}) for output in outputs), f"{name}: no figure"
    stderr = [output.text for output in outputs if output.output_type == "stream" and output.name == "stderr"]
    assert not stderr, f"{name}: {stderr}"
