"""Policy training: an optax loop with progress, early stopping, a NaN guard, and atomic
checkpoints of the whole training state from which an interrupted run resumes exactly."""

import math
import os
import pathlib
import time
from collections.abc import Callable
from typing import Any, NamedTuple

import equinox as eqx
import jax
import jax.numpy as jnp
import optax
from tqdm.auto import tqdm

from ._checkpoint import check_same_run, load_checkpoint, save_checkpoint
from ._fingerprint import run_fingerprint
from ._platform.validation import InputError


class TrainingDiverged(FloatingPointError):
    """The loss became NaN or infinite. `step` is the step that produced it; `params` are the
    best parameters seen before it, so nothing trained so far is lost."""

    def __init__(self, message: str, step: int, params):
        super().__init__(message)
        self.step = step
        self.params = params


class TrainResult(NamedTuple):
    """`params`: the parameters with the best loss seen; `history`: per step, the loss and every
    metric; `steps_run`; `stopped_early`; `best_loss`; `seconds`: wall time of all steps after
    the first; `compile_seconds`: the first step's time minus a typical step's."""

    params: Any
    history: dict[str, list[float]]
    steps_run: int
    stopped_early: bool
    best_loss: float
    seconds: float
    compile_seconds: float


def default_optimizer(learning_rate: float, steps: int, clip_norm: float) -> optax.GradientTransformation:
    """Adam on a warm-up-cosine schedule (5% warm-up, decay to 1% of the peak), after clipping
    the global gradient norm."""
    schedule = optax.warmup_cosine_decay_schedule(
        init_value=learning_rate / 10,
        peak_value=learning_rate,
        warmup_steps=max(1, steps // 20),
        decay_steps=max(2, steps),
        end_value=learning_rate / 100,
    )
    return optax.chain(optax.clip_by_global_norm(clip_norm), optax.adam(schedule))


def train(
    loss_fn: Callable,
    params,
    *,
    steps: int,
    optimizer: optax.GradientTransformation | None = None,
    learning_rate: float = 1e-2,
    clip_norm: float = 1.0,
    key=None,
    patience: int | None = None,
    min_delta: float = 0.0,
    checkpoint_path: str | os.PathLike | None = None,
    checkpoint_every: int = 100,
    resume: bool = False,
    callback: Callable | None = None,
    progress: bool = True,
    description: str = "training",
    pass_step: bool = False,
    keep_best: bool = True,
    fingerprint: dict | None = None,
    data=None,
) -> TrainResult:
    """Minimise `loss_fn` over the inexact array leaves of `params`.

    **Arguments:**
    - `loss_fn`: `loss_fn(params) -> (loss, metrics)` with `metrics` a dict of scalars (a
      `"value"` entry is shown in the progress bar); with `key`, `loss_fn(params, key)` gets a
      fresh key each step (`jax.random.fold_in(key, step)`), e.g. to draw new Monte Carlo paths.
    - `pass_step`: also pass the step number (0-based, a traced integer, so nothing recompiles),
      last: `loss_fn(params, [key,] step)`, for a curriculum (a horizon, a sharpness, a gradient
      decay that changes over the training).
    - `data`: a pytree passed to `loss_fn` as its last argument, `loss_fn(params, [key,] [step,]
      data)`: the arrays the loss reads (training paths, scenarios) enter the compiled step as
      arguments. Arrays the loss closes over are baked into the program as constants instead,
      which makes a large data set's first compile slow and its cache entry as large
      (docs/dev/gas_storage_notes.md, "The 60-second row"). Part of the run's fingerprint.
    - `keep_best`: return (and checkpoint) the parameters with the lowest loss seen; `False`: the
      parameters after the last step (on divergence, the last ones with a finite loss). When
      every step draws a fresh random batch, the lowest batch loss marks a lucky batch more than
      the best parameters.
    - `steps`: the maximum number of steps.
    - `optimizer`: any `optax.GradientTransformation` (default: `default_optimizer`).
    - `patience`, `min_delta`: stop when the loss has not improved by `min_delta` for
      `patience` steps.
    - `checkpoint_path`: where the whole training state (parameters, optimizer state, best
      parameters, history) is written atomically every `checkpoint_every` steps, when the run is
      interrupted or fails, and at the end.
    - `resume`: continue from `checkpoint_path` when it exists; the resumed run gives the same
      result as one that was never interrupted (same steps, same keys).
    - `fingerprint`: what defines the run besides the arguments here (name -> value: the inputs,
      the settings, the model; see `run_fingerprint`). The checkpoint records it with the
      initial `params`, `steps`, `learning_rate`, `clip_norm`, `key`, `patience`, `min_delta`,
      `keep_best`, `pass_step` and the package versions, and `resume` refuses a checkpoint whose
      record differs, naming what differs. (A custom `optimizer` is not recorded: put its
      settings in `fingerprint`.)
    - `callback(step, loss, metrics)`: called after every step (raising in it interrupts the run,
      which still writes its checkpoint).

    The result is deterministic for given inputs and key.

    **Raises:** `TrainingDiverged` naming the step whose loss was not finite; `InputError` for a
    checkpoint of another run (a different fingerprint) or an unreadable one.
    """
    if not isinstance(steps, int) or steps < 1:
        raise InputError(f"steps = {steps!r} must be a positive integer.")
    if patience is not None and patience < 1:
        raise InputError(f"patience = {patience!r} must be a positive integer or None.")
    optimizer = optimizer or default_optimizer(learning_rate, steps, clip_norm)
    opt_state = optimizer.init(eqx.filter(params, eqx.is_inexact_array))
    best_params = params
    # Only a checkpoint records the run (digesting large `data` takes a second).
    run = None if checkpoint_path is None else run_fingerprint({
        **(fingerprint or {}), "initial parameters": eqx.filter(params, eqx.is_array),
        **({} if data is None else {"data": data}),
        "training settings": (steps, learning_rate, clip_norm, patience, min_delta, keep_best, pass_step,
                              optimizer is None), "key": key})
    info = {"next_step": 0, "steps": steps, "history": {"loss": []}, "best_loss": None, "since_best": 0,
            "stopped_early": False, "fingerprint": run}
    if resume and checkpoint_path is not None and pathlib.Path(checkpoint_path).exists():
        best_params, saved, (params, opt_state) = load_checkpoint(checkpoint_path, params, (params, opt_state))
        check_same_run(checkpoint_path, saved, run)
        info = saved

    @eqx.filter_jit
    def update(params, opt_state, data, *key_args):
        data_args = () if data is None else (data,)
        (loss, metrics), grads = eqx.filter_value_and_grad(loss_fn, has_aux=True)(params, *key_args, *data_args)
        updates, opt_state = optimizer.update(grads, opt_state, eqx.filter(params, eqx.is_inexact_array))
        return eqx.apply_updates(params, updates), opt_state, loss, metrics

    history = info["history"]
    best_loss = math.inf if info["best_loss"] is None else info["best_loss"]
    since_best, stopped_early = info["since_best"], info["stopped_early"]
    finite_params = params  # the last parameters whose loss was finite

    def kept():
        return best_params if keep_best else params
    step_times: list[float] = []
    first = info["next_step"]

    def checkpoint(next_step: int) -> None:
        if checkpoint_path is not None:
            save_checkpoint(checkpoint_path, kept(), {
                "next_step": next_step, "steps": steps, "history": history,
                "best_loss": None if math.isinf(best_loss) else best_loss, "since_best": since_best,
                "stopped_early": stopped_early, "fingerprint": run}, (params, opt_state))

    bar = tqdm(total=steps, initial=first, desc=description, disable=not progress, leave=False)
    try:
        for step in range(first, first if stopped_early else steps):
            key_args = () if key is None else (jax.random.fold_in(key, step),)
            if pass_step:
                key_args += (jnp.asarray(step, jnp.int32),)
            start = time.perf_counter()
            new_params, new_opt_state, loss, metrics = update(params, opt_state, data, *key_args)
            loss = float(loss)
            step_times.append(time.perf_counter() - start)
            if not math.isfinite(loss):
                raise TrainingDiverged(
                    f"{description}: the loss became {loss} at step {step} (last finite loss "
                    f"{history['loss'][-1] if history['loss'] else 'none'}); lower the learning "
                    "rate or the smoothing sharpness, or check the inputs.",
                    step,
                    best_params if keep_best else finite_params,
                )
            history["loss"].append(loss)
            for name, value in metrics.items():
                history.setdefault(name, []).append(float(value))
            if loss < best_loss - min_delta:
                best_loss, best_params, since_best = loss, params, 0
            else:
                since_best += 1
            finite_params, params, opt_state = params, new_params, new_opt_state
            bar.update(1)
            postfix = {"loss": f"{loss:.6g}"}
            if "value" in metrics:
                postfix["value"] = f"{float(metrics['value']):.6g}"
            bar.set_postfix(postfix, refresh=False)
            stopped_early = patience is not None and since_best >= patience
            if (step + 1) % checkpoint_every == 0:
                checkpoint(step + 1)
            if callback is not None:
                callback(step, loss, metrics)
            if stopped_early:
                break
    except BaseException:
        # Interrupted (Ctrl-C, a failed step, a diverged loss): keep every completed step.
        checkpoint(len(history["loss"]))
        raise
    finally:
        bar.close()
    checkpoint(len(history["loss"]))
    typical = sorted(step_times[1:])[len(step_times[1:]) // 2] if len(step_times) > 1 else 0.0
    return TrainResult(
        params=kept(),
        history=history,
        steps_run=len(history["loss"]),
        stopped_early=stopped_early,
        best_loss=best_loss,
        seconds=sum(step_times[1:]),
        compile_seconds=max(step_times[0] - typical, 0.0) if step_times else 0.0,
    )
