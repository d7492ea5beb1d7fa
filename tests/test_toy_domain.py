"""A toy domain plugged in through the `snapo_ode.plugins` entry point, as docs/adding_a_domain.md
describes: its typed study result, its verb and its bench, found by `snapo` as an installed domain
is. The whole domain is the module `TOY` below (the test file stays under 100 lines)."""

import csv
import json

import numpy as np
import pytest

from snapo_ode.cli import main

TOY = '''
"""toy: x' = -k x on [0, 1], x(0) = 1; the study checks dx(1)/dk against central bumps."""
import dataclasses

import jax.numpy as jnp

import snapo_ode


@dataclasses.dataclass(frozen=True, kw_only=True)
class DecayStudy(snapo_ode.Result):
    rate: float
    value: float
    sensitivity: float
    max_rel_diff: float

    def summary(self):
        return f"x(1) = {self.value:.6f}, dx(1)/dk = {self.sensitivity:.6f} (bumps agree to {self.max_rel_diff:.1e})"


def run_decay(rate):
    snapo_ode.check_range("rate", rate, 0.0, 100.0)
    settings = snapo_ode.SolverSettings(rtol=1e-10, atol=1e-12)

    def x_end(k):
        return settings.solve(lambda t, x, k: -k * x, 0.0, 1.0, jnp.ones(()), k).ys[-1]

    bumps = snapo_ode.compare_with_bumps(x_end, jnp.asarray(rate), relative_step=1e-4, repeats=1)
    return DecayStudy(rate=rate, value=float(bumps.value), sensitivity=float(bumps.adjoint),
                      max_rel_diff=bumps.max_rel_diff)


def run(args):
    study = run_decay(args.rate)
    study.write_json(args.json)
    print(study.summary())


def bench(args):
    rows = [run_decay(rate).to_json() for rate in args.rates]
    print(snapo_ode.format_table(rows, [snapo_ode.Column("k", "rate", "g"), snapo_ode.Column("x(1)", "value", ".6f")]))
    snapo_ode.write_table(args.out, "bench_decay", rows)


def register(cli):
    verb = cli.command("decay", "exponential decay and its sensitivity to the rate")
    verb.add_argument("--rate", type=float, default=1.0)
    verb.set_defaults(handler=run)
    timing = cli.bench("decay", "exponential decay at several rates")
    timing.add_argument("--rates", type=float, nargs="+", default=[0.5, 2.0])
    timing.set_defaults(handler=bench)
'''


@pytest.fixture
def toy_installed(tmp_path, monkeypatch):
    (tmp_path / "toy.py").write_text(TOY)
    info = tmp_path / "toy-0.1.dist-info"
    info.mkdir()
    (info / "METADATA").write_text("Metadata-Version: 2.1\nName: toy\nVersion: 0.1\n")
    (info / "entry_points.txt").write_text("[snapo_ode.plugins]\ntoy = toy:register\n")
    monkeypatch.syspath_prepend(str(tmp_path))
    return tmp_path


def test_a_toy_domain_plugs_in_its_verb_bench_and_result(toy_installed, capsys):
    out = toy_installed / "out"
    assert main(["decay", "--rate", "2", "--out", str(out)]) == 0
    result = json.loads((out / "decay.json").read_text())
    assert result["value"] == pytest.approx(np.exp(-2.0), rel=1e-8)
    assert result["sensitivity"] == pytest.approx(-np.exp(-2.0), rel=1e-7)
    assert result["max_rel_diff"] < 1e-6
    assert main(["bench", "decay", "--out", str(out)]) == 0
    rows = list(csv.DictReader((out / "bench_decay.csv").open()))
    assert [float(row["rate"]) for row in rows] == [0.5, 2.0]
    assert "| 0.5 |" in capsys.readouterr().out
    assert main(["decay", "--rate", "-1", "--out", str(out)]) == 2
    assert "rate = -1.0 is outside the allowed range [0, 100]" in capsys.readouterr().err
