"""`snapo alm` and `snapo bench alm` at a small size: the JSON keys, the table and its files."""

import csv
import json

from finance.alm._cli import register_alm
from snapo_ode.cli import main

KEYS = {"objective", "funding_ratio", "sensitivities", "adjoint_seconds", "bump_seconds",
        "forward_mode_seconds", "speedup", "max_rel_diff", "train_seconds", "compile_seconds",
        "objective_smooth", "smoothing_gap", "baselines", "value_seconds", "gradient_forward_ratio"}


def _run(argv):
    return main(argv, plugins=[register_alm])


def test_alm_writes_every_key_with_bump_and_training(tmp_path, capsys):
    out = tmp_path / "alm.json"
    code = _run(["alm", "--risk-factors", "12", "--paths", "8", "--horizon-months", "3", "--bump",
                 "--train-steps", "2", "--train-paths", "8", "--no-progress", "--json", str(out)])
    assert code == 0
    payload = json.loads(out.read_text())
    assert KEYS <= set(payload)
    assert len(payload["sensitivities"]) == payload["n_risk_factors"] == 12
    assert payload["max_rel_diff"] <= 1e-6
    assert payload["train_seconds"] > 0
    assert set(payload["funding_ratio"]) == {"mean", "p05", "p50", "p95", "probability_below_1"}
    assert "speedup" in capsys.readouterr().out


def test_bench_writes_the_scaling_table(tmp_path, capsys):
    code = _run(["bench", "alm", "--risk-factors", "10", "20", "--paths", "4",
                 "--horizon-months", "2", "--repeats", "1", "--no-progress", "--out", str(tmp_path)])
    assert code == 0
    rows = list(csv.DictReader((tmp_path / "alm_scaling.csv").open()))
    assert [int(row["n_risk_factors"]) for row in rows] == [10, 20]
    assert all(float(row["max_rel_diff"]) <= 1e-6 for row in rows)
    assert (tmp_path / "alm_scaling.png").stat().st_size > 1000
    assert json.loads((tmp_path / "alm_scaling.json").read_text())["rows"][0]["n_risk_factors"] == 10
    # Every bench's names, the same table: bench_alm.{csv,json}.
    assert (tmp_path / "bench_alm.csv").read_text() == (tmp_path / "alm_scaling.csv").read_text()
    assert json.loads((tmp_path / "bench_alm.json").read_text()) == json.loads((tmp_path / "alm_scaling.json").read_text())
    assert "| 20 |" in capsys.readouterr().out
