"""Exported programs (`snapo_ode.exported`): a second process loads the traced program from disk
and neither traces it nor compiles it (also when it was prefetched: read once, in the
background); its results are bit-identical to the first process's and
match the plain jitted function; a changed setting or shape makes a new entry; a corrupt entry is
rebuilt with a warning; a failed solve still raises `SolverFailed` through the deserialised
program (its checks are NaN marks under `call_checked`, not host callbacks).

Traces are counted by a Python side effect inside the exported function, compiles as JAX's
backend-compile events less its persistent-cache hits (as in test_core_cache.py). The program is
an explicit solve (Tsit5: it compiles in 60% of an implicit one's time); exported programs with
implicit solves (Rodas5's linear solves) run in `snapo pharma sensitivities` (test_pharma_cli.py)."""

import functools
import json
import os
import shutil
import subprocess
import sys
import warnings

import equinox as eqx
import jax
import jax.numpy as jnp
import pytest

import snapo_ode
from snapo_ode._runtime.export_keys import EXPORTED_DIRECTORY

SCRIPT = """
import json, sys, warnings
import diffrax, equinox as eqx, jax, jax.numpy as jnp, numpy as np
from jax._src.dispatch import BACKEND_COMPILE_EVENT
import snapo_ode
from snapo_ode._runtime.export_keys import EXPORTED_DIRECTORY

snapo_ode.configure()
compiles, hits, traces = [], [], []
jax.monitoring.register_event_duration_secs_listener(
    lambda event, duration, **kw: compiles.append(event) if event == BACKEND_COMPILE_EVENT else None)
jax.monitoring.register_event_listener(lambda event, **kw: hits.append(event) if event.endswith("cache_hits") else None)


class Decay(eqx.Module):
    rates: jax.Array
    max_steps: int = eqx.field(static=True)


def value_and_gradient(model, y0):
    traces.append(1)  # runs only when the function is traced

    def final(rates):
        solution = snapo_ode.diffeqsolve_checked(
            diffrax.ODETerm(lambda t, y, k: -k * y), diffrax.Tsit5(), 0.0, 1.0, None, y0, rates,
            stepsize_controller=diffrax.PIDController(rtol=1e-8, atol=1e-10), max_steps=model.max_steps)
        return jnp.sum(solution.ys[-1] ** 2)

    return jax.value_and_grad(final)(model.rates)


program = snapo_ode.exported(value_and_gradient, name="test-decay")
max_steps, n = int(sys.argv[1]), int(sys.argv[2])
model = Decay(jnp.linspace(1.0, 1e3, n), max_steps)
with warnings.catch_warnings(record=True) as caught:
    warnings.simplefilter("always")
    try:
        y0 = jax.device_put(jnp.ones(n), jax.devices()[0])  # committed, as a model's arrays often are
        prefetched = sys.argv[3] == "prefetch" and snapo_ode.prefetch_checked(program, model, y0)
        value, gradient = snapo_ode.call_checked(program, model, y0)
        result = {"value": float(value), "gradient": np.asarray(gradient).tolist(), "traces": len(traces),
                  "compiles": len(compiles) - len(hits), "reads": len(hits), "prefetched": prefetched}
        if sys.argv[3] == "plain":
            plain = jax.jit(value_and_gradient)(model, jnp.ones(n))
            result["plain"] = [float(plain[0]), np.asarray(plain[1]).tolist()]
    except snapo_ode.SolverFailed as error:
        result = {"failed": str(error), "traces": len(traces)}
result["warnings"] = [str(w.message) for w in caught if "snapo" in str(w.message)]
print(json.dumps(result))
"""


def run(cache_dir, max_steps=4096, n=2, plain=False, prefetch=False):
    """The script in a fresh process with `cache_dir` as its cache (with `plain`, also the plain
    jitted function; with `prefetch`, the program prefetched before its call); its JSON line."""
    env = dict(os.environ, SNAPO_CACHE_DIR=str(cache_dir))
    how = "plain" if plain else "prefetch" if prefetch else "-"
    out = subprocess.run([sys.executable, "-c", SCRIPT, str(max_steps), str(n), how], env=env,
                         capture_output=True, text=True, check=True)
    return json.loads(out.stdout.strip().splitlines()[-1])


