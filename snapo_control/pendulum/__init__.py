"""Gymnasium's Pendulum-v1 on snapo_ode: the model in JAX with the angle as a periodic state
component, training by backpropagation through whole episodes, and evaluation on Gymnasium's own
environment.

Layers: `_model` (constants, step, reset, features) -> `_training` (rollouts, the training loop) ->
`_gymnasium` (evaluation on Gymnasium) -> `_results`, `_study` -> `_cli`. See docs/pendulum.md.
Public names load on first use (see `snapo_ode.lazy_exports`).
"""

from snapo_ode import lazy_exports

__getattr__, __dir__, __all__ = lazy_exports(__name__, {
    "._gymnasium": ("ENV_ID", "gymnasium_returns", "require_gymnasium"),
    "._model": ("PERIODIC", "STATE", "TAU", "Pendulum", "features", "features_from_observation"),
    "._results": ("PendulumStudy",),
    "._study": ("run_pendulum",),
    "._training": ("TrainingSettings", "episode_costs", "new_policy", "torque", "train_policy"),
})
