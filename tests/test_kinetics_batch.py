"""Batched constant-volume ignitions (`chemistry.IgnitionBatch` and the `*_batch` solves): the
batch's concentrations against Cantera's, its values against single solves of the same reactors,
its gradients against central bumps of its own forward solve and, vmapped, against one reactor at a
time (reactors that finish early used to get NaN), bad input refused before anything
compiles, and `snapo bench kinetics --batch` writing its fields."""

import json
from pathlib import Path

import cantera
import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
import pytest

import chemistry.kinetics._batch as batch_module
from chemistry import (
    ONE_ATM,
    REACTOR_SOLVER,
    IgnitionBatch,
    Mechanism,
    final_temperature_batch,
    solve_ignition_batch,
    temperature_at,
    temperature_sensitivities_batch,
)
from chemistry.kinetics._bench import cantera_seconds
from chemistry.kinetics._ignition import IGNITION_CASES, trajectory_and_delay
from chemistry.kinetics._reactor import Reactor, simulate
from chemistry.kinetics._sensitivities import with_multipliers
from snapo_ode import InputError, Rodas5, SolverFailed
from snapo_ode.cli import main

H2O2 = Path(cantera.__file__).parent / "data" / "h2o2.yaml"
# Rodas5 with its stages in a loop (the reactors' method; its gradient compiles in about half the time).
SETTINGS = REACTOR_SOLVER.replace(solver=Rodas5(), rtol=1e-10, atol=1e-14)
TIME = 2.7e-4  # late in the induction of the 1000 K reactor, as the single tests
COMPOSITIONS = ["H2:2,O2:1,N2:3.76", "H2:1, O2:1, N2:3.76", {"H2": 2.0, "O2": 1.0, "AR": 4.0}, "H2:2,O2:1,N2:3.76"]


@pytest.fixture(scope="module")
def mechanism():
    return Mechanism.from_yaml(H2O2)


@pytest.fixture(scope="module")
def batch(mechanism):
    """Four reactors, each with its own T0, P0, composition and (for two) rate multipliers,
    all still in their induction at `TIME`."""
    multipliers = np.zeros((4, mechanism.n_reactions))
    multipliers[1:3] = 0.05 * np.random.default_rng(0).standard_normal((2, mechanism.n_reactions))
    return IgnitionBatch(mechanism, [980.0, 975.0, 960.0, 1000.0], ONE_ATM * np.array([1.0, 0.6, 0.8, 1.0]),
                         COMPOSITIONS, multipliers)


def test_the_batch_concentrations_are_cantera_s(batch):
    solution = cantera.Solution(str(H2O2))
    for i, composition in enumerate(COMPOSITIONS):
        solution.TPX = float(batch.temperature[i]), float(batch.pressure[i]), composition
        np.testing.assert_allclose(batch.concentrations[i], solution.concentrations, rtol=1e-14, atol=0)


def test_sorting_a_batch_moves_every_field_of_a_reactor_together(batch):
    ordered, order = batch.sorted_by(batch.temperature)
    assert list(order) == [2, 1, 0, 3]
    for field in ("temperature", "pressure", "mole_fractions", "log_multiplier"):
        np.testing.assert_array_equal(getattr(ordered, field), np.asarray(getattr(batch, field))[order])


def test_batched_temperatures_equal_single_solves(mechanism, batch):
    batched = np.asarray(final_temperature_batch(mechanism, batch, TIME, settings=SETTINGS))
    single = eqx.filter_jit(temperature_at)
    for i in range(batch.size):
        alone = float(single(batch.log_multiplier[i], mechanism, batch.temperature[i], batch.concentrations[i],
                             TIME, SETTINGS))
        assert abs(batched[i] / alone - 1) < 1e-10, (i, batched[i], alone)
    assert batched[0] < batched[-1] < 1100.0  # hotter starts are further on, none has ignited


