"""A process that compiles many programs stays below the kernel's limit on memory mappings."""

import jax
import jax.numpy as jnp
import pytest

import snapo_ode


def test_compiled_programs_are_dropped_near_the_mapping_limit():
    """`relieve_mappings` drops JAX's compiled programs once the process holds more than the
    given share of `vm.max_map_count` (each compiled CPU program stays mapped until then), and
    leaves them below it."""
    counts = snapo_ode.memory_mappings()
    if counts is None:
        pytest.skip("no /proc: the limit is not known here")
    assert 0 < counts[0] < counts[1]
    program = jax.jit(lambda x: jnp.sin(x) * 2.0)
    program(jnp.ones(3))
    assert program._cache_size() == 1
    assert snapo_ode.relieve_mappings(fraction=1.0) is False and program._cache_size() == 1
    assert snapo_ode.relieve_mappings(fraction=0.0) is True and program._cache_size() == 0


def test_the_hot_path_check_reads_the_mappings_only_after_a_compile(monkeypatch):
    """`relieve_mappings_after_compiles` (called by `call_checked` and `time_function`) reads
    /proc/self/maps once after each XLA compile, not on every call."""
    from snapo_ode._platform import resources

    reads = []
    monkeypatch.setattr(resources, "relieve_mappings", lambda: reads.append(1) or False)
    resources.relieve_mappings_after_compiles()
    reads.clear()
    assert resources.relieve_mappings_after_compiles() is False and reads == []
    jax.jit(lambda x: jnp.cos(x) * 3.0 + 1.0)(jnp.ones(5))  # a new program: one compile
    resources.relieve_mappings_after_compiles()
    assert reads == [1]
    resources.relieve_mappings_after_compiles()
    assert reads == [1]
