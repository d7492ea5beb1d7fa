"""The next experiment: candidate kinetic runs ranked by how much they would sharpen the fitted
parameters, D-optimal on the Fisher information: the gain of ln det(F + J_c^T W J_c) over ln det F,
with F the current fit's information (J^T J of its weighted residuals, divided by its scale) and
J_c the candidate's Jacobian at the current estimates, its weights from the error model at the
predicted values. Also each parameter's standard error after the candidate, against now."""

import numpy as np

from snapo_ode import InputError

from ._experiments import ErrorModel, LabData
from ._fit import FitResult, residual_functions
from ._fit_model import experiment_model
from ._fit_synthetic import lab_design


def rank_candidates(chain, data: LabData, result: FitResult, candidates, times: list[float],
                    species: list[str]) -> list[dict]:
    """Each candidate (`Experiment`) sampled at `times` [min] for `species`, ranked best first:
    {name, temperature_K, charges, log_det_gain, standard_errors_after (name -> value),
    standard_error_ratio (after / now, per parameter)}.

    **Raises:** `InputError` for a species the data's error model does not state (its sd would be
    unknown) when the fit's sds were known."""
    missing = [s for s in species if s not in data.error_model]
    if result.sd_known and missing:
        raise InputError(f"--species {missing[0]}: the experiments file's error_model states no sd for it; a candidate's "
                         "weights come from the error model.")
    errors = {s: data.error_model.get(s, ErrorModel(float(np.sqrt(result.scale)), 0.0)) for s in species}
    plan = lab_design(tuple(candidates), list(times), list(species), errors)
    model = experiment_model(chain, plan, result.fitted)
    predicted = np.asarray(model.predict(result.theta))
    sd = np.zeros_like(predicted)
    for name, error in errors.items():
        rows = np.asarray(plan.measurements.species) == name
        sd[rows] = error.sd(np.abs(predicted[rows]))
    _, with_jacobian = residual_functions(model, predicted, sd)
    jacobian = np.asarray(with_jacobian(result.theta)[1])
    information = np.linalg.pinv(result.theta_covariance)
    now = np.linalg.slogdet(information)[1]
    se_now = result.standard_errors
    rows = []
    for e, candidate in enumerate(candidates):
        j = jacobian[plan.measurements.experiment == e]
        after = information + j.T @ j
        covariance = np.linalg.pinv(after)
        _, _, reported = result.fitted.physical(result.theta, covariance, np.zeros(len(result.fitted.reactions)))
        se_after = np.sqrt(np.diag(reported))
        rows.append({"name": candidate.name, "temperature_K": candidate.temperature, "charges": candidate.charges,
                     "log_det_gain": float(np.linalg.slogdet(after)[1] - now),
                     "standard_errors_after": dict(zip(result.names, se_after.tolist())),
                     "standard_error_ratio": dict(zip(result.names, (se_after / se_now).tolist()))})
    return sorted(rows, key=lambda row: -row["log_det_gain"])