def test_batched_ignitions_in_groups_equal_single_solves(mechanism, batch):
    times = np.linspace(0.0, 1.5e-3, 7)  # delays 0.3-0.6 ms (Cantera)
    result = solve_ignition_batch(mechanism, batch, times, group_size=3)  # a group of 3, then one of 1
    reactor = Reactor(mechanism, "constant-volume", ("energy",))
    single = eqx.filter_jit(lambda m, t, c: trajectory_and_delay(reactor, t, c, jnp.asarray(times), REACTOR_SOLVER,
                                                                 400.0, with_multipliers(mechanism, m)))
    for i in range(batch.size):
        trajectory, delay = single(batch.log_multiplier[i], batch.temperature[i], batch.concentrations[i])
        assert abs(result.delay[i] / float(delay) - 1) < 1e-10
        np.testing.assert_allclose(result.temperature[i], trajectory.temperature, rtol=1e-10, atol=0)
        assert result.steps[i] == int(trajectory.solution.stats["num_accepted_steps"])
    assert np.all(result.delay < times[-1]) and np.all(result.temperature[:, -1] > 2000.0)


def test_a_reactor_that_does_not_ignite_in_time_fails_the_batch_with_advice(mechanism, batch):
    early = np.linspace(0.0, 4.5e-4, 7)  # the slowest delay is ~0.6 ms, the fastest ~0.3 ms
    with pytest.raises(SolverFailed, match=r"never reached T0 \+ 400 K before the last saved time \(0.00045 s\)"):
        solve_ignition_batch(mechanism, batch, early, group_size=3)


def test_batched_gradients_match_central_bumps_of_the_batch(mechanism, batch):
    sensitivities, temperature = temperature_sensitivities_batch(mechanism, batch, TIME, settings=SETTINGS)
    sensitivities, temperature = np.asarray(sensitivities), np.asarray(temperature)
    assert sensitivities.shape == (batch.size, mechanism.n_reactions)
    step = 1e-5
    for rank in (0, 3):  # the largest and the fourth largest of reactors 1 and 3, bumped in one batch of 4
        rows, bumped = [], []
        for reactor in (1, 3):
            reaction = np.argsort(-np.abs(sensitivities[reactor]))[rank]
            rows.append((reactor, reaction))
            for sign in (1.0, -1.0):
                bumped.append(np.asarray(batch.log_multiplier[reactor]).copy())
                bumped[-1][reaction] += sign * step
        temperature0, pressure, fractions = (np.repeat(np.asarray(field)[[1, 3]], 2, axis=0) for field in
                                             (batch.temperature, batch.pressure, batch.mole_fractions))
        bumps = IgnitionBatch(mechanism, temperature0, pressure, fractions, np.stack(bumped))
        values = np.asarray(final_temperature_batch(mechanism, bumps, TIME, settings=SETTINGS))
        for k, (reactor, reaction) in enumerate(rows):
            central = (values[2 * k] - values[2 * k + 1]) / (2 * step) / temperature[reactor]
            ours = sensitivities[reactor, reaction]
            assert abs(central - ours) < 1e-5 * max(abs(ours), 1e-3), (reactor, reaction, central, ours)
    assert np.max(np.abs(sensitivities)) > 0.1  # late in the induction: sensitivities are large


@pytest.mark.slow  # ~2.5 minutes; the batch's gradients are checked against bumps above
def test_vmapped_gradients_equal_one_reactor_at_a_time(mechanism):
    """Reactors that finish in fewer steps than the slowest go on through the vmapped loop's
    discarded steps (h = 0): their gradients must be those of a reactor solved alone (they were
    NaN before the Rosenbrock step guarded h = 0). Hotter reactors ignite inside the window and
    take the most steps."""
    spread = IgnitionBatch(mechanism, [950.0, 1000.0, 1050.0, 1100.0], ONE_ATM, COMPOSITIONS[0])
    reactor = Reactor(mechanism, "constant-volume", ("energy",))
    steps = {int(simulate(reactor, temperature, concentrations, jnp.array([0.0, TIME]), settings=SETTINGS)
                 .solution.stats["num_steps"])
             for temperature, concentrations in zip(spread.temperature, spread.concentrations, strict=True)}
    assert len(steps) == 4  # every reactor finishes at a step of its own
    vmapped, values = map(np.asarray, temperature_sensitivities_batch(mechanism, spread, TIME, settings=SETTINGS))
    alone, alone_values = map(np.asarray, temperature_sensitivities_batch(mechanism, spread, TIME, settings=SETTINGS,
                                                                          group_size=1))
    assert np.all(np.isfinite(vmapped))
    np.testing.assert_allclose(values, alone_values, rtol=1e-12, atol=0)
    normwise = np.max(np.abs(vmapped - alone), axis=1) / np.max(np.abs(alone), axis=1)
    assert np.all(normwise < 1e-6), normwise  # round-off through an ignition (measured 2.5e-8)


