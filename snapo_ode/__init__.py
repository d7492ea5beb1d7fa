"""snapo-ode: Smooth Neural Adjoint Policy Optimization on differentiable simulators.

Importing the package turns on float64 and JAX's persistent compilation cache (see
`snapo_ode.configure`).
"""

from ._config import configure as configure, default_cache_dir as default_cache_dir

CACHE_DIR = configure()

from ._effects import (  # noqa: E402
    EffectCatalogue as EffectCatalogue,
    Scene as Scene,
    count_operations as count_operations,
)
from . import smooth as smooth  # noqa: E402
from ._ode import (  # noqa: E402
    SolverFailed as SolverFailed,
    call_checked as call_checked,
    diffeqsolve_checked as diffeqsolve_checked,
    raise_if_failed as raise_if_failed,
)
from ._rosenbrock import Rodas4 as Rodas4  # noqa: E402
from ._io import (  # noqa: E402
    atomic_write_bytes as atomic_write_bytes,
    atomic_write_json as atomic_write_json,
    atomic_write_text as atomic_write_text,
)
from ._policy import (  # noqa: E402
    MLPPolicy as MLPPolicy,
    load_policy as load_policy,
    save_policy as save_policy,
)
from ._rollout import (  # noqa: E402
    DiscreteStepper as DiscreteStepper,
    RolloutMethod as RolloutMethod,
    rollout as rollout,
)
from ._sensitivity import (  # noqa: E402
    DEFAULT_RELATIVE_STEP as DEFAULT_RELATIVE_STEP,
    BumpComparison as BumpComparison,
    Jacobian as Jacobian,
    bump_and_revalue as bump_and_revalue,
    choose_mode as choose_mode,
    compare_with_bumps as compare_with_bumps,
    flatten_inputs as flatten_inputs,
    jacobian as jacobian,
    max_relative_difference as max_relative_difference,
    value_and_sensitivities as value_and_sensitivities,
)
from ._training import (  # noqa: E402
    TrainingDiverged as TrainingDiverged,
    TrainResult as TrainResult,
    default_optimizer as default_optimizer,
    load_checkpoint as load_checkpoint,
    save_checkpoint as save_checkpoint,
    train as train,
)
from ._timing import Timing as Timing, time_function as time_function  # noqa: E402
from ._validation import (  # noqa: E402
    InputError as InputError,
    check_choice as check_choice,
    check_finite as check_finite,
    check_increasing as check_increasing,
    check_range as check_range,
)
