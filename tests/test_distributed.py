"""Samples split over devices and processes give the single-device results: the core's sharded
mean and its gradient against the analytic ones on 4 forced host devices, and `snapo alm` on 2
and 4 devices and in two processes on loopback (CPU collectives) against one device, values and
sensitivities to 1e-12 relative. Each run is a process of its own: the device count is fixed
when JAX starts."""

import json
import socket
import subprocess
import sys
import textwrap

import pytest

ALM = ["alm", "--risk-factors", "12", "--paths", "48", "--horizon-months", "6", "--bump", "--no-progress"]
TIMING_KEYS = ("seconds", "speedup", "forward_ratio")
"""Keys whose values are timings or their ratios (they differ between any two runs)."""
ERROR_KEYS = ("max_rel_diff",)
"""Keys that measure the bumps' round-off against the adjoint: equal to its order, not its digits."""


def _snapo(*argv):
    return subprocess.Popen([sys.executable, "-m", "snapo_ode.cli", *argv], stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True)


def _finish(process, timeout=600):
    out, err = process.communicate(timeout=timeout)
    assert process.returncode == 0, err[-3000:]
    return out


def _compare(reference, other, path=""):
    """Every leaf of `other` equals `reference`'s: floats to 1e-12 relative, timings ignored,
    error measures to their order."""
    if isinstance(reference, dict):
        assert set(reference) == set(other), path
        for key in reference:
            _compare(reference[key], other[key], f"{path}/{key}")
    elif isinstance(reference, list):
        assert len(reference) == len(other), path
        for k, (a, b) in enumerate(zip(reference, other)):
            _compare(a, b, f"{path}[{k}]")
    elif isinstance(reference, float) and not any(key in path for key in TIMING_KEYS):
        if any(key in path for key in ERROR_KEYS):
            assert other == pytest.approx(reference, rel=0.5), path
        else:
            assert other == pytest.approx(reference, rel=1e-12, abs=1e-300), path
    elif not isinstance(reference, float):
        assert reference == other, path


@pytest.fixture(scope="module")
def one_device(tmp_path_factory):
    out = tmp_path_factory.mktemp("one")
    _finish(_snapo(*ALM, "--devices", "1", "--out", str(out)))
    return json.loads((out / "alm.json").read_text())


@pytest.mark.parametrize("devices", [2, 4])
def test_alm_on_several_devices_equals_one_device(one_device, tmp_path, devices):
    _finish(_snapo(*ALM, "--devices", str(devices), "--out", str(tmp_path)))
    _compare(one_device, json.loads((tmp_path / "alm.json").read_text()))


def test_alm_in_two_processes_equals_one_process_and_only_process_0_writes(one_device, tmp_path):
    with socket.socket() as probe:  # a free port for the coordinator
        probe.bind(("127.0.0.1", 0))
        port = probe.getsockname()[1]
    runs = [_snapo(*ALM, "--out", str(tmp_path / f"process{i}"), "--coordinator", f"127.0.0.1:{port}",
                   "--num-processes", "2", "--process-id", str(i)) for i in range(2)]
    outputs = [_finish(run) for run in runs]
    assert "written:" in outputs[0] and "written:" not in outputs[1]
    assert not (tmp_path / "process1").exists()
    _compare(one_device, json.loads((tmp_path / "process0" / "alm.json").read_text()))


def test_paths_that_do_not_split_are_refused_before_any_compile(tmp_path):
    run = subprocess.run([sys.executable, "-m", "snapo_ode.cli", *ALM[:3], "--paths", "47", "--devices", "2",
                          "--out", str(tmp_path)], capture_output=True, text=True)
    assert run.returncode == 2
    assert "paths = 47 does not split over 2 devices; use a multiple of 2 (e.g. 46 or 48)" in run.stderr


def test_the_sharded_mean_and_its_gradient_equal_the_analytic_ones():
    """E[sin(a s)] over s ~ N(0, 1) draws split over 4 devices: the mean and d/da against the
    same draws on the host (sum of a * cos(a s) * s / n), and the draws equal the unsharded ones."""
    script = textwrap.dedent("""
        import jax, jax.numpy as jnp, numpy as np
        import snapo_ode
        snapo_ode.use_cpu_devices(4)
        snapo_ode.configure()
        mesh = snapo_ode.sample_mesh()
        assert mesh.size == 4
        draw = lambda key: jax.random.normal(key, (3, 400))
        sharded = snapo_ode.generate_sharded(draw, mesh, samples_axis=1, ndim=2)(jax.random.key(7))
        assert len(sharded.sharding.device_set) == 4
        host = np.asarray(draw(jax.random.key(7)))
        assert np.array_equal(np.asarray(sharded), host)
        fn = lambda a, s: jnp.mean(jnp.sin(a * s[0]))
        mean = snapo_ode.sample_mean(fn, snapo_ode.mesh_of(sharded), (snapo_ode.spec(), snapo_ode.spec(None, "samples")))
        value, gradient = jax.jit(jax.value_and_grad(mean))(0.3, sharded)
        s = host[0]
        assert abs(float(value) - np.mean(np.sin(0.3 * s))) < 1e-15
        assert abs(float(gradient) - np.mean(np.cos(0.3 * s) * s)) < 1e-15
        print("ok")
    """)
    run = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True)
    assert run.returncode == 0 and run.stdout.strip() == "ok", run.stderr[-3000:]


