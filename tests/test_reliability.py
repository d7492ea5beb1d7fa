"""Reliability (issue 19): each reported failure reproduced, and now a clear one-line error or a
correct result; outputs of one command form a set; files respect the umask; a run too large for
memory is refused before it allocates; several processes can share the cache and an output
directory."""

import json
import os
import stat
import subprocess
import sys
import textwrap

import numpy as np
import pytest

import snapo_ode
from finance import gas_storage as gs
from snapo_ode.cli import main


def error_of(argv, capsys) -> str:
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert err.startswith("snapo: error: ") and err.count("\n") == 1, err
    return err


def test_outputs_that_cannot_be_written_are_refused_before_any_computation(tmp_path, capsys, monkeypatch):
    import importlib

    import jax

    importlib.import_module("diffrax")  # before jax.jit is patched: equinox uses it at import

    monkeypatch.setattr(jax, "jit", lambda *a, **k: pytest.fail("nothing may compile before the outputs are checked"))
    a_file = tmp_path / "file"
    a_file.write_text("x")
    assert "is a directory" in error_of(["gas", "--json", str(tmp_path)], capsys)
    assert not list(tmp_path.glob("*.policy.eqx"))  # no stray DIR.policy.eqx
    assert "is a file" in error_of(["gas", "--json", str(a_file / "out.json")], capsys)
    assert "is an existing file" in error_of(["report", "pharma", "--out", str(a_file)], capsys)
    assert "is a file" in error_of(["report", "pharma", "--out", str(a_file / "report")], capsys)
    other = tmp_path / "other"
    other.mkdir()
    (other / "notes.txt").write_text("mine")
    assert "no earlier run wrote" in error_of(["report", "pharma", "--out", str(other)], capsys)


def test_bad_inputs_are_one_line_errors(tmp_path, capsys):
    assert "curve file" in error_of(["gas", "--curve", str(tmp_path / "missing.csv")], capsys)
    assert "facility file" in error_of(["gas", "--facility", str(tmp_path / "missing.json")], capsys)
    assert "add --stochastic" in error_of(["gas", "--volatility", "0.5"], capsys)
    assert "--volatility: -1 is out of range" in error_of(["gas", "--volatility", "-1"], capsys)
    assert "--train-steps: 0 is out of range: allowed >= 1" in error_of(["gas", "--train-steps", "0"], capsys)
    bad_curve = tmp_path / "curve.csv"
    bad_curve.write_text("day,price\n0,3.0\n1,abc\n")
    assert "line 3" in error_of(["gas", "--curve", str(bad_curve)], capsys)
    zeros = tmp_path / "zeros.csv"
    zeros.write_text("day,price\n" + "".join(f"{d},0\n" for d in range(30)))
    assert "zero on every day" in error_of(["gas", "--curve", str(zeros)], capsys)
    yaml = tmp_path / "broken.yaml"
    yaml.write_text("phases:\n- name: gas\n  species: [H2\n")
    assert str(yaml) in error_of(["kinetics", "check", str(yaml)], capsys)
    assert "risk factors" in error_of(["alm", "--risk-factors", "10000000"], capsys)  # not an OOM kill
    assert "nodes = 2.5" in str(pytest.raises(snapo_ode.InputError, gs.inventory_grid,
                                              gs.make_inputs(*gs.CASES["bdj"]()), gs.stochastic_scene(), 2.5).value)


def test_negative_prices_are_valued_deterministically_and_refused_stochastically():
    facility, curve = gs.CASES["bdj"]()
    negative = curve - 18.0  # about half of the days below zero
    inputs = gs.make_inputs(facility, negative)
    lp = gs.solve_intrinsic(inputs, gs.deterministic_scene())
    # The dynamic program on bdj's exact inventory grid (LSMC at zero volatility) is the other
    # exact solution; being paid to take gas, both end fuller than the required 100,000 MWh.
    prices = np.asarray(negative)[None, :]
    dp = gs.value_lsmc(inputs, gs.stochastic_scene(), prices, prices, nodes=101, degree=0)
    assert dp["lsmc_out_of_sample"] == pytest.approx(lp.value, rel=1e-10)
    assert lp.inventory[-1] > facility["terminal_inventory_min"] + 1.0
    with pytest.raises(snapo_ode.InputError, match="log-normal"):
        gs.run_study(gs.make_inputs(facility, negative, volatility=0.6, mean_reversion=18.0),
                     gs.StudySettings(stochastic=True, paths=8, train_paths=8, train_steps=1, progress=False))