def _refuses(monkeypatch, match, call):
    def no_compile(*args, **kwargs):
        raise AssertionError("nothing may be compiled before the batch is checked")

    for name in ("temperature_program", "ignition_program"):
        monkeypatch.setattr(batch_module, name, no_compile)
    with pytest.raises(InputError, match=match):
        call()


@pytest.mark.parametrize("fields, match", [
    (dict(temperature=[900.0, 1000.0], pressure=[1e5, 1e5, 1e5]), r"disagree.*temperature 2, pressure 3"),
    (dict(temperature=[1000.0, -5.0]), r"temperature\[1\] = -5.0 is outside the allowed range \(0, inf\]"),
    (dict(pressure=0.0), r"pressure = 0.0 is outside the allowed range \(0, inf\]"),
    (dict(composition="H2:2,XX:1"), r"species 'XX' is not in the mechanism"),
    (dict(composition="H2=2"), r"composition = 'H2=2' is not of the form"),
    (dict(composition=np.zeros(10)), r"composition sums to 0"),
    (dict(composition=np.ones((2, 11))), r"composition has shape \(2, 11\); expected \(10,\).*\(N, 10\)"),
    (dict(log_multiplier=np.zeros(28)), r"log_multiplier has shape \(28,\); expected \(29,\)"),
])
def test_bad_batch_input_is_refused_naming_the_field(monkeypatch, mechanism, fields, match):
    arguments = dict(temperature=1000.0, pressure=ONE_ATM, composition="H2:2,O2:1,N2:3.76") | fields
    _refuses(monkeypatch, match, lambda: IgnitionBatch(mechanism, **arguments))


def test_bad_solve_arguments_are_refused_before_compiling(monkeypatch, mechanism, batch):
    _refuses(monkeypatch, r"time = 0.0 is outside the allowed range \(0, inf\]",
             lambda: final_temperature_batch(mechanism, batch, 0.0))
    _refuses(monkeypatch, r"group_size = 0", lambda: final_temperature_batch(mechanism, batch, TIME, group_size=0))
    _refuses(monkeypatch, r"times", lambda: solve_ignition_batch(mechanism, batch, [0.0, 2e-3, 1e-3]))
    other = Mechanism.from_yaml(Path(cantera.__file__).parent / "data" / "gri30.yaml")
    _refuses(monkeypatch, r"the batch has 10 species", lambda: final_temperature_batch(other, batch, TIME))