# ~2 minutes with a cold cache: `make test-slow`; the sharded draws and Jacobians share their mesh code
# with ALM's runs on 2 and 4 devices and in two processes, above.
@pytest.mark.slow
def test_the_pharma_design_space_on_two_devices_equals_one_device():
    """The design space's full-model draws (`shifted_cqas`), 7 rows split over 2 devices (padded
    to 8), and its Jacobians at 3 grid points over 2 devices, against one device: to 1e-12."""
    script = textwrap.dedent("""
        import numpy as np
        import snapo_ode
        snapo_ode.use_cpu_devices(2)
        snapo_ode.configure()
        from chemistry.pharma import PharmaChain, make_cpps, shifted_cqas
        from chemistry.pharma._sensitivities import input_names, jacobians_function
        chain = PharmaChain()
        inputs = chain.inputs(make_cpps())
        names = input_names(chain)
        columns = [k for k, name in enumerate(names) if name.startswith("log_multiplier[")]
        shifts = np.zeros((7, len(names)))
        shifts[:, columns] = 0.1 * np.random.default_rng(0).standard_normal((7, len(columns)))
        one = shifted_cqas(chain, inputs, shifts)
        two = shifted_cqas(chain, inputs, shifts, snapo_ode.sample_mesh(2))
        assert one.shape == two.shape == (7, 5)
        assert len(set(np.round(one[:, 0], 9))) == 7  # the draws move the assay
        assert np.max(np.abs(two - one) / np.abs(one)) < 1e-12, np.max(np.abs(two - one) / np.abs(one))
        # The design space's Jacobians at grid points: three points over two devices.
        points = [chain.inputs(make_cpps(r1_temperature=t)) for t in (308.15, 313.15, 318.15)]
        single = jacobians_function(chain, True, "reverse")(points)
        spread = jacobians_function(chain, True, "reverse", snapo_ode.sample_mesh(2))(points)
        for (v1, m1), (v2, m2) in zip(single, spread, strict=True):
            assert np.max(np.abs(v2 - v1) / np.abs(v1)) < 1e-12
            assert np.max(np.abs(m2 - m1)) <= 1e-12 * np.max(np.abs(m1))
        assert not np.allclose(single[0][0], single[2][0])  # the points differ
        print("ok")
    """)
    run = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True)
    assert run.returncode == 0 and run.stdout.strip() == "ok", run.stderr[-3000:]


def test_bench_scaling_merges_the_device_counts_and_rates_them(tmp_path):
    """`snapo bench scaling --quick --only alm --device-counts 1,2`: one process per count, the
    rows merged with speed-up and efficiency against one device, the same value on each count."""
    run = subprocess.run([sys.executable, "-m", "snapo_ode.cli", "bench", "scaling", "--quick", "--only", "alm",
                          "--device-counts", "1,2", "--repeats", "1", "--no-progress", "--out", str(tmp_path)],
                         capture_output=True, text=True)
    assert run.returncode == 0, run.stderr[-3000:]
    rows = json.loads((tmp_path / "bench_scaling.json").read_text())["rows"]
    assert [(row["scaling"], row["devices"]) for row in rows] == [("strong", 1), ("weak", 1), ("strong", 2), ("weak", 2)]
    assert rows[2]["samples"] == rows[0]["samples"] and rows[3]["samples"] == 2 * rows[1]["samples"]
    assert rows[2]["value"] == pytest.approx(rows[0]["value"], rel=1e-12)
    for row in rows:
        speedup = rows[row["scaling"] == "weak"]["seconds"] / row["seconds"] * (row["devices"] if row["scaling"] == "weak" else 1)
        assert row["speedup"] == pytest.approx(speedup) and row["efficiency"] == pytest.approx(speedup / row["devices"])
        assert row["temp_megabytes_per_device"] > 0
    assert rows[2]["collective_bytes"] == 8 * 101 and rows[0]["collective_bytes"] == 0
    assert (tmp_path / "bench_scaling.png").stat().st_size > 10_000
    assert "| ALM sensitivities" in run.stdout


def test_bench_scaling_refuses_bad_device_counts_before_any_process(tmp_path, capsys):
    from snapo_ode.cli import main

    def register(cli):
        cli.scaling("toy", lambda args: [])

    code = main(["bench", "scaling", "--device-counts", "1,0", "--out", str(tmp_path)], plugins=[register])
    assert code == 2
    assert "--device-counts: entry 2: 0 is out of range: allowed >= 1" in capsys.readouterr().err
    assert not (tmp_path / "bench_scaling.json").exists()