def entries(cache_dir):
    return sorted((cache_dir / EXPORTED_DIRECTORY).glob("test-decay-*"))


@pytest.fixture(scope="module")
def exported_once(tmp_path_factory):
    """A cache directory in which one process exported the program (max_steps 4096, n = 2), and
    that process's result."""
    cache_dir = tmp_path_factory.mktemp("exported")
    return cache_dir, run(cache_dir, plain=True)


@pytest.fixture
def cache(exported_once, tmp_path):
    """A copy of `exported_once`'s cache directory, for a test to change (the copy's exported
    entries load; its XLA executables do not: JAX's cache keys depend on the directory)."""
    shutil.copytree(exported_once[0], tmp_path, dirs_exist_ok=True)
    return tmp_path


def test_second_process_loads_without_tracing_and_gives_the_same_results(exported_once):
    cache, first = exported_once
    assert first["traces"] == 1 and len(entries(cache)) == 1
    assert first["value"] == pytest.approx(first["plain"][0], rel=1e-12, abs=0)
    assert first["gradient"] == pytest.approx(first["plain"][1], rel=1e-12, abs=1e-300)
    second = run(cache)
    assert first["compiles"] >= 1
    assert second["traces"] == 0 and second["compiles"] == 0
    assert (second["value"], second["gradient"]) == (first["value"], first["gradient"])  # bit for bit
    assert second["warnings"] == []


def test_a_prefetched_program_is_read_once_and_gives_the_same_results(exported_once, tmp_path):
    cache, first = exported_once
    plain, prefetched = run(cache), run(cache, prefetch=True)
    assert prefetched["prefetched"] and prefetched["traces"] == 0 and prefetched["compiles"] == 0
    # The executable read in the background is the one the call runs: not read a second time.
    assert prefetched["reads"] == plain["reads"]
    assert (prefetched["value"], prefetched["gradient"]) == (first["value"], first["gradient"])
    cold = run(tmp_path, prefetch=True)  # nothing on disk yet: nothing to prefetch, traced as ever
    assert not cold["prefetched"] and cold["traces"] == 1 and cold["value"] == first["value"]


def test_a_changed_setting_or_shape_makes_a_new_entry(cache):
    assert run(cache, max_steps=2048, n=2)["traces"] == 1  # a static field
    assert run(cache, max_steps=4096, n=3)["traces"] == 1  # an array's shape
    assert len(entries(cache)) == 3
    assert run(cache, max_steps=2048, n=2)["traces"] == 0