# ~5 minutes (every program of the single and the batched bench): `make test-slow`. The batch's
# solves, gradients and bumps are checked above; the bench's own end-to-end run and its fields
# only here.
@pytest.mark.slow
def test_bench_kinetics_with_a_batch_writes_per_reactor_fields(tmp_path):
    assert main(["bench", "kinetics", "--out", str(tmp_path), "--mechanisms", "h2o2", "--repeats", "1",
                 "--batch", "3", "--batch-scaling", "1", "2"]) == 0
    (row,) = json.loads((tmp_path / "bench_kinetics.json").read_text())["rows"]
    assert row["mechanism"] == "h2o2" and row["parameters"] == 29 and row["batch"] == 3
    # The single bench's row stays. Equal tolerances, not equal errors: Cantera's atol 1e-14 is on
    # mass fractions (ours on amounts over the initial total): its T here is 2.7e-6 off its
    # converged value (rtol 1e-12, atol 1e-20: 1008.03118 K), ours 1.5e-7.
    assert abs(row["final_temperature_K"] / row["cantera_final_temperature_K"] - 1) < 1e-5
    assert all(row[key] > 0 for key in ("forward_s", "gradient_s", "cantera_forward_s", "cantera_sensitivities_s",
                                        "forward_bdf_s"))
    assert row["gradient_forward_ratio"] == pytest.approx(row["gradient_s"] / row["forward_s"])
    # The converged reference (our Rodas5 at rtol 1e-13) against Cantera's at rtol 1e-12 / atol 1e-20,
    # and each solver's error against it: the BDF within its tolerances' reach (atol-dominated).
    _, cantera_converged = cantera_seconds(Path(cantera.__file__).parent / "data" / "h2o2.yaml", IGNITION_CASES["h2o2"],
                                           row["end_time_s"], False, 1, rtol=1e-12, atol=1e-20)
    assert abs(row["reference_final_temperature_K"] / cantera_converged - 1) < 1e-9
    assert row["rodas5_temperature_rel_error"] < 1e-7 and row["bdf_temperature_rel_error"] < 2e-6
    assert row["cantera_temperature_rel_error"] == pytest.approx(
        abs(row["cantera_final_temperature_K"] / row["reference_final_temperature_K"] - 1))
    assert row["forward_bdf_slowdown_vs_cantera"] == pytest.approx(row["forward_bdf_s"] / row["cantera_forward_s"])
    assert (tmp_path / "bench_kinetics.csv").read_text().count("\n") == 2
    assert row["batch_max_relative_difference_vs_cantera"] < 1e-5  # equal tolerances, not equal errors
    assert row["batch_max_relative_difference_vs_single"] < 1e-10 and row["batch_single_reactors"] == 3
    assert row["batch_gradient_max_relative_difference_vs_bumps"] < 1e-5 and row["batch_gradient_bump_checks"] == 3
    assert row["device"].startswith(jax.default_backend())
    for key in ("batch_forward_s_per_reactor", "batch_gradient_s_per_reactor", "cantera_serial_s_per_reactor"):
        assert row[key] > 0
    assert row["batch_forward_speedup_vs_cantera_serial"] == pytest.approx(
        row["cantera_serial_s_per_reactor"] / row["batch_forward_s_per_reactor"])
    assert "batch_gradient_compile_s" in (tmp_path / "bench_kinetics.csv").read_text().splitlines()[0]
    scaling = json.loads((tmp_path / "bench_kinetics_scaling.json").read_text())["rows"]
    assert [r["batch"] for r in scaling] == [1, 2] and all(r["device"] == row["device"] for r in scaling)
    for r in scaling:
        assert r["batch_forward_speedup_vs_cantera_serial"] == pytest.approx(
            r["cantera_serial_s_per_reactor"] / r["batch_forward_s_per_reactor"])
        assert r["batch_max_relative_difference_vs_cantera"] < 1e-5
    assert main(["bench", "kinetics", "--out", str(tmp_path), "--batch", "0"]) == 2
    assert main(["bench", "kinetics", "--out", str(tmp_path), "--batch-scaling", "4", "0"]) == 2


def test_the_batch_bench_refuses_to_time_non_finite_results():
    # Half of a gri30 sample's gradients were once NaN, and the bench timed them as results.
    from chemistry.kinetics._batch_bench import _compiled_and_timed

    with pytest.raises(SolverFailed, match="the batch bench's program gave non-finite values"):
        _compiled_and_timed(eqx.filter_jit(lambda x: jnp.log(x - 1.0)), (jnp.zeros(2),), 1)
    _, seconds, out = _compiled_and_timed(eqx.filter_jit(lambda x: jnp.log(x + 1.0)), (jnp.zeros(2),), 2)
    assert seconds > 0 and np.all(np.asarray(out) == 0.0)
