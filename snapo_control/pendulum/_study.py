"""The pendulum study of `snapo pendulum`: train with the periodic treatment and without it, and
evaluate both on Gymnasium's own Pendulum-v1. Inputs are validated before anything is traced."""

import os
import pathlib

import jax
import numpy as np

from snapo_ode import check_count, save_policy

from ._gymnasium import gymnasium_returns, require_gymnasium
from ._model import Pendulum
from ._results import PendulumStudy
from ._training import TrainingSettings, train_policy


def run_pendulum(train_steps: int | None = None, *, eval_episodes: int = 100, eval_seed: int = 0, seed: int = 0,
                 settings: TrainingSettings | None = None, without_periodic: bool = True,
                 policy_path: str | os.PathLike | None = None, progress: bool = True) -> PendulumStudy:
    """Train a policy on `Pendulum()` (`settings`, with `train_steps` steps if given), evaluate it
    on `eval_episodes` Gymnasium episodes from `eval_seed`, and the same without the periodic
    treatment (unless `without_periodic=False`); save the policy to `policy_path` if given.

    **Raises:** `InputError` naming a bad count or setting; `ImportError` without gymnasium.
    """
    settings = settings or TrainingSettings()
    if train_steps is not None:
        settings = settings.replace(steps=train_steps)
    check_count("eval_episodes", eval_episodes)
    check_count("eval_seed", eval_seed, low=0)
    check_count("seed", seed, low=0)
    require_gymnasium()
    pendulum = Pendulum()
    key = jax.random.key(seed)

    policy, trained = train_policy(pendulum, settings, key, progress=progress)
    load_average = list(os.getloadavg())
    returns = gymnasium_returns(policy, eval_episodes, eval_seed)
    baseline = {}
    if without_periodic:
        plain, plain_trained = train_policy(pendulum, settings.replace(periodic=False), key, progress=progress)
        plain_returns = gymnasium_returns(plain, eval_episodes, eval_seed, periodic=False)
        baseline = dict(mean_return_without_periodic=float(np.mean(plain_returns)),
                        std_return_without_periodic=float(np.std(plain_returns)),
                        train_seconds_without_periodic=plain_trained.seconds,
                        returns_without_periodic=plain_returns.tolist(),
                        learning_curve_without_periodic=plain_trained.history["value"],
                        policy_without_periodic=plain)
    else:
        baseline = dict.fromkeys(("mean_return_without_periodic", "std_return_without_periodic",
                                  "train_seconds_without_periodic", "returns_without_periodic",
                                  "learning_curve_without_periodic"))
    if policy_path is not None:
        policy_path = pathlib.Path(policy_path)
        save_policy(policy_path, policy)
    return PendulumStudy(
        mean_return=float(np.mean(returns)), std_return=float(np.std(returns)), episodes=eval_episodes,
        eval_seed=eval_seed, train_seconds=trained.seconds, compile_seconds=trained.compile_seconds,
        train_steps=trained.steps_run, settings=settings.as_dict(), load_average=load_average,
        cpu_count=os.cpu_count() or 1, policy_path=None if policy_path is None else str(policy_path),
        returns=returns.tolist(), learning_curve=trained.history["value"], policy=policy, **baseline)
