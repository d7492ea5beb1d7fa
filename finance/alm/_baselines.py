"""The fixed mixes a policy is compared with: the fund's strategic mix (where its file names one),
60/40, and liability matching at the liabilities' duration as the simulation values them."""

import numpy as np

from ._liabilities import liability_duration_as_valued
from ._model import indexed_share
from ._policy import AbstractRebalancing, FixedMix, liability_matching, sixty_forty


def liability_duration(study) -> float:
    """The liabilities' duration [years] on the initial curve, as the simulation values them
    (each flow at its own date, the indexed share grown to it when the indexation effect is on):
    -dL/ds / L for a parallel shift s of the key rates (`liability_duration_as_valued`)."""
    problem = study.problem
    return liability_duration_as_valued({**study.fixed, **study.reported}, study.market, problem.schedule,
                                        indexed_share(problem.config, problem.scene))


def baselines(study, strategic_mix: dict | None = None) -> dict[str, AbstractRebalancing]:
    """The fixed-mix policies the trained one is compared with: the fund's `strategic_mix`
    (class -> weight, `Fund.strategic_mix`) first where it has one, then 60/40 and liability
    matching at the liabilities' duration as valued (`liability_duration`)."""
    mixes = {}
    if strategic_mix is not None:
        weights = np.array([strategic_mix[name] for name in study.market.asset_names])
        mixes["strategic_mix"] = FixedMix(weights / weights.sum())  # the file's sum is 1 to 1e-9
    return {**mixes, "sixty_forty": sixty_forty(study.market),
            "liability_matching": liability_matching(study.market, liability_duration(study))}
