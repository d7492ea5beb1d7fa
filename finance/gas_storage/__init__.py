"""Natural-gas storage: the intrinsic LP, a neural inject/withdraw policy trained with smooth
constraints, and all forward-curve deltas from one reverse pass."""

from ._inputs import (
    FACILITY_FIELDS as FACILITY_FIELDS,
    StorageInputs as StorageInputs,
    load_curve as load_curve,
    load_facility as load_facility,
    make_inputs as make_inputs,
    sample_curve as sample_curve,
    sample_facility as sample_facility,
)
from ._lp import IntrinsicSolution as IntrinsicSolution, solve_intrinsic as solve_intrinsic
from ._model import (
    GAS_EFFECTS as GAS_EFFECTS,
    Schedule as Schedule,
    deterministic_scene as deterministic_scene,
    expected_value as expected_value,
    inventory_floor as inventory_floor,
    make_policy as make_policy,
    simulate as simulate,
    stochastic_scene as stochastic_scene,
)
