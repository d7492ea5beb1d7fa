"""`snapo bench accuracy --quick` regenerates the page, plots and CSVs, and what they show holds:
errors fall as tolerances tighten, each reference agrees with its second method, the smooth-hard
gap falls like 1/k, standard errors like 1/sqrt(paths). One quick run per study for the whole file."""

import json
import math
import subprocess
import sys

import pytest

STUDIES = ("smoothing", "monte-carlo")
# Under `make test-slow`: the stiff study (~6 minutes on a 2-core machine with a cold cache; the
# solvers it compares are each checked against references in test_core_rosenbrock, test_core_bdf,
# test_hard_cases and test_ignition) and the gradients study (~17 minutes).


def run_studies(out, studies) -> dict:
    """`snapo bench accuracy --quick --only A --only B ...`: one page of the studies, each run in a
    `snapo` process of its own (the default when several run); {panel name: panel of the JSON}."""
    command = [sys.executable, "-m", "snapo_ode.cli", "bench", "accuracy", "--quick", "--out", str(out), "--no-progress"]
    run = subprocess.run(command + [flag for study in studies for flag in ("--only", study)],
                         capture_output=True, text=True)
    assert run.returncode == 0, run.stderr[-3000:]
    payload = json.loads((out / "bench_accuracy.json").read_text())
    assert list(dict.fromkeys(study["name"] for study in payload["studies"])) == list(studies)
    return {panel["name"]: panel for study in payload["studies"] for panel in study["panels"]}


@pytest.fixture(scope="module")
def stiff(tmp_path_factory):
    """The stiff study's quick page, as `bench` (under `make test-slow`)."""
    return run_studies(tmp_path_factory.mktemp("stiff"), ("stiff",))


@pytest.fixture(scope="module")
def bench(tmp_path_factory):
    """One quick page of the CI studies, as a user would run it: each study in a `snapo` process
    of its own, out of the pytest-xdist worker (a worker that compiled the bench's few hundred
    programs beside the rest of its tests died inside XLA's compiler; see conftest.py)."""
    out = tmp_path_factory.mktemp("accuracy")
    return out, run_studies(out, STUDIES)


def _line(panel, method):
    return [row for row in panel["rows"] if row["method"] == method]


def _assert_errors_fall_tenfold(line):
    assert len(line) >= 2 and all(row["y"] is not None for row in line)
    assert line[-1]["y"] < line[0]["y"] / 10


def test_the_page_plots_and_csvs_are_written(bench):
    out, panels = bench
    page = (out / "accuracy.md").read_text()
    for name in panels:
        assert (out / "accuracy" / f"{name}.png").stat().st_size > 10_000
        assert (out / "accuracy" / f"{name}.csv").read_text().startswith("method,setting,x,y")
        assert f"accuracy/{name}.png" in page
    assert {"smoothing_gas_gap", "smoothing_gas_gradient", "monte_carlo_gas_se", "smoothing_alm_gap",
            "monte_carlo_alm_se", "monte_carlo_alm_time"} <= set(panels)


@pytest.mark.slow
@pytest.mark.parametrize(("panel", "method"), [
    ("stiff_robertson", "Rodas4 (ours)"), ("stiff_robertson", "Rodas5 (ours, default)"),
    ("stiff_h2o2_ignition", "Rodas5 (ours, default)"), ("stiff_h2o2_ignition", "Cantera CVODES (C++)"),
    ("stiff_pharma_chain", "Rodas5 + Tsit5 (default)"),
])
def test_errors_fall_as_the_tolerance_tightens(stiff, panel, method):
    _assert_errors_fall_tenfold(_line(stiff[panel], method))


@pytest.mark.slow
def test_every_stiff_panel_has_ours_and_a_peer_and_names_failures(stiff):
    panels = stiff
    assert {"stiff_robertson", "stiff_h2o2_ignition", "stiff_pharma_chain"} <= set(panels)
    for name in ("stiff_robertson", "stiff_h2o2_ignition"):
        methods = {row["method"] for row in panels[name]["rows"] if row["y"] is not None}
        assert {"Rodas5 (ours, default)", "Rodas4 (ours)"} <= methods
        assert {"SciPy Radau (host)", "SciPy BDF (host)"} <= methods
    # Tsit5 cannot cross Robertson's stiff stretch: a listed failure, never a plotted NaN.
    tsit5 = _line(panels["stiff_robertson"], "Tsit5 (Diffrax, explicit)")
    assert tsit5 and all(row["failure"] and row["y"] is None for row in tsit5)
    assert "Tsit5 (Diffrax, explicit)" in panels["stiff_robertson"]["missed"]


def test_the_smooth_gap_falls_like_one_over_sharpness_and_the_adjoint_matches_bumps(bench):
    panels = bench[1]
    gap = panels["smoothing_gas_gap"]["rows"]
    assert all(a["y"] > b["y"] for a, b in zip(gap, gap[1:]))
    slope = math.log(gap[-1]["y"] / gap[0]["y"]) / math.log(gap[-1]["x"] / gap[0]["x"])
    assert -1.3 < slope < -0.7
    smooth = _line(panels["smoothing_gas_gradient"], "adjoint vs bumps of the smooth value")
    assert max(row["y"] for row in smooth) < 1e-6


@pytest.mark.parametrize(("panel", "method"), [("monte_carlo_gas_se", "hard value"),
                                                ("monte_carlo_alm_se", "objective J (exact constraints)")])
def test_standard_errors_fall_like_one_over_root_paths(bench, panel, method):
    rows = _line(bench[1][panel], method)
    ratio = rows[0]["y"] / rows[-1]["y"]
    assert 0.5 * math.sqrt(rows[-1]["x"] / rows[0]["x"]) < ratio < 2 * math.sqrt(rows[-1]["x"] / rows[0]["x"])


def test_the_alm_smooth_gap_falls_as_the_floor_sharpens(bench):
    gap = bench[1]["smoothing_alm_gap"]["rows"]
    assert len(gap) >= 3 and all(a["y"] > b["y"] for a, b in zip(gap, gap[1:]))


@pytest.mark.slow
def test_gradient_errors_fall_as_the_tolerance_tightens(tmp_path):
    panels = run_studies(tmp_path, ("gradients",))
    assert {"gradients_pharma_chain", "gradients_h2o2_ignition"} <= set(panels)
    _assert_errors_fall_tenfold(_line(panels["gradients_pharma_chain"], "reverse, a checkpoint a step"))