def test_a_corrupt_entry_is_rebuilt_with_a_warning(exported_once, cache):
    first = exported_once[1]
    [entry] = entries(cache)
    data = entry.read_bytes()
    for damaged in (b"not a program", data[:len(data) // 2], data[:-10] + bytes(b ^ 0xFF for b in data[-10:])):
        entry.write_bytes(damaged)
        rebuilt = run(cache)
        assert rebuilt["traces"] == 1
        assert any("unreadable" in warning for warning in rebuilt["warnings"])
        assert (rebuilt["value"], rebuilt["gradient"]) == (first["value"], first["gradient"])
    assert run(cache)["traces"] == 0  # the rebuilt entry is whole again


def test_a_failed_solve_still_raises_through_the_deserialised_program(tmp_path):
    first = run(tmp_path, max_steps=3)
    assert "non-finite values: an ODE solve failed" in first["failed"] and first["traces"] == 1
    second = run(tmp_path, max_steps=3)
    assert second["traces"] == 0
    assert "non-finite values: an ODE solve failed" in second["failed"]


def test_keys_describe_structure_and_refuse_what_differs_between_processes():
    class Model(eqx.Module):
        rates: jnp.ndarray
        name: str = eqx.field(static=True)

    model = Model(jnp.ones(3), "a")
    described = snapo_ode.describe(model)
    assert snapo_ode.describe(Model(jnp.zeros(3), "a")) == described  # arguments: shapes, not values
    assert snapo_ode.describe(Model(jnp.zeros(3), "a"), values=True) != snapo_ode.describe(model, values=True)
    assert snapo_ode.describe(Model(jnp.ones(3), "b")) != described
    assert snapo_ode.describe(Model(jnp.ones(4), "a")) != described
    with pytest.raises(snapo_ode.Unkeyable):
        snapo_ode.describe(lambda x: x)
    scale = 2.0
    with pytest.raises(snapo_ode.Unkeyable):
        snapo_ode.describe(lambda x: scale * x)
    with pytest.raises(snapo_ode.Unkeyable):
        snapo_ode.describe(object())


def _wrapping(fn):
    @functools.wraps(fn)
    def wrapped(*args):
        return fn(*args)

    return wrapped


@_wrapping
def _decorated(x):
    return x


def test_a_decorated_module_level_function_is_keyed_by_its_name_and_another_closure_is_not():
    # What the module holds under the name is the same object in every process (optimistix's
    # `max_norm`, in Kvaerno5's root finder, is such a function); a wrapper made elsewhere is not.
    assert snapo_ode.describe(_decorated) == ["function", f"{__name__}._decorated"]
    with pytest.raises(snapo_ode.Unkeyable):
        snapo_ode.describe(_wrapping(_double))


def _double(x):
    return (2 * x,)


def _apply(fn, x):
    return (fn(x),)


def test_an_argument_that_cannot_be_keyed_warns_outside_a_jit_and_not_inside():
    program = snapo_ode.exported(_apply, name="test-apply")
    with pytest.warns(UserWarning, match="test-apply cannot be kept on disk .*traced in every process"):
        (value,) = program(lambda x: 3 * x, jnp.ones(2))
    assert value.tolist() == [3.0, 3.0]
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        (inside,) = jax.jit(lambda x: program(lambda y: 3 * y, x))(jnp.ones(2))
    assert inside.tolist() == [3.0, 3.0] and not [w for w in caught if "cannot be kept" in str(w.message)]


def test_new_arrays_of_the_same_shapes_reuse_the_entry_without_describing_it_again(monkeypatch):
    import snapo_ode._runtime.exported as module

    described = []
    describe = module.describe
    monkeypatch.setattr(module, "describe", lambda tree, **kw: described.append(1) or describe(tree, **kw))
    monkeypatch.setattr(module, "entry_path", lambda name, key: json.dumps(key, sort_keys=True))
    program = snapo_ode.exported(_double, name="test-double")
    first = program._flat((jnp.ones(3),))[0]
    assert described and program._flat((jnp.zeros(3),))[0] == first  # a design space's next point
    count = len(described)
    assert program._flat((jnp.zeros(3),))[0] == first and len(described) == count  # not described again
    assert program._flat((jnp.zeros(4),))[0] != first  # another shape
    assert program._flat((jnp.zeros(3, dtype=jnp.int32),))[0] != first  # another dtype
    assert len(described) > count


HELPER_MODULE = """
import diffrax, equinox as eqx, jax, jax.numpy as jnp
import snapo_ode

traces = []


class Decay(eqx.Module):
    rates: jax.Array


def value_and_gradient(model, y0):
    traces.append(1)  # runs only where the function is traced

    def final(rates):
        solution = snapo_ode.diffeqsolve_checked(
            diffrax.ODETerm(lambda t, y, k: -k * y), diffrax.Tsit5(), 0.0, 1.0, None, y0, rates,
            stepsize_controller=diffrax.PIDController(rtol=1e-8, atol=1e-10), max_steps=4096)
        return jnp.sum(solution.ys[-1] ** 2)

    return jax.value_and_grad(final)(model.rates)


program = snapo_ode.exported(value_and_gradient, name="test-helper-decay")
"""

HELPER_SCRIPT = """
import json, sys, warnings
import jax, jax.numpy as jnp, numpy as np
import snapo_ode

import logging
snapo_ode.configure()
messages = []  # JAX logs each persistent-cache hit with the program's name: an exported one is jit(call)
handler = logging.Handler(logging.DEBUG)
handler.emit = lambda record: messages.append(record.getMessage())
logging.getLogger("jax._src.compiler").setLevel(logging.DEBUG)
logging.getLogger("jax._src.compiler").addHandler(handler)
sys.path.insert(0, sys.argv[1])  # the caller's path only: a helper finds the module only on PYTHONPATH
import helper_decay as m

model, y0 = m.Decay(jnp.linspace(1.0, 1e3, 3)), jnp.ones(3)
program = m.program if sys.argv[2] == "module" else snapo_ode.exported(m.value_and_gradient, name="test-local")
with warnings.catch_warnings(record=True) as caught:
    warnings.simplefilter("always")
    on_disk = snapo_ode.prefetch_checked(program, model, y0, elsewhere=True)
    value, gradient = snapo_ode.call_checked(program, model, y0)
plain = jax.jit(m.value_and_gradient)(model, y0)
print(json.dumps({"traces_here": len(m.traces) - 1, "on_disk": on_disk, "cache_reads": sum("cache hit for 'jit_call'" in m for m in messages), "value": float(value),
                  "gradient": np.asarray(gradient).tolist(), "plain": [float(plain[0]), np.asarray(plain[1]).tolist()],
                  "warnings": [str(w.message) for w in caught if "snapo" in str(w.message)]}))
"""


def run_elsewhere(cache_dir, module_dir, *, which="module", helper_can_import=True):
    """HELPER_SCRIPT in a fresh process (its program prefetched `elsewhere`): its JSON line.
    `traces_here` counts the caller's traces of the program (the plain jit's own trace excluded)."""
    env = dict(os.environ, SNAPO_CACHE_DIR=str(cache_dir))
    if helper_can_import:
        env["PYTHONPATH"] = os.pathsep.join(filter(None, [str(module_dir), os.environ.get("PYTHONPATH")]))
    out = subprocess.run([sys.executable, "-c", HELPER_SCRIPT, str(module_dir), which], env=env,
                         capture_output=True, text=True, check=True)
    return json.loads(out.stdout.strip().splitlines()[-1])


def test_a_program_prefetched_elsewhere_is_traced_by_a_helper_process_and_gives_the_same_results(tmp_path):
    (tmp_path / "module").mkdir()
    (tmp_path / "module" / "helper_decay.py").write_text(HELPER_MODULE)
    first = run_elsewhere(tmp_path / "cache", tmp_path / "module")
    # Traced, written and compiled by the helper: the caller read the entry, and its executable
    # from the compilation cache (a fresh one: nothing else could be read there), and ran it.
    assert first["traces_here"] == 0 and not first["on_disk"] and first["warnings"] == []
    assert first["cache_reads"] == 1
    assert len(list((tmp_path / "cache" / EXPORTED_DIRECTORY).glob("test-helper-decay-*"))) == 1
    assert first["value"] == pytest.approx(first["plain"][0], rel=1e-12, abs=0)
    assert first["gradient"] == pytest.approx(first["plain"][1], rel=1e-12, abs=1e-300)
    second = run_elsewhere(tmp_path / "cache", tmp_path / "module")
    assert second["on_disk"] and second["traces_here"] == 0
    assert (second["value"], second["gradient"]) == (first["value"], first["gradient"])
    # A program no helper can import (made inside a function) is traced by the caller, silently.
    local = run_elsewhere(tmp_path / "cache-local", tmp_path / "module", which="local")
    assert local["traces_here"] == 1 and local["warnings"] == [] and local["value"] == first["value"]
    assert local["cache_reads"] == 0


def test_a_failed_helper_process_leaves_the_trace_to_the_call_with_a_warning(tmp_path):
    (tmp_path / "module").mkdir()
    (tmp_path / "module" / "helper_decay.py").write_text(HELPER_MODULE)
    failed = run_elsewhere(tmp_path / "cache", tmp_path / "module", helper_can_import=False)
    assert failed["traces_here"] == 1
    assert any("helper process" in warning and "traced by the call" in warning for warning in failed["warnings"])
    assert failed["value"] == pytest.approx(failed["plain"][0], rel=1e-12, abs=0)