def test_a_facility_worth_nothing_gives_a_json_not_a_crash(tmp_path):
    facility = tmp_path / "facility.json"
    facility.write_text(json.dumps(dict(gs.sample_facility(), max_injection=0.0, initial_inventory=0.0,
                                        terminal_inventory_min=0.0)))
    out = tmp_path / "gas.json"
    assert main(["gas", "--facility", str(facility), "--train-steps", "3", "--json", str(out), "--no-progress"]) == 0
    result = json.loads(out.read_text())
    assert result["intrinsic_lp"] == 0.0 and result["hard_to_lp_ratio"] is None
    assert result["mode"] == "deterministic" and result["seed"] == 0  # the initial policy's seed, in every mode
    policy = tmp_path / "gas.policy.eqx"
    assert result["attachments"]["gas.policy.eqx"] == snapo_ode.sha256(policy.read_bytes())


def test_a_set_is_published_whole_or_not_at_all(tmp_path):
    old = {tmp_path / "a.bin": b"old a", tmp_path / "b.json": b"old b"}
    snapo_ode.publish(old)
    with pytest.raises(ValueError):  # the JSON of the new set cannot be written: NaN
        snapo_ode.publish({tmp_path / "a.bin": b"new a", tmp_path / "b.json": snapo_ode.json_bytes(float("nan"))})
    assert {path.read_bytes() for path in old} == {b"old a", b"old b"}
    report = tmp_path / "report"
    snapo_ode.publish_directory(report, {"x.html": b"1", "y.pdf": b"1"})
    snapo_ode.publish_directory(report, {"x.html": b"2"})
    assert sorted(p.name for p in report.iterdir()) == [snapo_ode.MANIFEST, "x.html"]
    assert not [p for p in tmp_path.iterdir() if p.name.startswith(".")]  # no temporaries left


def test_outputs_respect_the_umask_and_a_replaced_file_keeps_its_mode(tmp_path):
    previous = os.umask(0o022)
    try:
        path = snapo_ode.atomic_write_text(tmp_path / "new.txt", "x")
        assert stat.S_IMODE(path.stat().st_mode) == 0o644
        path.chmod(0o640)
        snapo_ode.atomic_write_text(path, "y")
        assert stat.S_IMODE(path.stat().st_mode) == 0o640
    finally:
        os.umask(previous)


def test_training_verbs_resume_from_their_checkpoint(tmp_path):
    argv = ["alm", "--risk-factors", "10", "--paths", "8", "--horizon-months", "3", "--train-steps", "4",
            "--train-paths", "8", "--no-progress"]
    assert main([*argv, "--json", str(tmp_path / "a.json")]) == 0
    assert (tmp_path / "a.checkpoint.eqx").exists()
    # Resuming a finished run continues from its last step: nothing left to train, the same result.
    assert main([*argv, "--json", str(tmp_path / "a.json"), "--resume"]) == 0
    first = json.loads((tmp_path / "a.json").read_text())
    assert main([*argv, "--json", str(tmp_path / "b.json")]) == 0
    second = json.loads((tmp_path / "b.json").read_text())
    assert first["objective"] == second["objective"] and first["sensitivities"] == second["sensitivities"]


def test_four_processes_share_the_cache_and_the_output_directory(tmp_path):
    script = textwrap.dedent("""
        import sys, jax, jax.numpy as jnp, snapo_ode
        snapo_ode.configure(sys.argv[1])
        f = jax.jit(lambda x, c: jnp.sin(x) @ jnp.cos(x).T + c)  # one program, shared by all
        value = float(f(jnp.ones((40, 40)), jnp.asarray(float(sys.argv[3]))).sum())
        snapo_ode.atomic_write_json(sys.argv[2], {"value": value, "writer": sys.argv[3]})
        snapo_ode.publish({sys.argv[2] + ".csv": b"a,b\\n", sys.argv[2] + ".set.json": snapo_ode.json_bytes({"v": value})})
    """)
    cache, out = tmp_path / "cache", tmp_path / "out" / "result.json"
    runs = [subprocess.Popen([sys.executable, "-c", script, str(cache), str(out), str(i)]) for i in range(4)]
    assert [run.wait(timeout=300) for run in runs] == [0, 0, 0, 0]
    written = json.loads(out.read_text())
    expected = float(np.sum(np.sin(np.ones((40, 40))) @ np.cos(np.ones((40, 40))).T + float(written["writer"])))
    assert written["value"] == pytest.approx(expected, rel=1e-12)
    assert not [p for p in out.parent.iterdir() if p.name.startswith(".")]
    # The cache survived four writers: a fifth process reads its program back.
    subprocess.run([sys.executable, "-c", script, str(cache), str(tmp_path / "fifth.json"), "0"], check=True)
