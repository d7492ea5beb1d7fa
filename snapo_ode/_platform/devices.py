"""Scale out on JAX's own distributed engine: independent samples (Monte Carlo paths, design-space
points, uncertainty draws, reactor conditions) split over a one-axis device mesh, across processes
when `jax.distributed` is initialised.

- `use_cpu_devices(n)` splits the host CPU into `n` XLA devices (before JAX starts its backends);
  on a GPU machine the devices are the GPUs.
- `initialize(...)` starts `jax.distributed` (a coordinator `HOST:PORT`, the process count and
  this process's id, or auto-detection on SLURM); CPU processes then talk through gloo
  collectives. `start(devices, ...)` does both, as the CLI's `--devices` and
  `--coordinator/--num-processes/--process-id` ask.
- `sample_mesh(devices)` is the mesh `Mesh(devices, ("samples",))` over the first `devices` of
  every process's devices.
- `generate_sharded(fn, mesh, axis)` runs a generator of samples (random draws) so that each
  device computes only its own share: with JAX's partitionable threefry (on by default) the
  draws are the same numbers whatever the device count, so a sharded run sees the paths a
  single-device run sees.
- `sample_mean(fn, mesh, specs)` turns `fn`, the mean over its share of the samples, into the
  mean over all of them: one all-reduce (`pmean`) for the value, and, differentiated, one
  all-reduce of each replicated input's cotangent (JAX transposes the replicated input into a
  `psum`).
- `per_sample(fn, mesh, specs)` keeps a per-sample output sharded along the samples (funding
  ratios, probabilities): no collective at all.

Shares are equal: the sample count must be a multiple of the device count (`check_divisible`),
so the mean of the devices' means is the mean of the samples (to float64 round-off of the
summation order). Only process 0 writes outputs (`is_writer`).
"""

import os
from collections.abc import Callable

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
from jax.sharding import Mesh, NamedSharding, PartitionSpec

from .validation import InputError

SAMPLES = "samples"
"""The mesh's one axis: the independent samples."""
SLURM_VARIABLES = ("SLURM_JOB_ID", "SLURM_NTASKS")


def use_cpu_devices(n: int) -> None:
    """Make the host CPU `n` XLA devices (`jax_num_cpu_devices`); call before the first
    computation (JAX reads it when it starts the CPU backend). Each device then runs its share
    of the samples on its own thread.

    **Raises:** `InputError` for `n` < 1, or when the CPU backend already started with a
    different count."""
    if n < 1:
        raise InputError(f"devices = {n} is out of range; use at least 1.")
    try:
        jax.config.update("jax_num_cpu_devices", n)
    except RuntimeError as error:  # the backend is up: the count can no longer change
        if len(jax.devices("cpu")) != n:
            raise InputError(f"devices = {n}: JAX's CPU backend already started with "
                             f"{len(jax.devices('cpu'))} devices; set the count before the first "
                             "computation.") from error


def initialize(coordinator: str | None = None, num_processes: int | None = None,
               process_id: int | None = None) -> int:
    """Start `jax.distributed` for a multi-process run, before any computation; returns the
    number of processes (1: nothing started).

    With `coordinator` ("HOST:PORT"), `num_processes` and `process_id` all given, those; with
    none given, auto-detection when SLURM launched this process as one of several tasks
    (`SLURM_JOB_ID`, `SLURM_NTASKS` > 1; JAX reads the rest from SLURM); otherwise nothing. CPU
    processes talk through gloo collectives.

    **Raises:** `InputError` when only some of the three are given or they are out of range."""
    given = [coordinator is not None, num_processes is not None, process_id is not None]
    if any(given) and not all(given):
        raise InputError("--coordinator, --num-processes and --process-id go together: give all three "
                         f"(got coordinator={coordinator!r}, num_processes={num_processes}, process_id={process_id}).")
    if all(given):
        if num_processes < 1 or not 0 <= process_id < num_processes:
            raise InputError(f"process_id = {process_id} with num_processes = {num_processes}: need "
                             "num_processes >= 1 and 0 <= process_id < num_processes.")
        count = num_processes
    elif all(v in os.environ for v in SLURM_VARIABLES):
        count = int(os.environ["SLURM_NTASKS"])
    else:
        count = 1
    if count > 1:
        jax.config.update("jax_cpu_collectives_implementation", "gloo")
        jax.distributed.initialize(coordinator, num_processes, process_id)
    return count


