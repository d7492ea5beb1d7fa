"""chemistry.pharma: a 4-unit API manufacturing chain (R1 synthesis, R2 hold, cooling
crystallizer, filter-dryer) as stiff Diffrax solves, its ICH Q8 sensitivities (every CQA to every
CPP and to every kinetic and physical parameter), design space and report."""

from ._chain import (
    DEFAULT_MECHANISM as DEFAULT_MECHANISM,
    PHARMA_EFFECTS as PHARMA_EFFECTS,
    ChainResult as ChainResult,
    PharmaChain as PharmaChain,
)
from ._cqa import (
    cqa_dict as cqa_dict,
    cqa_vector as cqa_vector,
    meets_specs as meets_specs,
    spec_margins as spec_margins,
    spec_penalty as spec_penalty,
)
from ._parameters import (
    CPP_NAMES as CPP_NAMES,
    CPP_RANGES as CPP_RANGES,
    CQA_NAMES as CQA_NAMES,
    CQA_SPECS as CQA_SPECS,
    MOLAR_MASSES as MOLAR_MASSES,
    PHYSICAL_NAMES as PHYSICAL_NAMES,
    CPPs as CPPs,
    ParameterRange as ParameterRange,
    PhysicalParameters as PhysicalParameters,
    Specification as Specification,
    default_physical_parameters as default_physical_parameters,
    make_cpps as make_cpps,
    outside_par as outside_par,
)
from ._profiles import (
    AbstractTemperatureProfile as AbstractTemperatureProfile,
    ConstantTemperature as ConstantTemperature,
    LinearRamp as LinearRamp,
    NeuralTemperature as NeuralTemperature,
)
from ._solver import ChainSolver as ChainSolver
