"""One storage study end to end: train the policy smooth, evaluate it hard, solve the LP,
and take every sensitivity from one reverse pass (optionally against bump-and-revalue)."""

import pathlib
import time
from typing import Literal

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np

import snapo_ode
from snapo_ode import Settings, check_choice, check_count, time_function, time_once

from ._inputs import StorageInputs, check_positive_prices
from ._lattice_start import basestock_start
from ._lp import solve_intrinsic
from ._model import deterministic_scene, stochastic_scene
from ._paths import PricePaths
from ._policy import DEFAULT_HEAD, POLICY_HEADS, PolicyHead, expected_value, make_policy, simulate
from ._results import StorageStudy, standard_error

PolicyStart = Literal["lattice", "intrinsic"]
POLICY_STARTS = ("lattice", "intrinsic")


# Training settings per head, measured on the Boogert & de Jong contract (docs/gas_storage.md,
# "Policy heads"): the basestock head trains in float32 on 512 fresh paths a step at a larger
# learning rate; like the action heads it trains on the smooth model (its value is also
# continuous in its targets on the exact model, which trains it as well: hard_training).
HEAD_TRAINING = {
    "basestock": dict(train_paths=512, train_steps=800, learning_rate=3e-2, sharpness=200.0, hard_training=False,
                      train_float32=True),
    "fraction": dict(train_paths=256, train_steps=1500, learning_rate=1e-2, sharpness=200.0, hard_training=False,
                     train_float32=False),
    "split": dict(train_paths=256, train_steps=1500, learning_rate=1e-2, sharpness=200.0, hard_training=False,
                  train_float32=False),
}
# Started on the lattice's targets (stochastic basestock), the policy is near the optimum: a smaller
# step keeps it there, and a sharper smoothing makes the smooth value the hard one's near the
# ratchets (measured on family cases: docs/gas_storage.md, Where the policy starts).
LATTICE_START_TRAINING = dict(learning_rate=3e-3, sharpness=1000.0)


class StudySettings(Settings):
    """**Fields:** `stochastic` (trade on simulated spot paths); `paths` (Monte Carlo paths of
    the evaluation, drawn fresh, common to the value, the adjoint and the bumps); `head` (of the
    policy, see `make_policy`; `split_actions=True` is `head="split"`) and `width`; `start`
    (where the basestock head starts on a random spot: `"lattice"`, the targets of the factor
    lattice's value, `_lattice_start.py`, with `LATTICE_START_TRAINING`'s defaults; or
    `"intrinsic"`, the intrinsic schedule; at zero volatility it is always the intrinsic);
    `train_paths` (paths drawn anew at every training step); `seed`; `train_steps`;
    `learning_rate`; `sharpness` (dimensionless smoothing sharpness of the smooth value; gaps
    are about log(2)/sharpness of a day's maximum flow); `hard_training` (train and take the
    sensitivities on the exact model, as the basestock head does); `train_float32` (training
    passes in float32; evaluation and sensitivities stay float64); the training fields left None
    take the head's measured defaults (`HEAD_TRAINING`); `deltas_only` (the reverse pass
    differentiates the forward curve only, not the facility's parameters: a smaller program);
    `bump` (also run central bump-and-revalue on the 365 deltas); `repeats` (timed runs per
    median after a warm-up run; None: 5 in deterministic mode, where a pass takes milliseconds,
    1 in stochastic mode, where it takes seconds); `progress` (show a progress bar); `checkpoint_path` and `resume` (of the training,
    see `snapo_ode.train`). Defaults that depend on other fields are filled when the settings are
    built: `replace(head=...)` or `replace(stochastic=...)` keeps them; build new settings to get
    the other head's or mode's defaults."""

    stochastic: bool = eqx.field(static=True, default=False)
    paths: int = eqx.field(static=True, default=1000)
    head: PolicyHead = eqx.field(static=True, default=DEFAULT_HEAD)
    split_actions: bool = eqx.field(static=True, default=False)
    train_paths: int | None = eqx.field(static=True, default=None)
    seed: int = eqx.field(static=True, default=0)
    train_steps: int | None = eqx.field(static=True, default=None)
    learning_rate: float | None = eqx.field(static=True, default=None)
    sharpness: float | None = eqx.field(static=True, default=None)
    hard_training: bool | None = eqx.field(static=True, default=None)
    train_float32: bool | None = eqx.field(static=True, default=None)
    width: int = eqx.field(static=True, default=32)
    start: PolicyStart = eqx.field(static=True, default="lattice")
    deltas_only: bool = eqx.field(static=True, default=False)
    bump: bool = eqx.field(static=True, default=False)
    repeats: int | None = eqx.field(static=True, default=None)
    progress: bool = eqx.field(static=True, default=True)
    checkpoint_path: pathlib.Path | None = eqx.field(static=True, default=None)
    resume: bool = eqx.field(static=True, default=False)

    def __post_init__(self):
        if self.split_actions:
            if self.head not in (DEFAULT_HEAD, "split"):
                raise snapo_ode.InputError(f"split_actions = True with head = {self.head!r}: split_actions means "
                                           "head = 'split'; give one of them.")
            self.head = "split"
        check_choice("head", self.head, POLICY_HEADS)
        check_choice("start", self.start, POLICY_STARTS)
        defaults = HEAD_TRAINING[self.head]
        if self.starts_on_lattice:
            defaults = {**defaults, **LATTICE_START_TRAINING}
        for name, default in defaults.items():
            if getattr(self, name) is None:
                setattr(self, name, default)
        if self.repeats is None:
            self.repeats = 1 if self.stochastic else 5

    def __check_init__(self):
        check_count("paths", self.paths, 2, 10_000_000)
        check_count("train_paths", self.train_paths, 1, 10_000_000)
        check_count("train_steps", self.train_steps, 1, 10_000_000)
        snapo_ode.check_range("learning_rate", self.learning_rate, 0.0, 1.0, low_open=True)
        snapo_ode.check_range("sharpness", self.sharpness, 0.0, 1e8, low_open=True)
        check_count("repeats", self.repeats)
        check_count("width", self.width, 1, 4096)

    @property
    def starts_on_lattice(self) -> bool:
        """Whether the policy starts on the factor lattice's targets (a stochastic basestock study
        with `start="lattice"`; `run_study` also needs a non-zero volatility)."""
        return self.stochastic and self.head == "basestock" and self.start == "lattice"

    @property
    def training(self) -> tuple:
        """The fields that define the training (its checkpoint's fingerprint): not the evaluation's."""
        return (self.stochastic, self.head, self.width, self.train_paths, self.seed, self.train_steps,
                self.learning_rate, self.sharpness, self.hard_training, self.train_float32, self.start)

    @property
    def training_sharpness(self) -> float | None:
        """The sharpness of training and of the sensitivities: None (exact) with `hard_training`."""
        return None if self.hard_training else self.sharpness


