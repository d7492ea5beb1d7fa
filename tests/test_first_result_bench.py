"""`snapo bench first-result`: each registered workload runs cold once and warm `--repeats` times,
each in a new `snapo` process on one fresh cache directory; a failed child is reported (row, exit
code 1), not hidden; bad options are refused before any process starts. (What the exported
programs save is tested in test_core_exported.py; the times themselves are the bench's output.)"""

import json

from snapo_ode.cli import EXIT_INPUT_ERROR, main


def register(cli):
    cli.first_result("help", ["kinetics", "--help"])  # a real snapo process that succeeds at once
    cli.first_result("broken", ["bench", "accuracy", "--only", "no-such-study"])


def test_each_workload_is_timed_cold_and_warm_and_a_failure_is_reported(tmp_path, capsys):
    assert main(["bench", "first-result", "--repeats", "2", "--out", str(tmp_path)], plugins=[register]) == 1
    rows = {row["workload"]: row for row in json.loads((tmp_path / "bench_first_result.json").read_text())["rows"]}
    assert rows["help"]["ok"] and rows["help"]["exit_codes"] == [0, 0, 0]
    assert len(rows["help"]["warm_seconds_all"]) == 2 and rows["help"]["cold_seconds"] > 0
    assert rows["help"]["command"] == "snapo kinetics --help"
    assert not rows["broken"]["ok"] and rows["broken"]["exit_codes"] == [EXIT_INPUT_ERROR] * 3
    assert "'broken' failed" in capsys.readouterr().err
    assert (tmp_path / "bench_first_result.csv").exists()


def test_bad_options_are_refused_before_any_process(tmp_path):
    assert main(["bench", "first-result", "--only", "nope", "--out", str(tmp_path)], plugins=[register]) == 2
    assert main(["bench", "first-result", "--repeats", "0", "--out", str(tmp_path)], plugins=[register]) == 2
    assert not (tmp_path / "bench_first_result.json").exists()
