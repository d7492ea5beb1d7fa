"""The accuracy notebook runs end to end at a small size (`snapo bench accuracy --quick --only
smoothing`; it is committed without outputs)."""


def test_notebook_is_committed_without_outputs_and_runs_small(run_notebook):
    run_notebook("04_accuracy_vs_time.ipynb", timeout=600)
