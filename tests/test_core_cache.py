"""The persistent compilation cache: a second process compiles nothing it compiled before."""

import os
import subprocess
import sys

SCRIPT = """
import jax, jax.numpy as jnp
misses = []
jax.monitoring.register_event_listener(
    lambda event, **kw: misses.append(event) if event.endswith("cache_misses") else None)
import snapo_ode
print(snapo_ode.CACHE_DIR)
f = jax.jit(lambda x: jnp.sin(x) @ jnp.cos(x).T + 1.2345)
f(jnp.ones((3, 3))).block_until_ready()
jax.jit(jax.grad(lambda x: jnp.sum(jnp.tanh(x) ** 3)))(jnp.ones(4)).block_until_ready()
print("misses", len(misses))
"""


def run(cache_dir):
    env = dict(os.environ, SNAPO_CACHE_DIR=str(cache_dir))
    out = subprocess.run([sys.executable, "-c", SCRIPT], env=env, capture_output=True, text=True, check=True)
    lines = out.stdout.split("\n")
    return lines[0], int(lines[1].split()[1])


def test_second_process_hits_the_cache(tmp_path):
    first_dir, first_misses = run(tmp_path / "cache")
    second_dir, second_misses = run(tmp_path / "cache")
    assert first_dir == second_dir == str(tmp_path / "cache")
    assert first_misses >= 2
    assert second_misses == 0
