"""The pharma notebook runs end to end at a small size (it is committed without outputs)."""


def test_notebook_is_committed_without_outputs_and_runs_small(run_notebook):
    run_notebook("03_pharma_ichq8.ipynb", timeout=600)
