"""The core of `snapo bench accuracy`: cheapest settings, the page, its plots and CSVs, the CLI
hook, on a toy study whose errors are against an analytic solution."""

import csv
import json
import math

import pytest

from snapo_ode import AccuracyStudy, Panel, Point, cheapest, read_accuracy, write_accuracy
from snapo_ode.cli import main


def euler_error(steps: int) -> float:
    """Relative error of explicit Euler on y' = -y, y(0) = 1, at t = 1 (exact: e^-1)."""
    y = 1.0
    for _ in range(steps):
        y -= y / steps
    return abs(y - math.exp(-1.0)) / math.exp(-1.0)


def toy_panel(target=1e-2) -> Panel:
    points = [Point("Euler", f"steps={n}", float(n), euler_error(n)) for n in (10, 100, 1000)]
    points += [Point("broken", "steps=1", float("nan"), float("nan"), failure="did not converge")]
    return Panel("toy_euler", "Euler on y' = -y", "steps", "relative error", points, target=target)


def test_cheapest_is_the_first_setting_reaching_the_target():
    panel = toy_panel()
    # Euler's error is ~1/(2n) relative: 10 steps miss 1e-2, 100 reach it.
    assert euler_error(10) > 1e-2 > euler_error(100)
    (best,) = cheapest(panel)
    assert (best.method, best.setting) == ("Euler", "steps=100")
    assert cheapest(toy_panel(target=None)) == []


def test_bench_accuracy_writes_the_page_plots_and_csv(tmp_path):
    seen = {}

    def register(cli):
        def run(args):
            seen["quick"] = args.quick
            return [AccuracyStudy("toy", "Toy", [toy_panel()], text="Explicit Euler against e^-1.")]
        cli.accuracy("toy", run)

    out = tmp_path / "out"
    assert main(["bench", "accuracy", "--quick", "--out", str(out), "--no-progress"], plugins=[register]) == 0
    assert seen["quick"] is True
    page = (out / "accuracy.md").read_text()
    assert "## Toy" in page and "accuracy/toy_euler.png" in page and "steps=100" in page
    assert "Never reached: broken." in page and "broken at steps=1: did not converge" in page
    assert (out / "accuracy" / "toy_euler.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    with open(out / "accuracy" / "toy_euler.csv") as file:
        rows = list(csv.DictReader(file))
    assert [row["setting"] for row in rows[:3]] == ["steps=10", "steps=100", "steps=1000"]
    assert float(rows[1]["y"]) == pytest.approx(euler_error(100), rel=1e-12)
    payload = json.loads((out / "bench_accuracy.json").read_text())
    assert payload["quick"] is True
    assert payload["studies"][0]["panels"][0]["cheapest"][0]["setting"] == "steps=100"


def test_bench_accuracy_refuses_an_unknown_study(tmp_path, capsys):
    def register(cli):
        cli.accuracy("toy", lambda args: [])

    code = main(["bench", "accuracy", "--only", "nope", "--out", str(tmp_path)], plugins=[register])
    assert code == 2
    assert "--only = 'nope'" in capsys.readouterr().err


def test_the_json_gives_the_studies_back(tmp_path):
    study = AccuracyStudy("toy", "Toy", [toy_panel()._replace(notes="Notes.", log_y=False)], text="Text.")
    write_accuracy(tmp_path, [study], "snapo bench accuracy")
    (back,) = read_accuracy(tmp_path / "bench_accuracy.json")
    assert (back.name, back.title, back.text) == ("toy", "Toy", "Text.")
    panel, original = back.panels[0], study.panels[0]
    assert panel._replace(points=[]) == original._replace(points=[])
    assert [p[:2] + p[4:] for p in panel.points] == [p[:2] + p[4:] for p in original.points]
    finite = [(p.x, p.y) for p in panel.points if not p.failure]
    assert finite == [(p.x, p.y) for p in original.points if not p.failure]
    assert math.isnan(panel.points[-1].x) and panel.points[-1].failure == "did not converge"
    # The page written from the studies read back is the page written from the originals.
    write_accuracy(tmp_path / "again", [back], "snapo bench accuracy")
    assert (tmp_path / "again" / "accuracy.md").read_text() == (tmp_path / "accuracy.md").read_text()
