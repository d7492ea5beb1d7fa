"""The pendulum notebook runs end to end at a small size (it is committed without outputs)."""


def test_notebook_is_committed_without_outputs_and_runs_small(run_notebook):
    run_notebook("05_pendulum.ipynb", timeout=300)