def start(devices: int | None = None, coordinator: str | None = None, num_processes: int | None = None,
          process_id: int | None = None) -> None:
    """Before any computation: start the processes (`initialize`) and, when `devices` is given,
    split each host's CPU into its share of them (`devices` / processes; GPUs are what they are).

    **Raises:** `InputError` when `devices` is below 1 or does not split over the processes."""
    if devices is not None and devices < 1:
        raise InputError(f"devices = {devices} is out of range; use at least 1.")
    processes = initialize(coordinator, num_processes, process_id)
    if devices is not None:
        if devices % processes:
            raise InputError(f"devices = {devices} does not split over {processes} processes; use a multiple "
                             f"of {processes}.")
        use_cpu_devices(devices // processes)


def is_writer() -> bool:
    """Whether this process writes outputs: process 0 (the only one in a single-process run)."""
    return jax.process_index() == 0


def sample_mesh(devices: int | None = None) -> Mesh:
    """The one-axis mesh ("samples") over the first `devices` of all processes' devices
    (default: all of them; in a multi-process run the count must be the global one).

    **Raises:** `InputError` naming the available count when `devices` is out of range."""
    available = jax.devices()
    n = len(available) if devices is None else devices
    if not 1 <= n <= len(available):
        raise InputError(f"devices = {devices} is out of range: {len(available)} device(s) available "
                         f"({available[0].platform}); on CPU, `--devices N` splits the host into N.")
    return Mesh(available[:n], (SAMPLES,))


def check_divisible(what: str, count: int, mesh: Mesh) -> None:
    """Refuse `count` samples that do not split evenly over the mesh's devices.

    **Raises:** `InputError` naming the field and the nearest counts that do."""
    n = mesh.size
    if count % n:
        lower, upper = count - count % n, count - count % n + n
        raise InputError(f"{what} = {count} does not split over {n} devices; use a multiple of {n} "
                         f"(e.g. {lower or upper} or {upper}).")


def spec(*axes) -> PartitionSpec:
    """`PartitionSpec(*axes)`; write `SAMPLES` where the samples' axis is."""
    return PartitionSpec(*axes)


def generate_sharded(fn: Callable, mesh: Mesh, samples_axis: int, ndim: int) -> Callable:
    """`fn(*args)` (returning one array of `ndim` dimensions, its samples along `samples_axis`)
    compiled so that each device computes only its own share. With partitionable threefry the
    random numbers do not depend on the sharding: the same key gives the same samples on 1 or N
    devices and processes."""
    axes = [None] * ndim
    axes[samples_axis] = SAMPLES
    return jax.jit(fn, out_shardings=NamedSharding(mesh, PartitionSpec(*axes)))


def mesh_of(array) -> Mesh | None:
    """The samples mesh `array` is sharded over (None for an array on one device, or not split
    along "samples"): downstream computations follow the sharding of their samples."""
    sharding = getattr(array, "sharding", None)
    if isinstance(sharding, NamedSharding) and SAMPLES in sharding.mesh.axis_names:
        return sharding.mesh
    return None


def _over_shards(fn: Callable, mesh: Mesh, in_specs, out_specs) -> Callable:
    """`shard_map` of `fn` over the array leaves of its arguments (a model's static fields, such as
    its activation function, stay closed over)."""

    def mapped(*args):
        dynamic, static = eqx.partition(args, eqx.is_array)
        return jax.shard_map(lambda dynamic: fn(*eqx.combine(dynamic, static)), mesh=mesh,
                             in_specs=(tuple(in_specs),), out_specs=out_specs, check_vma=False)(dynamic)

    return mapped


def sample_mean(fn: Callable, mesh: Mesh | None, in_specs, *, chunk: int | None = None) -> Callable:
    """The mean over all samples from `fn(*args)`, the mean over its device's share. `in_specs`:
    one `PartitionSpec` per argument, `spec()` for a replicated one (parameters, market data),
    `SAMPLES` where its samples' axis is. Equal shares (see `check_divisible`) make the mean of
    the means exact. Differentiable: the gradient with respect to a replicated argument is one
    all-reduce of the devices' cotangents.

    `chunk`: samples per call of `fn` on a device, one chunk after another (`lax.map`), when it
    divides the device's share: a working set that stays in cache, faster on one device and more
    so on several (ALM's reverse pass: docs/architecture.md, Measurements behind the design).
    Without a mesh, `fn` itself, or chunked on the one device."""
    if chunk is not None:
        fn = _in_chunks(fn, in_specs, chunk)
    if mesh is None:
        return fn
    return _over_shards(lambda *args: jax.lax.pmean(fn(*args), SAMPLES), mesh, in_specs, PartitionSpec())


def _in_chunks(fn: Callable, in_specs, chunk: int) -> Callable:
    """`fn`'s mean over chunks of `chunk` samples, one after another; `fn` itself when `chunk`
    does not divide the samples."""
    axes = [tuple(spec_).index(SAMPLES) if SAMPLES in tuple(spec_) else None for spec_ in in_specs]

    def chunked(*args):
        count = next(args[k].shape[axis] for k, axis in enumerate(axes) if axis is not None)
        if count % chunk or count == chunk:
            return fn(*args)

        def split(x, axis):  # (chunks, chunk, the other axes)
            x = jnp.moveaxis(x, axis, 0)
            return x.reshape((count // chunk, chunk) + x.shape[1:])

        pieces = {k: split(args[k], axis) for k, axis in enumerate(axes) if axis is not None}

        def one(sliced):
            restored = {k: jnp.moveaxis(piece, 0, axes[k]) for k, piece in sliced.items()}
            return fn(*(restored.get(k, arg) for k, arg in enumerate(args)))

        return jnp.mean(jax.lax.map(one, pieces))

    return chunked


def per_sample(fn: Callable, mesh: Mesh | None, in_specs, out_specs=PartitionSpec(SAMPLES)) -> Callable:
    """`fn` on each device's share, its per-sample outputs left sharded along the samples
    (`out_specs`, default the leading axis): nothing is communicated. `fn` itself without a mesh."""
    if mesh is None:
        return fn
    return _over_shards(fn, mesh, in_specs, out_specs)


def to_host(array) -> np.ndarray:
    """`array` as a NumPy array on this host, gathered from every process when it is spread over
    several (each process gets the whole array)."""
    if getattr(array, "is_fully_addressable", True):
        return np.asarray(array)
    from jax.experimental import multihost_utils

    return np.asarray(multihost_utils.process_allgather(array, tiled=True))