def memory_estimate(n_days: int, settings: StudySettings) -> float:
    """Peak bytes of a study: per simulated path and day about 16 float64 numbers live at once in
    a reverse pass (shocks, prices, the factor, the carried state and the schedule); the batched
    bumps simulate up to 65,536 paths at once; plus ~0.5 GiB for JAX itself."""
    paths = max(settings.paths, settings.train_paths) if settings.stochastic else 1
    if settings.bump:
        paths = max(paths, min(65_536, 2 * n_days * paths))
    return 0.5 * 1024**3 + 8.0 * 16 * paths * n_days


def check_size(n_days: int, settings: StudySettings) -> None:
    """Refuse, before any allocation, a study that would not fit in memory (`memory_estimate`)."""
    snapo_ode.check_memory(f"the storage study with {settings.paths if settings.stochastic else 1} paths x "
                           f"{n_days} days", memory_estimate(n_days, settings), "use fewer paths (--paths, "
                           "--train-paths) or a shorter curve.")


def constraint_violation(schedule, inputs: StorageInputs, kept: float) -> float:
    """The largest violation of any hard constraint by a schedule, in MMBtu (0 if none)."""
    inventory = np.asarray(schedule.inventory)
    injection, withdrawal = np.asarray(schedule.injection), np.asarray(schedule.withdrawal)
    capacity = float(inputs.capacity)
    fill = inventory[..., :-1] / capacity
    max_in = float(inputs.max_injection) * np.interp(fill, *np.asarray(inputs.injection_ratchet).T)
    max_out = float(inputs.max_withdrawal) * np.interp(fill, *np.asarray(inputs.withdrawal_ratchet).T)
    balance = inventory[..., 1:] - inventory[..., :-1] - kept * injection + withdrawal
    violations = [
        -inventory, inventory - capacity, -injection, -withdrawal,
        injection - max_in, withdrawal - max_out, np.abs(balance),
        float(inputs.terminal_inventory_min) - inventory[..., -1:],
    ]
    return max(0.0, max(float(np.max(v)) for v in violations))


def named_sensitivities(gradient: StorageInputs) -> dict[str, float]:
    """d value / d every scalar input by name (ratchet entries as `table[row][col]`), the
    forward curve left out (it is reported as `deltas`)."""
    named = {}
    for field, value in vars(gradient).items():
        if field == "forward_curve" or value is None:
            continue
        array = np.asarray(value)
        if array.ndim == 0:
            named[field] = float(array)
        else:
            for (i, j), entry in np.ndenumerate(array):
                named[f"{field}[{i}][{j}]"] = float(entry)
    return named


