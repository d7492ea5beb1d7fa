"""Configuration: importing snapo_ode changes no JAX state and imports no JAX; `configure()`
switches on float64 and the persistent compilation cache; entry points refuse float32.

The persistent compilation cache: a second process compiles nothing it compiled before,
including a checked stiff ODE solve and its derivative through the implicit solver, whose
failure checks (ours, and lineax's in optimistix's implicit-function rule) `call_checked` traces
as NaN marks rather than host callbacks.

Compiles are counted as JAX's backend-compile events (one per program, compiled or loaded) less
its cache hits, not as cache misses: a program that holds a host callback (e.g.
`equinox.error_if`) is neither looked up nor stored, so it raises no miss event and yet is
compiled again in every process."""

import os
import subprocess
import sys

SCRIPT = """
import jax, jax.numpy as jnp, diffrax
from jax._src.dispatch import BACKEND_COMPILE_EVENT
programs, hits = [], []
jax.monitoring.register_event_duration_secs_listener(
    lambda event, duration, **kw: programs.append(event) if event == BACKEND_COMPILE_EVENT else None)
jax.monitoring.register_event_listener(
    lambda event, **kw: hits.append(event) if event.endswith("cache_hits") else None)
import snapo_ode
print(snapo_ode.configure())
f = jax.jit(lambda x: jnp.sin(x) @ jnp.cos(x).T + 1.2345)
f(jnp.ones((3, 3))).block_until_ready()
jax.jit(jax.grad(lambda x: jnp.sum(jnp.tanh(x) ** 3)))(jnp.ones(4)).block_until_ready()

def decay(k):
    return snapo_ode.diffeqsolve_checked(
        diffrax.ODETerm(lambda t, y, k: -k * y), diffrax.Kvaerno3(), 0.0, 1.0, None, jnp.ones(2), k,
        stepsize_controller=diffrax.PIDController(rtol=1e-6, atol=1e-9)).ys[-1].sum()

snapo_ode.call_checked(jax.jit(decay), jnp.array([1.0, 1e4]))
snapo_ode.call_checked(jax.jit(jax.grad(decay)), jnp.array([1.0, 1e4]))
print("compiles", len(programs) - len(hits))
"""


def run(cache_dir):
    env = dict(os.environ, SNAPO_CACHE_DIR=str(cache_dir))
    out = subprocess.run([sys.executable, "-c", SCRIPT], env=env, capture_output=True, text=True, check=True)
    lines = out.stdout.split("\n")
    return lines[0], int(lines[1].split()[1])


def test_second_process_compiles_nothing(tmp_path):
    first_dir, first_compiles = run(tmp_path / "cache")
    second_dir, second_compiles = run(tmp_path / "cache")
    assert first_dir == second_dir == str(tmp_path / "cache")
    assert first_compiles >= 3
    assert second_compiles == 0


def test_import_changes_no_global_state_and_entry_points_refuse_float32():
    script = """
import sys
import snapo_ode, finance.gas_storage, chemistry.pharma, snapo_ode.cli
assert "jax" not in sys.modules, "importing the packages imported JAX"
import jax
assert not jax.config.jax_enable_x64
from finance import gas_storage as gs
try:
    gs.make_inputs(gs.sample_facility(), gs.sample_curve())
except snapo_ode.ConfigurationError as error:
    print(error)
"""
    out = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, check=True)
    assert "need float64, which is off: call snapo_ode.configure()" in out.stdout
