"""The typed result of `snapo pendulum` (JSON keys documented in docs/pendulum.md)."""

import dataclasses

from snapo_ode import MLPPolicy, Result, field


@dataclasses.dataclass(frozen=True, kw_only=True)
class PendulumStudy(Result):
    """A policy trained by backpropagation through our Pendulum-v1, evaluated on Gymnasium's.

    - `mean_return`, `std_return`, `returns`: over `episodes` Gymnasium episodes from `eval_seed`.
    - `train_seconds`: wall time of the training steps after the first; `compile_seconds`: the
      first step's time less a typical step's (the project's timing convention).
    - `*_without_periodic`: the same training and evaluation without the periodic treatment of
      the angle (None when it was not run).
    - `learning_curve`: per training step, the batch's mean smooth episode return.
    - `load_average`: the machine's 1, 5 and 15 minute load averages after training, and
      `cpu_count`, since the wall times depend on them.
    - `policy_path`: where the policy was saved (`snapo_ode.load_policy`), or None.
    """

    mean_return: float
    std_return: float
    episodes: int
    eval_seed: int
    train_seconds: float
    compile_seconds: float
    train_steps: int
    mean_return_without_periodic: float | None
    std_return_without_periodic: float | None
    train_seconds_without_periodic: float | None
    settings: dict
    load_average: list
    cpu_count: int
    policy_path: str | None
    returns: list
    returns_without_periodic: list | None
    learning_curve: list
    learning_curve_without_periodic: list | None
    policy: MLPPolicy = field(json=False)
    policy_without_periodic: MLPPolicy | None = field(json=False, default=None)

    def summary(self) -> str:
        lines = [f"Pendulum-v1 on Gymnasium, {self.episodes} episodes from seed {self.eval_seed}: mean return "
                 f"{self.mean_return:.1f} +- {self.std_return:.1f}",
                 f"  trained {self.train_steps} steps in {self.train_seconds:.1f} s (+ {self.compile_seconds:.1f} s "
                 f"compile), load average {self.load_average[0]:.1f} on {self.cpu_count} cores"]
        if self.mean_return_without_periodic is not None:
            lines.append(f"  without the periodic treatment: {self.mean_return_without_periodic:.1f} +- "
                         f"{self.std_return_without_periodic:.1f}")
        return "\n".join(lines)