def evaluation_shocks(settings: StudySettings, n_days: int) -> jax.Array:
    """The normal shocks of the evaluation paths, shape (paths, T): fresh, never trained on, and
    the same for every method valued on them (LSMC included)."""
    _, _, eval_key = jax.random.split(jax.random.key(settings.seed), 3)
    return jax.random.normal(eval_key, (settings.paths, n_days))


def run_study(inputs: StorageInputs, settings: StudySettings, *, training_paths: PricePaths | None = None,
              evaluation_paths: PricePaths | None = None) -> StorageStudy:
    """Train, evaluate, compare with the LP, and compute sensitivities. Returns the typed result
    (JSON keys documented in docs/gas_storage.md), which carries the trained policy, the
    evaluation shocks and the hard schedule of every evaluation path. `training_paths`,
    `evaluation_paths` (a desk's own paths, `_path_files.py`): each training step samples
    `train_paths` of the first (with replacement) instead of drawing fresh shocks; the policy is
    valued on the second instead of `settings.paths` fresh paths."""
    if settings.stochastic:
        check_positive_prices(inputs)
    check_size(inputs.n_days, settings)
    scene = stochastic_scene() if settings.stochastic else deterministic_scene()
    key = jax.random.key(settings.seed)
    policy_key, train_key, _ = jax.random.split(key, 3)
    eval_shocks = None
    spot_scale = 1.0
    if settings.stochastic:
        eval_shocks = evaluation_shocks(settings, inputs.n_days) if evaluation_paths is None else evaluation_paths
        kappa = max(float(inputs.mean_reversion), 1e-6)
        spot_scale = max(float(inputs.volatility) / np.sqrt(2 * kappa), 1e-3)
    intrinsic = solve_intrinsic(inputs, deterministic_scene())
    start_seconds, targets = 0.0, None
    if settings.starts_on_lattice and inputs.volatility > 0:
        start_seconds, targets = time_once(basestock_start, inputs, scene)
    policy = make_policy(scene, inputs, key=policy_key, spot_scale=spot_scale, head=settings.head,
                         width=settings.width, intrinsic_inventory=intrinsic.inventory, start=targets)
    scale = float(inputs.capacity * jnp.mean(jnp.abs(inputs.forward_curve)))
    sharpness = settings.training_sharpness
    train_dtype = jnp.float32 if settings.train_float32 else jnp.float64

    def cast(tree):
        return jax.tree.map(lambda leaf: leaf.astype(train_dtype) if eqx.is_inexact_array(leaf) else leaf, tree)

    def loss(policy, *step_key):
        shocks = None
        if settings.stochastic and training_paths is not None:
            rows = jax.random.randint(step_key[0], (settings.train_paths,), 0, training_paths.shape[0])
            shocks = cast(training_paths[rows])
        elif settings.stochastic:
            shocks = jax.random.normal(step_key[0], (settings.train_paths, inputs.n_days), train_dtype)
        value = expected_value(cast(policy), cast(inputs), scene, sharpness=sharpness, shocks=shocks)
        return -value / scale, {"value": value}

    start = time.perf_counter()
    trained = snapo_ode.train(loss, policy, steps=settings.train_steps, learning_rate=settings.learning_rate,
                              key=train_key if settings.stochastic else None,
                              progress=settings.progress, description="training storage policy",
                              checkpoint_path=settings.checkpoint_path, checkpoint_every=50, resume=settings.resume,
                              keep_best=not settings.stochastic,  # with fresh paths each step, the best is a lucky batch
                              fingerprint={"inputs": inputs, "effects": sorted(scene.active),
                                           "settings": settings.training})
    train_wall = time.perf_counter() - start + start_seconds  # the policy's start is part of its training
    untrained, policy = policy, trained.params

    # The evaluation shocks are arguments, not closed-over constants: XLA would fold a constant
    # array of 10,000 paths through the price model at compile time, a long compile.
    @eqx.filter_jit
    def evaluate(policy, inputs, shocks, sharpness_is_hard: bool):
        return simulate(policy, inputs, scene, sharpness=None if sharpness_is_hard else settings.sharpness,
                        shocks=shocks)

    smooth_run = evaluate(policy, inputs, eval_shocks, False)
    hard_run = evaluate(policy, inputs, eval_shocks, True)
    start_value_hard = None if targets is None else float(jnp.mean(evaluate(untrained, inputs, eval_shocks,
                                                                             True).value))
    kept = 1.0 - float(inputs.fuel_loss)

    @eqx.filter_jit
    def smooth_value(policy, inputs, shocks):
        return expected_value(policy, inputs, scene, sharpness=sharpness, shocks=shocks)

    @eqx.filter_jit
    def value_and_gradient_of_both(both, shocks):
        if settings.deltas_only:
            value, deltas = jax.value_and_grad(
                lambda curve: smooth_value(both[0], eqx.tree_at(lambda i: i.forward_curve, both[1], curve), shocks))(
                both[1].forward_curve)
            no_sensitivities = jax.tree.map(lambda _: None, both[1])
            return value, (None, eqx.tree_at(lambda i: i.forward_curve, no_sensitivities, deltas,
                                             is_leaf=lambda leaf: leaf is None))
        return snapo_ode.value_and_sensitivities(lambda both: smooth_value(*both, shocks), both)

    forward_timing, _ = time_function(smooth_value, policy, inputs, eval_shocks, repeats=settings.repeats)
    gradient_timing, (_, (_, gradient)) = time_function(value_and_gradient_of_both, (policy, inputs),
                                                            eval_shocks, repeats=settings.repeats)
    deltas = np.asarray(gradient.forward_curve)
    value_hard = float(np.mean(hard_run.value))
    value_smooth = float(np.mean(smooth_run.value))
    stochastic = {}
    if settings.stochastic:
        stochastic = dict(paths=eval_shocks.shape[0], train_paths=settings.train_paths,
                          value_hard_se=standard_error(hard_run.value), value_smooth_se=standard_error(smooth_run.value),
                          evaluation="out of sample: fresh paths, not those trained on",
                          schedule_note="schedule entries are means over the evaluation paths")
    bump = None
    if settings.bump:
        # Bumps of the forward curve only, chunked to about 65,536 simulated paths a batch; the
        # adjoint is the one reverse pass above, with respect to everything.
        paths = settings.paths if settings.stochastic else 1
        batch_size = max(1, 65_536 // paths)
        bump = snapo_ode.compare_with_bumps(
            lambda both: smooth_value(*both, eval_shocks), (policy, inputs), select=lambda both: both[1].forward_curve,
            adjoint_fn=lambda both: value_and_gradient_of_both(both, eval_shocks), batch_size=batch_size if batch_size < 2 * deltas.size else None,
            floor=1e-3, repeats=settings.repeats, bump_repeats=1, sequential=True)
    return StorageStudy(
        mode="stochastic" if settings.stochastic else "deterministic",
        scene=sorted(scene.active),
        value_hard=value_hard,
        value_smooth=value_smooth,
        smoothing_gap=value_smooth - value_hard,
        intrinsic_lp=intrinsic.value,
        intrinsic_method=intrinsic.method,
        hard_to_lp_ratio=value_hard / intrinsic.value if intrinsic.value else None,
        max_constraint_violation=constraint_violation(hard_run, inputs, kept),
        capacity=float(inputs.capacity),
        schedule={
            "injection": np.asarray(hard_run.injection).reshape(-1, inputs.n_days).mean(0).tolist(),
            "withdrawal": np.asarray(hard_run.withdrawal).reshape(-1, inputs.n_days).mean(0).tolist(),
            "inventory": np.asarray(hard_run.inventory).reshape(-1, inputs.n_days + 1).mean(0).tolist(),
        },
        deltas=deltas.tolist(),
        lp_envelope_deltas=intrinsic.deltas.tolist(),
        parameter_sensitivities=named_sensitivities(gradient),
        train_seconds=trained.seconds,
        train_wall_seconds=train_wall,
        train_steps=trained.steps_run,
        compile_seconds=trained.compile_seconds + forward_timing.compile_seconds + gradient_timing.compile_seconds,
        compile_breakdown={"train_step": trained.compile_seconds, "forward": forward_timing.compile_seconds,
                           "gradient": gradient_timing.compile_seconds},
        forward_seconds=forward_timing.median_seconds,
        gradient_seconds=gradient_timing.median_seconds,
        gradient_forward_ratio=gradient_timing.median_seconds / forward_timing.median_seconds,
        training_history={"loss": trained.history["loss"], "value": trained.history["value"]},
        training_curve=trained.history["value"], head=settings.head,
        training_settings=dict(train_paths=settings.train_paths, train_steps=settings.train_steps,
                               learning_rate=settings.learning_rate, sharpness=sharpness,
                               train_float32=settings.train_float32, keep="best" if not settings.stochastic else "last"),
        start="lattice" if targets is not None else "intrinsic", start_seconds=start_seconds,
        start_value_hard=start_value_hard, policy=policy, inputs=inputs, scene_effects=scene, evaluation_shocks=eval_shocks, hard=hard_run,
        intrinsic=intrinsic, bump=bump, bump_relative_step=snapo_ode.DEFAULT_RELATIVE_STEP if bump else None,
        seed=settings.seed,  # the policy's initial parameters depend on it in either mode
        **stochastic,
    )
