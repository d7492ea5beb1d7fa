"""The gas-storage notebook runs end to end at a small size (it is committed without outputs)."""


def test_notebook_is_committed_without_outputs_and_runs_small(run_notebook):
    run_notebook("01_gas_storage.ipynb", timeout=300)
